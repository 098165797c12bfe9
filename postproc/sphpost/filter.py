"""filter: zero-phase low-pass filtering of a run's probe pressures.

Reads the probe columns p_probe_1 ... of RUN_DIR/timeseries.csv (sampled at
the solver's varying time steps), resamples each onto a uniform grid, filters
it with FFTW's type-I DCT (the even extension of the signal: no wrap-around
jump) and a real raised-cosine transfer function (zero phase), and writes
RUN_DIR/probes_filtered.csv (or -o FILE) with the columns
  time, p_probe_k (raw, resampled), p_probe_k_filtered, ...
and, for cases with an exact centre pressure, p_centre_exact.

The cut-off defaults to half the lowest acoustic frequency of the patch
(doc/theory/ X6: circle 2.405 c0/(2 pi R), sphere c0/(2R), square
c0/(sqrt(2) L)); see doc/reference/postproc.md for the design and its limits.
For each probe it prints the RMS of the removed part and the frequency of its
spectral peak, to compare with the acoustic frequency.

Example:
  postproc/filter runs/circle2d
  postproc/filter runs/circle2d --cutoff-flow 2 -o /tmp/p.csv
"""
import argparse
import os
import sys

from . import foreign
from .cli import main_guard
from .exceptions import PostprocError
from .filtering import add_filter_options, filter_from_args, lowpass

PROG = "filter"


def command(argv, prog="postproc/filter"):
    """The tool on the arguments argv (without the program name); prints its
    report and returns the exit status.  Raises PostprocError."""
    ap = argparse.ArgumentParser(prog=prog, description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir", help="the run directory (output.dir of an sph run), or another "
                                    "code's output (--case, doc/reference/postproc.md)")
    ap.add_argument("-o", "--output", metavar="FILE",
                    help="where to write the filtered signals "
                         "(default RUN_DIR/probes_filtered.csv)")
    ap.add_argument("--dt", type=float, metavar="DT",
                    help="step of the uniform grid (default: the median time step of the run)")
    add_filter_options(ap)
    foreign.add_options(ap)
    args = ap.parse_args(argv)
    filter_probes(foreign.open_run(args.run_dir, args), args, args.output, args.dt)
    return 0


def filter_probes(run, fopts, output=None, dt=None, echo=print):
    """Filters every probe of the Run `run` with the filter options fopts
    (sphpost.filter_options or the parsed command line), writes the CSV
    `output` (default RUN_DIR/probes_filtered.csv) and passes each line of
    the report to echo.  Returns {probe column: {"f_peak": the spectral
    peak of the removed part, cycles per unit time; "rms": its RMS}} for
    the probes filtered."""
    import numpy as np
    c = run.case
    probes = sorted((k for k in run.ts if k.startswith("p_probe_")),
                    key=lambda s: int(s.rsplit("_", 1)[1]))
    if not probes:
        raise PostprocError(f"{run.path}/timeseries.csv has no probe columns "
                               "(output.n_probes = 0?)")
    fc, tw, how = filter_from_args(c, fopts)
    unit = c.rate_label
    for n in c.notes:
        echo(f"note: {n}")
    echo(f"run {run.path}: {c.name}; cut-off {how}; transition +-{tw:g} "
         f"(H = 1 below {fc * (1 - tw) / c.rate:.4g} {unit}, "
         f"0 above {fc * (1 + tw) / c.rate:.4g} {unit})")
    tu = None
    cols = {}
    stats = {}
    for name in probes:
        t, y = run.probe_samples(name)
        n_bad = int(np.sum(~np.isfinite(y)))
        if np.sum(np.isfinite(y)) < 4:
            echo(f"{name}: fewer than 4 valid samples (no particle near the probe): skipped")
            continue
        tu_k, yu, yf = lowpass(t, y, fc, tw, dt=dt if tu is None else tu[1] - tu[0])
        if tu is None:
            tu = tu_k
        # a probe with NaNs at the ends covers a shorter span: put it on the common grid
        yu = np.interp(tu, tu_k, yu, left=np.nan, right=np.nan)
        yf = np.interp(tu, tu_k, yf, left=np.nan, right=np.nan)
        cols[name] = yu
        cols[name + "_filtered"] = yf
        rem = yu - yf
        ok = np.isfinite(rem)
        spec = np.abs(np.fft.rfft((rem[ok] - rem[ok].mean()) * np.hanning(ok.sum())))
        freq = np.fft.rfftfreq(ok.sum(), tu[1] - tu[0])
        f_peak = freq[int(np.argmax(spec))]
        stats[name] = {"f_peak": float(f_peak), "rms": float(np.sqrt(np.mean(rem[ok]**2)))}
        echo(f"{name}: {len(t) - n_bad} samples -> {len(tu_k)} uniform (dt {tu[1] - tu[0]:.4g}); "
             f"removed part RMS {np.sqrt(np.mean(rem[ok]**2)):.4g} "
             f"({np.sqrt(np.mean(rem[ok]**2)) / c.p_unit:.4g} {c.p_unit_label}), "
             f"spectral peak {f_peak / c.rate:.4g} {unit} = {f_peak / c.f_acoustic:.3f} x "
             f"the lowest acoustic frequency"
             + (f"; {n_bad} NaN samples dropped" if n_bad else ""))
    if tu is None:
        raise PostprocError("no probe had enough valid samples to filter")
    if "p_centre_exact" in run.ts:
        cols["p_centre_exact"] = np.interp(tu, run.time, run.ts["p_centre_exact"])
    out = output or os.path.join(run.path, "probes_filtered.csv")
    names = list(cols)
    with open(out, "w") as f:
        f.write(",".join(["time"] + names) + "\n")
        for i in range(len(tu)):
            f.write(",".join(f"{v:.16e}" for v in [tu[i]] + [cols[k][i] for k in names]) + "\n")
    echo(f"wrote {out} ({len(tu)} rows)")
    return stats


def main(argv=None, prog="postproc/filter"):
    """The command line (argv defaults to sys.argv[1:]): returns the exit
    status; a PostprocError becomes a one-line message and status 2."""
    return main_guard(PROG, lambda a: command(a, prog),
                         sys.argv[1:] if argv is None else argv)
