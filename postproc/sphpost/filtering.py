"""sphpost.filtering: the zero-phase low-pass filter of probe signals
(doc/reference/postproc.md): a type-I discrete cosine transform (FFTW_REDFT00,
through pyFFTW) of the uniformly resampled signal, a raised-cosine
transfer function, and the cut-off chosen from the case's lowest acoustic
frequency or its flow rate."""
import argparse
import math

import numpy as np

from .exceptions import PostprocError


def _fftw():
    try:
        import pyfftw
    except ImportError as e:
        raise PostprocError("the filter needs pyFFTW: apt-get install python3-pyfftw "
                            "(and run the scripts with /usr/bin/python3)") from e
    return pyfftw


def dct1(x):
    """FFTW's REDFT00 of x (unnormalised DCT-I, the DFT of the even extension
    x_0 .. x_{M-1} .. x_1 of period 2(M-1)):
    Y_k = x_0 + (-1)^k x_{M-1} + 2 Sum_{j=1}^{M-2} x_j cos(pi j k/(M-1)).
    Applied twice it multiplies by 2(M-1)."""
    pyfftw = _fftw()
    x = np.asarray(x, dtype=float)
    a = pyfftw.empty_aligned(x.shape, dtype="float64")
    b = pyfftw.empty_aligned(x.shape, dtype="float64")
    plan = pyfftw.FFTW(a, b, direction="FFTW_REDFT00", flags=("FFTW_ESTIMATE",))
    a[:] = x
    plan()
    return b.copy()


def raised_cosine(f, f_cut, transition):
    """The filter's transfer function H(f): 1 below f_cut (1 - transition),
    0 above f_cut (1 + transition), a half cosine between (H(f_cut) = 1/2).
    Real and even: zero phase."""
    f = np.abs(np.asarray(f, dtype=float))
    lo, hi = f_cut * (1 - transition), f_cut * (1 + transition)
    h = np.where(f <= lo, 1.0, 0.0)
    if hi > lo:
        mid = (f > lo) & (f < hi)
        h[mid] = 0.5 * (1 + np.cos(math.pi * (f[mid] - lo) / (hi - lo)))
    return h


def resample_uniform(t, y, dt=None):
    """Linear interpolation of the samples (t, y) onto a uniform grid from
    t[0] to t[-1]; NaN samples and repeated times are dropped first.  The
    grid step is the median sampling interval unless dt is given (never
    coarser: the step is adjusted down to fit a whole number of steps).
    Returns (tu, yu)."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    ok = np.isfinite(t) & np.isfinite(y)
    t, y = t[ok], y[ok]
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    keep = np.concatenate([[True], np.diff(t) > 0])
    t, y = t[keep], y[keep]
    if len(t) < 4:
        raise PostprocError(f"a signal needs at least 4 valid samples to filter, got {len(t)}")
    if dt is None:
        dt = float(np.median(np.diff(t)))
    m = int(math.ceil((t[-1] - t[0]) / dt - 1e-9)) + 1
    tu = np.linspace(t[0], t[-1], max(m, 4))
    return tu, np.interp(tu, t, y)


def lowpass(t, y, f_cut, transition=0.3, dt=None):
    """Zero-phase low-pass filter of a non-uniformly sampled signal.

    1. resample onto a uniform grid (resample_uniform);
    2. transform the even extension by FFTW's REDFT00 (dct1): the periodic
       signal it represents has no jump at the ends (no wrap-around
       artefact), only a kink where the slope is not zero there;
    3. multiply by the real transfer function raised_cosine(f_k) at the
       frequencies f_k = k / (2 (M-1) dt) (zero phase);
    4. transform back and divide by 2(M-1).

    f_cut is in cycles per unit time.  Returns (tu, y_uniform, y_filtered).
    """
    if not f_cut > 0:
        raise PostprocError(f"the cut-off frequency must be positive, got {f_cut}")
    if not 0 <= transition < 1:
        raise PostprocError(f"the transition width must be in [0, 1), got {transition}")
    tu, yu = resample_uniform(t, y, dt)
    m = len(tu)
    step = tu[1] - tu[0]
    fk = np.arange(m) / (2 * (m - 1) * step)
    yf = dct1(raised_cosine(fk, f_cut, transition) * dct1(yu)) / (2 * (m - 1))
    return tu, yu, yf


DEFAULT_ACOUSTIC_FRACTION = 0.5
DEFAULT_TRANSITION = 0.3


def cutoff(case, acoustic_fraction=None, flow_multiple=None):
    """The cut-off frequency (cycles per unit time) and a sentence saying how
    it was chosen: flow_multiple times the flow rate (A0, omega or V0/L) when
    given, else acoustic_fraction (default 1/2) of the lowest acoustic
    frequency."""
    if flow_multiple is not None and acoustic_fraction is not None:
        raise PostprocError("give the cut-off either relative to the acoustic frequency "
                            "or to the flow rate, not both")
    unit = case.rate_label
    if flow_multiple is not None:
        if not flow_multiple > 0:
            raise PostprocError(f"--cutoff-flow must be positive, got {flow_multiple}")
        fc = flow_multiple * case.rate
        how = (f"{flow_multiple:g} {unit} = {fc / case.f_acoustic:.3f} x the lowest acoustic "
               f"frequency {case.f_acoustic / case.rate:.4g} {unit}")
    else:
        frac = DEFAULT_ACOUSTIC_FRACTION if acoustic_fraction is None else acoustic_fraction
        if not frac > 0:
            raise PostprocError(f"--cutoff-acoustic must be positive, got {frac}")
        fc = frac * case.f_acoustic
        how = (f"{frac:g} x the lowest acoustic frequency {case.f_acoustic / case.rate:.4g} "
               f"{unit} = {fc / case.rate:.4g} {unit}")
    return fc, how


def add_filter_options(parser):
    """The filter's command-line options, shared by the scripts."""
    g = parser.add_argument_group("pressure filter (doc/reference/postproc.md)")
    g.add_argument("--cutoff-acoustic", type=float, metavar="FRAC",
                   help="cut-off as a fraction of the lowest acoustic frequency of the "
                        f"patch (doc/theory/ X6); default {DEFAULT_ACOUSTIC_FRACTION}")
    g.add_argument("--cutoff-flow", type=float, metavar="F",
                   help="cut-off in units of the flow rate instead (A0, omega or V0/L: "
                        "cycles per 1/A0 ...)")
    g.add_argument("--transition", type=float, default=DEFAULT_TRANSITION, metavar="W",
                   help="relative half-width of the raised-cosine transition: H = 1 below "
                        "(1-W) f_cut, 0 above (1+W) f_cut; default %(default)s")


def filter_from_args(case, args):
    fc, how = cutoff(case, args.cutoff_acoustic, args.cutoff_flow)
    return fc, args.transition, how


def filter_options(cutoff_acoustic=None, cutoff_flow=None, transition=DEFAULT_TRANSITION):
    """The filter's options as add_filter_options parses them, with the same
    defaults: what the tools' functions take when called from Python."""
    return argparse.Namespace(cutoff_acoustic=cutoff_acoustic, cutoff_flow=cutoff_flow,
                              transition=transition)
