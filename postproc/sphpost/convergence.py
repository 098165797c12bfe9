"""convergence: errors of runs at several resolutions, their observed orders
of convergence, and a log-log plot.

Given run directories of the same case (circle2d or ellipsoid3d) at several
particle numbers, prints for each run N, the equivalent spacing
dx = (area/N)^(1/2) (2D) or (volume/N)^(1/3) (3D) in units of R, and the
errors of postproc/errors: time-averaged ("mean") semi-axis (largest of the
axes), RMS position, RMS velocity, raw and filtered centre pressure, and the
kinetic-energy change at the end; then the observed order between successive
resolutions, log(e_i/e_i+1)/log(dx_i/dx_i+1), and the least-squares slope of
log e against log dx.  Writes the errors against dx as a log-log PNG.

Runs of different lengths compare over a common interval [0, T] with
--until T (T in the flow's time, t A0).

Example:
  postproc/convergence runs/c1k runs/c5k runs/c20k runs/c80k -o conv.png
  postproc/convergence runs/c1k runs/c5k runs/c20k runs/c80k runs/c320k --until 0.5
"""
import argparse
import json
import sys

from . import foreign
from .cli import main_guard
from .exceptions import PostprocError
from .figures import use_agg
from .filtering import add_filter_options, filter_from_args
from .measures import observed_orders, stretching_errors

PROG = "convergence"

# (name in the errors dict, key of sphpost.stretching_errors, which average,
# column title, legend label)
QUANTITIES = [
    ("axis_max", "axis_max", "mean", "axis", "semi-axis (time mean, largest axis)"),
    ("pos", "pos", "mean", "pos", "RMS position vs Lagrangian map (time mean)"),
    ("vel", "vel", "mean", "vel", "RMS velocity (time mean)"),
    ("ke_mean", "ke", "mean", "KE mean", "kinetic energy error (time mean)"),
    ("ke", "ke", "final", "KE end", "kinetic energy change at the end"),
    ("p_raw", "p_raw", "mean", "p raw", "centre pressure, raw (time mean)"),
    ("p_filt", "p_filt", "mean", "p filt", "centre pressure, filtered (time mean)"),
]


def collect(runs, fopts):
    """Per run: N, dx/R and the chosen errors (absolute values, fractions)."""
    rows = []
    for run in runs:
        fc, tw, _ = filter_from_args(run.case, fopts)
        res = stretching_errors(run, fc, tw)
        e = {}
        for name, key, avg, _, _ in QUANTITIES:
            if key in res[avg]:
                e[name] = abs(res[avg][key])
        rows.append({"run": run.path, "n": run.n_particles, "dx": run.dx / run.case.length,
                     "t_end": float(run.time[-1]), "errors": e,
                     "filter_bias": res["mean"].get("p_filt_bias")})
    return rows


def command(argv, prog="postproc/convergence"):
    """The tool on the arguments argv (without the program name); prints its
    report and returns the exit status.  Raises PostprocError."""
    ap = argparse.ArgumentParser(prog=prog, description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dirs", nargs="+", metavar="RUN_DIR",
                    help="run directories of one case at several resolutions (any order), "
                         "ours or another code's (--case, doc/reference/postproc.md)")
    ap.add_argument("-o", "--output", metavar="PNG", default="convergence.png",
                    help="the log-log plot (default %(default)s)")
    ap.add_argument("--json", metavar="FILE", help="also write the table and orders as JSON")
    ap.add_argument("--title", help="title of the plot")
    ap.add_argument("--until", type=float, metavar="T",
                    help="compare the runs over [0, T] only, T in the flow's time (t A0): "
                         "runs that go further are cut at T, e.g. four full levels and "
                         "a fifth stopped at a checkpoint")
    add_filter_options(ap)
    foreign.add_options(ap)
    args = ap.parse_args(argv)
    if len(args.run_dirs) < 2:
        raise PostprocError("give at least two run directories (resolutions)")
    if args.until is not None and not args.until > 0:
        raise PostprocError(f"--until {args.until:g}: give a time above 0")
    runs = [foreign.open_run(d, args) for d in args.run_dirs]
    if args.until is not None:
        runs = [r.window(args.until) for r in runs]
    table = study(runs, args, args.output, args.title)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(table, f, indent=1)
    return 0


def study(runs, fopts, output="convergence.png", title=None, echo=print):
    """The convergence study of the Runs `runs` (one case, any order) with
    the filter options fopts (sphpost.filter_options or the parsed command
    line): passes each line of the report to echo and writes the plot
    `output`.  Returns what --json writes: {"case", "rows" (per run, by N:
    "run", "n", "dx" (/R), "t_end", "errors" (fractions), "filter_bias"),
    "orders" ({quantity: {"pairs", "lsq"}})}."""
    import numpy as np
    names = {r.case.name for r in runs}
    if len(names) > 1:
        raise PostprocError(f"the runs are of different cases: {', '.join(sorted(names))}")
    ends = {round(float(r.time[-1]), 9) for r in runs}
    if len(ends) > 1:
        print(f"warning: the runs end at different times {sorted(ends)}: their errors are not "
              "comparable (--until T compares them over [0, T])", file=sys.stderr)
    runs = sorted(runs, key=lambda r: r.n_particles)
    rows = collect(runs, fopts)
    case = runs[0].case
    keys = [q for q in QUANTITIES if all(q[0] in r["errors"] for r in rows)]
    h = [r["dx"] for r in rows]

    echo(f"{case.name}: {len(rows)} runs to {case.time_label} = {rows[0]['t_end'] * case.rate:g}; "
         "errors in % (time averages over the run but KE end, at the end)")
    echo(f"{'N':>9} {'dx/R':>8} " + " ".join(f"{q[3]:>8}" for q in keys))
    for r in rows:
        echo(f"{r['n']:9d} {r['dx']:8.5f} "
             + " ".join(f"{100 * r['errors'][q[0]]:8.4f}" for q in keys))
    orders = {}
    for q in keys:
        orders[q[0]] = observed_orders(h, [r["errors"][q[0]] for r in rows])
    echo("observed order of convergence in dx:")
    for i in range(len(rows) - 1):
        lab = f"{rows[i]['n']}->{rows[i + 1]['n']}"
        echo(f"{lab:>18} " + " ".join(f"{orders[q[0]][0][i]:8.2f}" for q in keys))
    echo(f"{'least squares':>18} " + " ".join(f"{orders[q[0]][1]:8.2f}" for q in keys))
    if rows[0].get("filter_bias") is not None:
        echo("filter bias on the exact curve (time mean, % of P(0)): " +
             ", ".join(f"{100 * r['filter_bias']:.3f}" for r in rows))

    plt = use_agg()
    fig, ax = plt.subplots(figsize=(8, 7))
    markers = "osD^vxP"
    for k, q in enumerate(keys):
        e = [100 * r["errors"][q[0]] for r in rows]
        ax.loglog(h, e, marker=markers[k % len(markers)],
                  label=f"{q[4]}: order {orders[q[0]][1]:.2f}")
    # reference slopes through the middle of the data
    hh = np.array([min(h), max(h)])
    allv = [100 * r["errors"][q[0]] for r in rows for q in keys if r["errors"][q[0]] > 0]
    mid = np.exp(np.mean(np.log(allv))) if allv else 1.0
    hm = np.sqrt(hh[0] * hh[1])
    for order, ls in ((1, ":"), (2, "--")):
        ax.loglog(hh, mid * (hh / hm) ** order, "k" + ls, lw=0.9, label=f"slope {order}")
    ax.set_xlabel(r"particle spacing $dx / R$")
    ax.set_ylabel("error (%)")
    ax.grid(True, which="both", alpha=0.3)
    from matplotlib.ticker import FuncFormatter, NullFormatter
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(FuncFormatter(
        lambda v, _: f"{v:g}" if f"{v:.1e}"[0] in "25" else ""))
    ax.set_xticks(h)
    ax.set_xticklabels([f"{d:.3g}\nN={r['n']:,}" for d, r in zip(h, rows)], fontsize=8)
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_title(title or f"{case.name}: convergence to {case.time_label} = "
                 f"{rows[0]['t_end'] * case.rate:g}, {case.c0_label}")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    fig.tight_layout()
    fig.savefig(output, dpi=130)
    plt.close(fig)      # callers in one process (validate) draw many figures
    echo(f"wrote {output}")
    return {"case": case.name, "rows": rows,
            "orders": {k: {"pairs": v[0], "lsq": v[1]} for k, v in orders.items()}}


def main(argv=None, prog="postproc/convergence"):
    """The command line (argv defaults to sys.argv[1:]): returns the exit
    status; a PostprocError becomes a one-line message and status 2."""
    return main_guard(PROG, lambda a: command(a, prog),
                         sys.argv[1:] if argv is None else argv)
