"""sphpost: the post-processing of sph runs (doc/reference/postproc.md).

The library is sphpost.core; its names are re-exported here, so code that
did `import sphpost as sp` against the former postproc/sphpost.py (the
tests, notebooks) keeps working.  Each tool is a module with a main():
sphpost.errors, .filter, .convergence, .plots and .validate.  The scripts
postproc/TOOL and `python3 -m sphpost TOOL` (with postproc/ on the path)
run them with the same arguments.
"""
from .core import *  # noqa: F401,F403
