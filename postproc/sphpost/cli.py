"""sphpost.cli: the command line.

`sphpost TOOL ARGS...` (the entry point pip installs), `python3 -m sphpost
TOOL ARGS...` and the scripts postproc/TOOL run the same tool with the same
arguments, output and exit status.  Each tool is a module with a main():
errors, filter, convergence, plots, validate and reference.  Here: the
dispatcher, the guard that turns a PostprocError into a one-line message,
and where the sph repository is, for the tools that run the solver.
"""
import argparse
import importlib
import os
import sys

from .exceptions import PostprocError

TOOLS = ("errors", "filter", "convergence", "plots", "validate", "reference")


def main_guard(prog, fn, argv):
    """Runs fn(argv); turns a PostprocError into a one-line message on stderr
    and exit status 2."""
    try:
        return fn(argv)
    except PostprocError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2


def is_repository(path):
    """Whether path is the root of an sph source tree (its Makefile, src/ and
    input/circle2d.nml)."""
    return all(os.path.exists(os.path.join(path, p))
               for p in ("Makefile", "src", os.path.join("input", "circle2d.nml")))


def repository_root():
    """The sph repository the tools that run the solver work in: the one
    this package sits in (postproc/sphpost of a checkout), else the current
    directory or the nearest of its parents that is one, else the current
    directory (require_repository then says what is missing)."""
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    if is_repository(here):
        return here
    d = os.getcwd()
    while True:
        if is_repository(d):
            return d
        up = os.path.dirname(d)
        if up == d:
            return os.getcwd()
        d = up


def require_repository(root, tool):
    """Raises PostprocError unless root is an sph repository."""
    if not is_repository(root):
        raise PostprocError(
            f"{tool} runs the solver on the repository's input files: '{root}' is not an sph "
            "repository (no Makefile, src/ and input/circle2d.nml); run it from the "
            "repository's directory (or one below it)")


def tool(name):
    """The module of a tool, imported when asked for: one tool's start does
    not pay for the others' imports."""
    return importlib.import_module(f"{__package__}.{name}")


def main(argv=None, prog=None):
    """sphpost TOOL ARGS...: runs a post-processing tool."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if prog is None:
        prog = "sphpost"
    # the tool parses its own arguments (--help included): a subparser here
    # would have to repeat them
    if argv and argv[0] in TOOLS:
        return tool(argv[0]).main(argv[1:], prog=f"{prog} {argv[0]}")
    ap = argparse.ArgumentParser(
        prog=prog, description="The post-processing of sph runs and of other particle codes' "
        "runs of the same cases (doc/reference/postproc.md).",
        epilog=f"{prog} TOOL --help describes a tool; doc/reference/postproc.md all of them.",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="tool", required=True, metavar="TOOL")
    for name in TOOLS:
        # the first paragraph of the tool's docstring, less its "name: "
        first = " ".join(tool(name).__doc__.split("\n\n")[0].split())
        sub.add_parser(name, add_help=False, help=first.split(": ", 1)[1])
    # only --help, no tool or an unknown one get here: argparse prints the
    # help or the error and exits
    ap.parse_args(argv)
    return 2
