"""sphpost: the post-processing of sph runs (doc/postproc.md).

The library is sphpost.core; its names are re-exported here, so code that
did `import sphpost as sp` against the former postproc/sphpost.py (the
tests, notebooks) keeps working.
"""
from .core import *  # noqa: F401,F403
