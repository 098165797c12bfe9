"""sphpost.measures: the paper's error measures of a run against the exact
solution: time means, windows, the stretching cases' errors (axes,
positions, velocities, kinetic energy, the raw and filtered centre
pressure, the start-up dip), the compressibility floor of a run's case,
and observed orders of convergence."""
import numpy as np

from .exact import compressibility_floor
from .exceptions import PostprocError
from .filtering import lowpass

# the trapezoidal rule: numpy.trapezoid since NumPy 2.0, numpy.trapz before
_trapezoid = getattr(np, "trapezoid", None) or np.trapz


def time_mean(t, e):
    """Time average of e over [t0, t1] (trapezoidal rule on the samples)."""
    t = np.asarray(t, float)
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    t, e = t[ok], e[ok]
    if len(t) < 2 or t[-1] <= t[0]:
        return float(e[0]) if len(e) else float("nan")
    return float(_trapezoid(e, t) / (t[-1] - t[0]))


def window_mean(t, e, a, b):
    """Time average of e over the window [a, b] (a < b, inside the samples'
    span): the integral of the piecewise-linear interpolant of the finite
    samples, the one time_mean's trapezoidal rule integrates, so that the
    windows' integrals add up to the whole run's."""
    t = np.asarray(t, float)
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    t, e = t[ok], e[ok]
    inner = (t > a) & (t < b)
    tw = np.concatenate(([a], t[inner], [b]))
    ew = np.concatenate(([np.interp(a, t, e)], e[inner], [np.interp(b, t, e)]))
    return float(_trapezoid(ew, tw) / (b - a))


def windowed_errors(res, edges):
    """The time means of stretching_errors' absolute errors (res, its
    'signals') over the windows [edges[k], edges[k + 1]] (run time,
    increasing, within the run): where in the run an error is made.
    Returns a list of (a, b, {name: mean}) with the names of res['mean'] but
    the bias and the floor."""
    return [(float(a), float(b), {n: window_mean(ts, np.abs(e), a, b)
                                  for n, (ts, e) in res["signals"].items()})
            for a, b in zip(edges[:-1], edges[1:])]


DIP_WINDOW = 0.05   # t A0 below which the start-up dip of the centre pressure is read


def stretching_errors(run, f_cut, transition):
    """The paper's errors of a circle2d / ellipsoid3d run, as fractions.

    Returns a dict with
      'series': {name: array over the time-series rows} of the signed errors
          axis_k (fitted SPH semi-axis / same fit of the exact positions - 1),
          axis_max (max_k |axis_k|, the solver's summary quantity),
          pos, vel (RMS over particles / R, / (A0 R)), ke (KE / KE_exact - 1),
          p_raw ((p_centre - P(t)) / P(0)), P (= P(t)/P(0));
      'filtered': (tu, e_f, P_u, bias) on the uniform grid: the low-pass
          filtered centre-pressure error e_f = filter(p - P)/P(0) (so the
          filtered SPH pressure is P + e_f P(0)), P(t)/P(0) resampled, and
          the filter applied to the exact curve minus the exact curve (its
          own rounding of a smooth signal at the ends, which filtering the
          error leaves out);
      'signals': {name: (times, signed error)} of every error 'mean'
          averages but the bias and the floor, each on its own times: the
          time-series rows, the probe's samples (p_raw), the filter's
          uniform grid (p_filt);
      'mean': time averages (trapezoidal, over [0, t_end]) of the absolute
          errors; 'sample_mean': plain averages over rows, as the solver's
          closing summary computes them; 'final': the last row's values;
      'dip': the start-up dip, max(0, -min (p - P(t))/P(0)) over
          t A0 < DIP_WINDOW (raw pressure; absent without a centre probe);
      'p0': P(0); 'probe': the probe column used.
    """
    c = run.case
    if not c.stretching:
        raise PostprocError(f"errors are defined for circle2d and ellipsoid3d, not {c.name}")
    t = run.time
    dim = c.dim
    ser = {}
    for k in range(1, dim + 1):
        ser[f"axis_{k}"] = run.column(f"semi_axis_{k}_error")
    ser["axis_max"] = np.max(np.abs([ser[f"axis_{k}"] for k in range(1, dim + 1)]), axis=0)
    # a measure the run cannot give (a foreign run without particle ids has
    # no Lagrangian position error) is left out, with the reason
    missing = dict(getattr(run, "missing", {}))
    if "pos" not in missing:
        ser["pos"] = run.column("rms_position_error")
    ser["vel"] = run.column("rms_velocity_error")
    ser["ke"] = run.column("kinetic_energy") / run.column("kinetic_energy_exact") - 1
    pex = run.column("p_centre_exact")
    p0 = float(pex[0])
    ser["P"] = pex / p0
    probe = run.centre_probe()
    out = {"series": ser, "p0": p0, "probe": probe, "time": t, "missing": missing}
    if probe is not None:
        # the probe's own samples: the time-series rows for our runs, a
        # probe file's rows for a foreign run that has one
        tp, praw, pexp = run.probe_signal(probe)
        eraw = (praw - pexp) / p0
        ser["p_raw"] = eraw if tp is t else np.interp(t, tp, eraw)
        # the error signal p - P(t) is filtered, i.e. the SPH pressure and
        # the exact one pass through the same filter: the filter's rounding
        # of the exact curve at the ends (bias, below) cancels instead of
        # being counted as an error of the solver (doc/reference/postproc.md)
        tu, _, ef = lowpass(tp, eraw, f_cut, transition)
        _, pu, pexf = lowpass(tp, pexp, f_cut, transition, dt=tu[1] - tu[0])
        out["filtered"] = (tu, ef, pu / p0, (pexf - pu) / p0)
    names = [f"axis_{k}" for k in range(1, dim + 1)] + ["axis_max", "pos", "vel", "ke"]
    names = [n for n in names if n not in missing]
    if probe is not None:
        names.append("p_raw")
    signals = {n: (t, ser[n]) for n in names}
    if probe is not None:
        tu, ef, _, bias = out["filtered"]
        signals["p_raw"] = (tp, eraw)
        signals["p_filt"] = (tu, ef)
    mean = {n: time_mean(ts, np.abs(e)) for n, (ts, e) in signals.items()}
    smean = {n: float(np.nanmean(np.abs(ser[n]))) for n in names}
    final = {n: float(ser[n][-1]) for n in names}
    if probe is not None:
        smean["p_raw"] = float(np.nanmean(np.abs(eraw)))
        final["p_raw"] = float(eraw[-1])
        smean["p_filt"] = float(np.mean(np.abs(ef)))
        final["p_filt"] = float(ef[-1])
        mean["p_filt_bias"] = time_mean(tu, np.abs(bias))
        final["p_filt_bias"] = float(bias[-1])
        # the start-up dip: the largest fall of the raw centre pressure below
        # P(t) over t rate < DIP_WINDOW (0 if it never falls below)
        early = tp * c.rate < DIP_WINDOW
        out["dip"] = float(max(0.0, -np.min(eraw[early]))) if early.any() else 0.0
    out["slow"] = slow_centre_pressure(c, t)
    mean["slow"] = time_mean(t, np.abs(out["slow"]))
    out.update(mean=mean, sample_mean=smean, final=final, names=names, signals=signals)
    return out


def slow_centre_pressure(case, t):
    """compressibility_floor (I2) of a run's case (CaseInfo) at the times t."""
    return compressibility_floor(t, case.rates, case.length, case.rho0, case.c0)


def row_indices(run, times=None, count=None):
    """Rows of the time series to tabulate: those at the snapshot times
    (default), at the given times, or `count` evenly spread rows."""
    t = run.time
    if count is not None:
        if count < 1:
            raise PostprocError("--count must be at least 1")
        want = np.linspace(t[0], t[-1], count)
    elif times is not None:
        want = np.asarray(times, float)
    elif run.snapshots:
        want = run.snapshot_times()
    else:
        step = float(run.nml.get("output", {}).get("dt", (t[-1] - t[0]) / 10 or 1.0))
        want = np.append(np.arange(t[0], t[-1], step), t[-1])
    idx = [int(np.argmin(np.abs(t - w))) for w in want]
    return sorted(set(idx))


def observed_orders(h, e):
    """Orders between successive resolutions log(e_i/e_{i+1})/log(h_i/h_{i+1})
    and the least-squares slope of log e against log h."""
    h = np.asarray(h, float)
    e = np.abs(np.asarray(e, float))
    pair = [float(np.log(e[i] / e[i + 1]) / np.log(h[i] / h[i + 1]))
            if e[i] > 0 and e[i + 1] > 0 else float("nan") for i in range(len(h) - 1)]
    ok = e > 0
    lsq = float(np.polyfit(np.log(h[ok]), np.log(e[ok]), 1)[0]) if ok.sum() >= 2 else float("nan")
    return pair, lsq
