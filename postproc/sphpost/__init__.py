"""sphpost: the post-processing of sph runs and of other particle codes'
runs of the same four cases (doc/reference/postproc.md).

The modules, each with one concern:

  readers       the files: our run directory (readers.sph), its input file
                (readers.namelist), other codes' particle files in the plain
                format, VTK and PySPH's dumps, and which files of a directory
                are the particle files (readers.series)
  foreign       another code's output as a run: one time-series row per file
  cases         the case registry (the solver's case names) and their scales
  exact         the exact solutions (doc/theory/ X1-X5, I2)
  particles     estimates from particles: pressure at a point, semi-axes,
                free surface
  filtering     the zero-phase low-pass filter of probe signals
  measures      the error measures and orders of convergence
  figures       what the figures share
  cli           the command line: `sphpost TOOL`, `python3 -m sphpost TOOL`

and one module per tool: errors, filter, convergence, plots, reference,
validate.  The names below are the library's public face, each from its
module, for scripts and notebooks (`import sphpost as sp; sp.Run(DIR)`).
"""
from . import exact
from .cases import CASES, CaseInfo, case_info, patch_volume, scaled_input
from .exceptions import PostprocError
from .foreign import ForeignRun, open_run
from .filtering import (DEFAULT_ACOUSTIC_FRACTION, DEFAULT_TRANSITION, cutoff, filter_options,
                        lowpass)
from .measures import observed_orders, stretching_errors, time_mean, windowed_errors
from .readers.namelist import read_namelist
from .readers.sph import Run, read_timeseries, solver_summary

__all__ = ["exact", "CASES", "CaseInfo", "case_info", "patch_volume", "scaled_input",
           "PostprocError", "ForeignRun", "open_run", "DEFAULT_ACOUSTIC_FRACTION",
           "DEFAULT_TRANSITION", "cutoff", "filter_options", "lowpass", "observed_orders",
           "stretching_errors", "time_mean", "windowed_errors", "read_namelist", "Run",
           "read_timeseries", "solver_summary"]
