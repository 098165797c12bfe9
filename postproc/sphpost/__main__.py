"""python3 -m sphpost TOOL ARGS...: runs a post-processing tool, as the
script postproc/TOOL does, with the same arguments, output and exit status.
From the repository root: PYTHONPATH=postproc /usr/bin/python3 -m sphpost ...
"""
import argparse
import importlib
import sys

PROG = "python3 -m sphpost"
TOOLS = ("errors", "filter", "convergence", "plots", "validate", "reference")


def tool(name):
    """The module of a tool, imported when asked for: one tool's start does
    not pay for the others' imports."""
    return importlib.import_module(f"{__package__}.{name}")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    # the tool parses its own arguments (--help included): a subparser here
    # would have to repeat them
    if argv and argv[0] in TOOLS:
        return tool(argv[0]).main(argv[1:], prog=f"{PROG} {argv[0]}")
    ap = argparse.ArgumentParser(
        prog=PROG, description=__doc__,
        epilog=f"{PROG} TOOL --help describes a tool; doc/reference/postproc.md all of them.",
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


if __name__ == "__main__":
    sys.exit(main())
