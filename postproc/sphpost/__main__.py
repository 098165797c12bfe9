"""python3 -m sphpost TOOL ARGS...: runs a post-processing tool, as the
command sphpost and the script postproc/TOOL do (sphpost.cli)."""
import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main(prog="python3 -m sphpost"))
