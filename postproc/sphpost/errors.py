"""errors: the paper's errors of a circle2d or ellipsoid3d run against the
exact solution, at the output times and averaged over time; for the square
patches, and any case without an exact solution, the probe pressure,
kinetic energy and free surface.

Prints a table over the snapshot times (or --times / --count), then the
time-averaged ("mean") absolute errors the paper quotes: semi-axes, particle
positions against the exact Lagrangian map, velocities, kinetic energy, and
the centre pressure raw and low-pass filtered (relative to P(0)).  The values
at the table's times are the solver's own time-series values (timeseries.csv);
--check-snapshots recomputes them from the HDF5 snapshots as a cross-check.

The run is one of ours (a run directory) or another code's output, one file
per output time: the plain format (CSV or .npz), VTK (.vtk, .vtu, .vtp) or
PySPH's dumps (doc/reference/other-codes.md); its case is --case and
its units --length, --rate, --v0, --rho.

Example:
  postproc/errors runs/circle2d
  postproc/errors runs/circle2d --count 9 --csv errors.csv
  postproc/errors --case circle2d my_code/output --probe-file my_code/centre.csv
  postproc/errors --case circle2d dsph/out --pattern 'PartFluid_*.vtk' --output-dt 0.01
"""
import argparse
import json
import math
import sys

from . import exact, foreign
from .cases import CASES, PROBES
from .cli import main_guard
from .exceptions import PostprocError
from .filtering import add_filter_options, filter_from_args, lowpass
from .measures import DIP_WINDOW, row_indices, stretching_errors, windowed_errors
from .particles import free_surface_outline, outline_measures

PROG = "errors"


def snapshot_check(run):
    """Recomputes RMS position/velocity errors and the kinetic energy from
    each snapshot (sorted by id) and returns the largest relative difference
    from the time-series values at the same times."""
    import numpy as np
    c = run.case
    worst = {"pos": 0.0, "vel": 0.0, "ke": 0.0}
    for i in range(len(run.snapshots)):
        s = run.snapshot(i)
        row = int(np.argmin(np.abs(run.time - s["attrs"]["time"])))
        pos = math.sqrt(np.mean(np.sum((s["position"] - s["position_exact"])**2, axis=1))) \
            / c.length
        vel = math.sqrt(np.mean(np.sum((s["velocity"] - s["velocity_exact"])**2, axis=1))) \
            / (c.rate * c.length)
        ke = 0.5 * float(np.sum(s["mass"] * np.sum(s["velocity"]**2, axis=1)))
        for key, mine, col in (("pos", pos, "rms_position_error"),
                               ("vel", vel, "rms_velocity_error"),
                               ("ke", ke, "kinetic_energy")):
            ref = run.ts[col][row]
            d = abs(mine - ref) / max(abs(ref), 1e-300) if ref != 0 else abs(mine)
            worst[key] = max(worst[key], d)
    return worst


def velocity_split(run, degree=3):
    """The RMS velocity error of each snapshot split into a smooth part, the
    least-squares fit of u - u_exact by the polynomials of total degree <=
    `degree` in the initial positions (it holds the compressible flow I1
    and any large-scale error), and the particle-scale rest.  Returns rows
    (t, total, smooth, rest) in units of A0 R."""
    import numpy as np
    c = run.case
    rows = []
    for i in range(len(run.snapshots)):
        s = run.snapshot(i)
        x0 = s["position_initial"][:, :c.dim] / c.length
        e = (s["velocity"] - s["velocity_exact"]) / (c.rate * c.length)
        powers = [p for p in np.ndindex(*([degree + 1] * c.dim)) if sum(p) <= degree]
        basis = np.stack([np.prod(x0**np.array(p), axis=1) for p in powers], axis=1)
        coef, *_ = np.linalg.lstsq(basis, e, rcond=None)
        smooth = basis @ coef
        rms = lambda v: math.sqrt(float(np.mean(np.sum(v**2, axis=1))))
        rows.append((s["attrs"]["time"], rms(e), rms(smooth), rms(e - smooth)))
    return rows


#: the band edges of plane_bands, in dx of initial distance from the nearest
#: coordinate plane (doc/studies/symmetry.md: the packing's layers reach about 1.5 dx)
PLANE_BAND_EDGES = (0.5, 1.0, 2.0, 4.0, 8.0)
#: plane_bands groups the particles of initial radius below this (in R) by
#: their distance from the planes; the rest, near the free surface, apart
PLANE_BAND_INTERIOR = 0.8


def _plane_band_rows(run, edges, interior):
    """One pass over the snapshots for plane_bands and plane_band_pressure:
    (labels, counts, velocity rows, pressure rows), the groups taken from the
    initial positions of the first snapshot."""
    import numpy as np
    c = run.case
    labels = (["on a plane", f"(0, {edges[0]:g})"]
              + [f"[{a:g}, {b:g})" for a, b in zip(edges[:-1], edges[1:])]
              + [f">= {edges[-1]:g}", f"r0 >= {interior:g}", "all"])
    bounds = [0.0] + list(edges) + [math.inf]
    groups, vrows, prows = None, [], []
    for i in range(len(run.snapshots)):
        s = run.snapshot(i)
        if groups is None:
            # by the initial positions: the same particles, sorted by id, in
            # every snapshot
            x0 = s["position_initial"][:, :c.dim] / c.length
            d = np.min(np.abs(x0), axis=1) / (run.dx / c.length)
            inner = np.sum(x0**2, axis=1) < interior**2
            groups = [inner & (d == 0)]
            groups += [inner & (d > 0) & (d >= a) & (d < b)
                       for a, b in zip(bounds[:-1], bounds[1:])]
            groups += [~inner, np.ones(len(d), bool)]
            counts = [int(g.sum()) for g in groups]
            p0 = float(s["attrs"]["p_centre_exact"])
        t = s["attrs"]["time"]
        e2 = np.sum((s["velocity"] - s["velocity_exact"])**2, axis=1) / (c.rate * c.length)**2
        vrows.append((t, [math.sqrt(float(e2[g].mean())) if k else math.nan
                          for g, k in zip(groups, counts)]))
        e = (s["pressure"] - s["pressure_exact"]) / p0
        prows.append((t, [float(e[g].mean()) if k else math.nan
                          for g, k in zip(groups, counts)]))
    return labels, counts, vrows, prows


def plane_bands(run, edges=PLANE_BAND_EDGES, interior=PLANE_BAND_INTERIOR):
    """The RMS velocity error of each snapshot by the particles' initial
    distance d from the nearest coordinate plane through the centre, in dx:
    for the interior particles (initial radius below `interior` R) those on a
    plane (d = 0: M5 of doc/theory/mirrors.md), then 0 < d < edges[0], edges[0] <=
    d < edges[1], ..., d >= edges[-1]; then the other particles and all of
    them.  A mirror-plane run is taken as its whole body (core.Run.snapshot),
    a full run at the same planes, so that the two compare band by band.
    Returns (labels, counts, rows), rows (t, rms per group) in units of
    A0 R; sum over groups of count rms^2 is all's."""
    labels, counts, vrows, _ = _plane_band_rows(run, edges, interior)
    return labels, counts, vrows


def plane_band_pressure(run, edges=PLANE_BAND_EDGES, interior=PLANE_BAND_INTERIOR):
    """The mean signed pressure error (p - p_exact) / P(0) of each snapshot
    in the groups of plane_bands (P(0) the exact centre pressure at t = 0):
    the layers next to a plane can carry a pressure of their own that the
    RMS velocity does not show (doc/studies/symmetry.md, "The late centre
    pressure").  Every group moves with the run's acoustic oscillation, so
    the groups compare within a row.  Returns (labels, counts, rows) as
    plane_bands; sum over groups of count mean is all's."""
    labels, counts, _, prows = _plane_band_rows(run, edges, interior)
    return labels, counts, prows


def window_edges(text, run):
    """The edges 0, T1, ..., Tk, t_end in run time of --windows T1,...,Tk
    (given in the table's unit, t times the case's rate); PostprocError
    unless they increase strictly inside (0, t_end)."""
    c = run.case
    try:
        inner = [float(v) for v in text.split(",")]
    except ValueError:
        raise PostprocError(f"--windows {text}: not a comma-separated list of times")
    t0, t1 = float(run.time[0]), float(run.time[-1])
    edges = [t0] + [v / c.rate for v in inner] + [t1]
    if any(b <= a for a, b in zip(edges[:-1], edges[1:])):
        raise PostprocError(f"--windows {text}: the times must increase strictly between "
                               f"{t0 * c.rate:g} and t_end = {t1 * c.rate:g} "
                               f"({c.time_label})")
    return edges


def command(argv, prog="postproc/errors"):
    """The tool on the arguments argv (without the program name); prints its
    report and returns the exit status.  Raises PostprocError."""
    ap = argparse.ArgumentParser(
        prog=prog, description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir", help="the run directory (output.dir of an sph run), or another "
                                    "code's output files: a directory or a glob pattern")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--times", type=float, nargs="+", metavar="T",
                   help="tabulate the rows nearest these times (default: the snapshot times)")
    g.add_argument("--count", type=int, metavar="N",
                   help="tabulate N rows evenly spread in time")
    ap.add_argument("--csv", metavar="FILE", help="also write the table as CSV")
    ap.add_argument("--reference", metavar="DIR",
                    help="the squares: compare with this reference run of postproc/reference "
                         "(doc/validation/reference.md); 'bem': the rotating square's "
                         "boundary-integral reference shipped with the package")
    ap.add_argument("--json", action="store_true",
                    help="print the means and final values as JSON instead of the tables")
    ap.add_argument("--check-snapshots", action="store_true",
                    help="recompute position, velocity and kinetic-energy values from the "
                         "snapshots and report the largest difference from timeseries.csv")
    ap.add_argument("--velocity-split", action="store_true",
                    help="split each snapshot's RMS velocity error into a smooth part (fit by "
                         "cubic polynomials of the initial positions) and a particle-scale rest")
    ap.add_argument("--plane-bands", action="store_true",
                    help="each snapshot's RMS velocity error, then its mean pressure error, "
                         "by the initial distance from the nearest coordinate plane, in dx "
                         "(interior particles), then near the surface: where a mirror-plane "
                         "run (particles.symmetry) parts from the full one")
    ap.add_argument("--windows", metavar="T1[,T2...]",
                    help="also the time means over the windows [0, T1], [T1, T2], ..., "
                         "[Tk, t_end] (times in the table's unit, t A0): where in the run an "
                         "error is made")
    add_filter_options(ap)
    foreign.add_options(ap)
    args = ap.parse_args(argv)

    import numpy as np
    run = foreign.open_run(args.run_dir, args)
    c = run.case
    if isinstance(run, foreign.ForeignRun) and (args.check_snapshots or args.velocity_split
                                                or args.plane_bands):
        raise PostprocError("--check-snapshots, --velocity-split and --plane-bands need an "
                               f"sph run's snapshots; '{args.run_dir}' is another code's output")
    fc, tw, how = filter_from_args(c, args)
    if not c.stretching:
        if args.windows:
            raise PostprocError("--windows is for the stretching cases (circle2d, "
                                   f"ellipsoid3d), not {c.name}")
        return patch_report(run, fc, tw, how, args)
    edges = window_edges(args.windows, run) if args.windows else None
    res = stretching_errors(run, fc, tw)
    windows = windowed_errors(res, edges) if edges is not None else None
    if args.json:
        js = {"run": run.path, "case": c.name, "n": run.n_particles,
              "dx": run.dx, "t_end": float(run.time[-1]), "f_cut": fc,
              "mean": res["mean"], "sample_mean": res["sample_mean"],
              "final": res["final"], "missing": res["missing"]}
        if windows is not None:
            js["windows"] = [{"from": a * c.rate, "to": b * c.rate, "mean": m}
                             for a, b, m in windows]
        print(json.dumps(js, indent=1))
        return 0

    dim = c.dim
    ser = res["series"]
    rows = row_indices(run, args.times, args.count)
    for n in c.notes:
        print(f"note: {n}")
    print(f"run {run.path}: {c.name}, {run.n_particles} particles, dx/R {run.dx / c.length:.4g}, "
          f"c0 {c.c0:g} ({c.c0_label}), t_end {run.time[-1]:g} ({c.time_label} = "
          f"{run.time[-1] * c.rate:g}), {len(run.time)} time-series rows")
    if c.units:
        print(f"units: {c.units}")
    if res["probe"] is None:
        print("no pressure probe at the centre: pressure errors left out")
    else:
        tu = res["filtered"][0]
        print(f"centre pressure: {res['probe']}; P(0) = {res['p0']:.6g}; filter: zero-phase "
              f"DCT-I low-pass, cut-off {how}, transition +-{tw:g}; "
              f"{len(tu)} uniform samples, dt {tu[1] - tu[0]:.4g}")
    print("errors in %: semi-axis k: fitted SPH / same fit of the exact positions - 1; "
          "pos: RMS |x - x_exact| / R; vel: RMS |u - u_exact| / (A0 R); "
          "KE: KE / KE_exact - 1; p raw, p filt: (p - P(t)) / P(0)")
    for key, why in res["missing"].items():
        print(f"left out: {key} ({why})")
    cols = [f"axis {k}" for k in range(1, dim + 1)] + ["max|axis|", "pos", "vel", "KE"]
    keys = [f"axis_{k}" for k in range(1, dim + 1)] + ["axis_max", "pos", "vel", "ke"]
    cols = [n for n, k in zip(cols, keys) if k not in res["missing"]]
    keys = [k for k in keys if k not in res["missing"]]
    has_p = res["probe"] is not None
    if has_p:
        cols += ["p raw", "p filt", "P(t)/P(0)"]
    head = f"{c.time_label:>8} " + " ".join(f"{x:>9}" for x in cols)
    print(head)
    table = []
    for i in rows:
        vals = [100 * ser[k][i] for k in keys]
        if has_p:
            tu, ef, pu, _ = res["filtered"]
            vals += [100 * ser["p_raw"][i], 100 * float(np.interp(run.time[i], tu, ef)),
                     ser["P"][i]]
        table.append([run.time[i] * c.rate] + vals)
        print(f"{run.time[i] * c.rate:8.4f} " + " ".join(
            f"{v:9.4f}" if j < len(vals) - 1 or not has_p else f"{v:9.6f}"
            for j, v in enumerate(vals)))
    keys_m = keys + (["p_raw", "p_filt"] if has_p else [])
    for label, d in (("mean", res["mean"]), ("samples", res["sample_mean"])):
        print(f"{label:>8} " + " ".join(f"{100 * d[k]:9.4f}" for k in keys_m))
    print("mean: time average of |error| over [0, t_end] (trapezoidal rule); samples: plain "
          "average over the time-series rows, as the solver's closing summary")
    if windows is not None:
        print(f"time means over windows of {c.time_label} (the mean's rule on each; weighted "
              f"by their lengths they add up to the mean)")
        print(f"{'window':>17} " + " ".join(f"{x:>9}" for x in cols[:len(keys_m)]))
        for a, b, m in windows:
            print(f"{f'[{a * c.rate:.4g}, {b * c.rate:.4g}]':>17} "
                  + " ".join(f"{100 * m[k]:9.4f}" for k in keys_m))
    if has_p:
        print(f"p filt is the filtered error filter(p - P(t)): the filter applied to the exact "
              f"P(t) alone would move it by {100 * res['mean']['p_filt_bias']:.4f} % of P(0) on "
              f"average ({100 * res['final']['p_filt_bias']:+.4f} % at the end), which this "
              f"leaves out")
        print(f"start-up dip: the raw centre pressure falls at most "
              f"{100 * res['dip']:.4f} % of P(0) below P(t) for {c.time_label} < "
              f"{DIP_WINDOW:g}")
    print(f"compressibility floor (I2, doc/studies/numerics.md): the weakly compressible slow "
          f"solution's own centre pressure departs from P(t) by {100 * res['mean']['slow']:.4f} "
          f"% of P(0) on average at {c.c0_label}; the filtered error does not converge below "
          f"it (it falls as 1/c0^2)")
    if args.check_snapshots:
        if not run.snapshots:
            print("snapshot check: no snapshots")
        else:
            w = snapshot_check(run)
            print(f"snapshot check ({len(run.snapshots)} snapshots): largest relative difference "
                  f"from timeseries.csv: pos {w['pos']:.2e}, vel {w['vel']:.2e}, KE {w['ke']:.2e}")
    if args.velocity_split:
        print("velocity error split (RMS / (A0 R), %): smooth = least-squares fit by cubic "
              "polynomials of the initial positions; rest = particle-scale")
        print(f"{c.time_label:>8} {'total':>9} {'smooth':>9} {'rest':>9}")
        for t, tot, sm, rest in velocity_split(run):
            print(f"{t * c.rate:8.4f} {100 * tot:9.4f} {100 * sm:9.4f} {100 * rest:9.4f}")
    if args.plane_bands:
        labels, counts, brows, prows = _plane_band_rows(run, PLANE_BAND_EDGES,
                                                        PLANE_BAND_INTERIOR)
        print(f"velocity error by the initial distance d from the nearest coordinate plane, "
              f"in dx = {run.dx / c.length:.4g} R, of the particles of initial radius below "
              f"{PLANE_BAND_INTERIOR:g} R; then the others, and all (RMS / (A0 R), %)")
        w = max(11, max(len(x) for x in labels) + 1)
        print(f"{c.time_label:>8} " + "".join(f"{x:>{w}}" for x in labels))
        for t, v in brows:
            print(f"{t * c.rate:8.4f} " + "".join(f"{100 * x:{w}.4f}" if k else f"{'-':>{w}}"
                                                  for x, k in zip(v, counts)))
        print(f"{'count':>8} " + "".join(f"{k:>{w}d}" for k in counts))
        print("pressure error by the same groups: mean (p - p_exact) / P(0), %")
        print(f"{c.time_label:>8} " + "".join(f"{x:>{w}}" for x in labels))
        for t, v in prows:
            print(f"{t * c.rate:8.4f} " + "".join(f"{100 * x:{w}.4f}" if k else f"{'-':>{w}}"
                                                  for x, k in zip(v, counts)))
    if args.csv:
        import csv
        with open(args.csv, "w", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["time"] + [k.replace(" ", "_").replace("|", "") for k in cols])
            for r in table:
                wr.writerow([f"{v:.10g}" for v in r])
    return 0


def reference_comparison(case, t, p_probe, t_ke, ke, ref_dir, fc, tw):
    """The squares against their independent reference (postproc/reference,
    doc/validation/reference.md) in ref_dir: given the case (CaseInfo), the probe
    pressure p_probe at times t and the kinetic energy ke at t_ke, the
    numbers of sphpost.reference.series_against; None without ref_dir."""
    if not ref_dir:
        return None
    from . import reference
    return reference.series_against(case, reference.Reference(ref_dir), t, p_probe, t_ke, ke,
                                    fc, tw)[0]


def patch_report(run, fc, tw, how, args):
    """The squares, and any case without an exact solution in sphpost.cases:
    the probe pressure raw and filtered, against the initial pressure of
    the sine series (X3, X4) for the squares, the kinetic energy, against
    the exact flow's (kept constant) for the squares, the free surface's
    outline (area, perimeter, curves) at the first and last output (2D),
    and the reference comparison's hook.  Prints the report (or JSON)."""
    import numpy as np
    c = run.case
    t = run.time
    exact_at = CASES[c.name].exact if c.name in CASES else None
    if exact_at:
        point = np.array(PROBES[c.name]) * c.length
        p0_exact, ke0_exact = exact_at(c, point[0], point[1])
    else:
        point, p0_exact, ke0_exact = None, None, None
    ke = run.column("kinetic_energy")
    run.column("p_probe_1")
    tp, pp = run.probe_samples("p_probe_1")
    out = {"run": run.path, "case": c.name, "n": run.n_particles, "t_end": float(t[-1]),
           "probe": None if point is None else point.tolist(), "p0_exact": p0_exact,
           "p_first": float(pp[0]), "p_end": float(pp[-1]),
           "ke0_exact": ke0_exact, "ke_first": float(ke[0]), "ke_end": float(ke[-1]),
           "ke_change": float(ke[-1] / ke[0] - 1) if ke[0] != 0 else None}
    if exact_at:
        out["p0_error"] = (float(pp[0]) - p0_exact) / c.p_unit
        out["ke0_error"] = float(ke[0] / ke0_exact - 1)
    ok = np.isfinite(pp)
    if ok.sum() >= 4:
        tu, pu, pf = lowpass(tp[ok], pp[ok], fc, tw)
        out["p_filt_end"] = float(pf[-1])
        out["p_acoustic_rms"] = float(np.sqrt(np.mean((pu - pf)**2)) / c.p_unit)
    outlines = getattr(run, "outlines", None)
    if outlines is None and run.snapshots and c.dim == 2:
        outlines = {}
        for i in (0, -1):
            s = run.snapshot(i)
            vol = s["mass"] / s["density"]
            outlines[s["attrs"]["time"]] = free_surface_outline(
                s["position"][:, :2], vol, run.dx)
    out["outline"] = {f"{tt:g}": dict(zip(("area", "perimeter", "curves"),
                                          outline_measures(lines)))
                      for tt, lines in (outlines or {}).items()}
    if args.reference and not c.square:
        raise PostprocError(f"--reference is for the squares, not {c.name}")
    out["reference"] = reference_comparison(c, tp, pp, t, ke, args.reference, fc, tw)
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    for n in c.notes:
        print(f"note: {n}")
    unit = c.p_unit_label
    print(f"run {run.path}: {c.name}, {run.n_particles} particles, c0 {c.c0:g} ({c.c0_label}), "
          f"t_end {t[-1]:g} ({c.time_label} = {t[-1] * c.rate:g}), {len(t)} rows")
    if c.units:
        print(f"units: {c.units}")
    if exact_at:
        print(f"probe at ({point[0]:g}, {point[1]:g}): p(0) {pp[0]:.6g} against the sine "
              f"series' {p0_exact:.6g} (X3/X4): {out['p0_error']:+.3e} {unit}; at the end "
              f"{pp[-1]:.6g}")
    else:
        print(f"probe 1: p(0) {pp[0]:.6g}, at the end {pp[-1]:.6g}")
    if "p_filt_end" in out:
        print(f"filtered (cut-off {how}, transition +-{tw:g}): at the end "
              f"{out['p_filt_end']:.6g}; RMS of the removed acoustic part "
              f"{out['p_acoustic_rms']:.3e} {unit}")
    else:
        print("filtered probe pressure: fewer than 4 samples, left out")
    change = "" if out["ke_change"] is None else f" ({100 * out['ke_change']:+.4f} %)"
    if exact_at:
        print(f"kinetic energy: {ke[0]:.6g} at the start ({100 * out['ke0_error']:+.4f} % from "
              f"the exact {ke0_exact:.6g}), {ke[-1]:.6g} at the end{change}")
    else:
        print(f"kinetic energy: {ke[0]:.6g} at the start, {ke[-1]:.6g} at the end{change}")
    for tt, m in out["outline"].items():
        print(f"free surface at {c.time_label} = {float(tt) * c.rate:g}: area "
              f"{m['area'] / c.length**2:.5f} L^2, perimeter {m['perimeter'] / c.length:.4f} L, "
              f"{m['curves']} closed curve(s)")
    r = out["reference"]
    if r is None:
        if c.square:
            print("reference solution: none given (--reference DIR, a run of "
                  "postproc/reference)")
    else:
        print(f"against the reference {args.reference}, {c.time_label} in "
              f"[0, {r['p_interval_end']:.3g}] (both probes in the fluid): probe pressure mean "
              f"|difference| raw {100 * r['p_raw_mean']:.3f} %, filtered "
              f"{100 * r['p_filtered_mean']:.3f} % of |p(0)| (to " + ", ".join(
                  f"{w}: {100 * v:.3f} %" for w, v in r["p_filtered_mean_to"].items())
              + f"); kinetic energy's relative change {100 * r['ke_change_difference_mean']:.3f} %")
    return 0


def main(argv=None, prog="postproc/errors"):
    """The command line (argv defaults to sys.argv[1:]): returns the exit
    status; a PostprocError becomes a one-line message and status 2."""
    return main_guard(PROG, lambda a: command(a, prog),
                         sys.argv[1:] if argv is None else argv)
