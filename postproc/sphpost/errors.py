"""errors: the paper's errors of a circle2d or ellipsoid3d run against the
exact solution, at the output times and averaged over time.

Prints a table over the snapshot times (or --times / --count), then the
time-averaged ("mean") absolute errors the paper quotes: semi-axes, particle
positions against the exact Lagrangian map, velocities, kinetic energy, and
the centre pressure raw and low-pass filtered (relative to P(0)).  The values
at the table's times are the solver's own time-series values (timeseries.csv);
--check-snapshots recomputes them from the HDF5 snapshots as a cross-check.

Example:
  postproc/errors runs/circle2d
  postproc/errors runs/circle2d --count 9 --csv errors.csv
"""
import argparse
import json
import math
import sys

from . import core as sp

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


def command(argv, prog="postproc/errors"):
    """The tool on the arguments argv (without the program name); prints its
    report and returns the exit status.  Raises PostprocError."""
    ap = argparse.ArgumentParser(
        prog=prog, description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir", help="the run directory (output.dir of an sph run)")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--times", type=float, nargs="+", metavar="T",
                   help="tabulate the rows nearest these times (default: the snapshot times)")
    g.add_argument("--count", type=int, metavar="N",
                   help="tabulate N rows evenly spread in time")
    ap.add_argument("--csv", metavar="FILE", help="also write the table as CSV")
    ap.add_argument("--json", action="store_true",
                    help="print the means and final values as JSON instead of the tables")
    ap.add_argument("--check-snapshots", action="store_true",
                    help="recompute position, velocity and kinetic-energy values from the "
                         "snapshots and report the largest difference from timeseries.csv")
    ap.add_argument("--velocity-split", action="store_true",
                    help="split each snapshot's RMS velocity error into a smooth part (fit by "
                         "cubic polynomials of the initial positions) and a particle-scale rest")
    sp.add_filter_options(ap)
    args = ap.parse_args(argv)

    import numpy as np
    run = sp.Run(args.run_dir)
    c = run.case
    fc, tw, how = sp.filter_from_args(c, args)
    res = sp.stretching_errors(run, fc, tw)
    if args.json:
        print(json.dumps({"run": run.path, "case": c.name, "n": run.n_particles,
                          "dx": run.dx, "t_end": float(run.time[-1]), "f_cut": fc,
                          "mean": res["mean"], "sample_mean": res["sample_mean"],
                          "final": res["final"]}, indent=1))
        return 0

    dim = c.dim
    ser = res["series"]
    rows = sp.row_indices(run, args.times, args.count)
    for n in c.notes:
        print(f"note: {n}")
    print(f"run {run.path}: {c.name}, {run.n_particles} particles, dx/R {run.dx / c.length:.4g}, "
          f"c0 {c.c0:g}, t_end {run.time[-1]:g}, {len(run.time)} time-series rows")
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
    cols = [f"axis {k}" for k in range(1, dim + 1)] + ["max|axis|", "pos", "vel", "KE"]
    keys = [f"axis_{k}" for k in range(1, dim + 1)] + ["axis_max", "pos", "vel", "ke"]
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
    if has_p:
        print(f"p filt is the filtered error filter(p - P(t)): the filter applied to the exact "
              f"P(t) alone would move it by {100 * res['mean']['p_filt_bias']:.4f} % of P(0) on "
              f"average ({100 * res['final']['p_filt_bias']:+.4f} % at the end), which this "
              f"leaves out")
        print(f"start-up dip: the raw centre pressure falls at most "
              f"{100 * res['dip']:.4f} % of P(0) below P(t) for {c.time_label} < "
              f"{sp.DIP_WINDOW:g}")
    print(f"compressibility floor (I2, doc/numerics.md): the weakly compressible slow "
          f"solution's own centre pressure departs from P(t) by {100 * res['mean']['slow']:.4f} "
          f"% of P(0) on average at c0 = {c.c0:g}; the filtered error does not converge below "
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
    if args.csv:
        import csv
        with open(args.csv, "w", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["time"] + [k.replace(" ", "_").replace("|", "") for k in cols])
            for r in table:
                wr.writerow([f"{v:.10g}" for v in r])
    return 0


def main(argv=None, prog="postproc/errors"):
    """The command line (argv defaults to sys.argv[1:]): returns the exit
    status; a PostprocError becomes a one-line message and status 2."""
    return sp.main_guard(PROG, lambda a: command(a, prog),
                         sys.argv[1:] if argv is None else argv)
