"""plots: the paper's figures from our runs or another code's (PNG, matplotlib Agg).

Subcommands:
  circle RUN_DIR      Figure 1 (circle2d): particles coloured by p/(rho A0^2 R^2)
                      at t = 0 and at the last snapshot with the exact ellipse
                      dashed; the centre pressure raw, filtered and exact.
  ellipsoid RUN_DIR   Figure 2 (ellipsoid3d): half of the domain at t = 0 and at
                      the last snapshot with the exact meridians and equator,
                      the central vertical cut, and the centre pressure.
  pressure RUN_DIR... a probe's pressure, raw and filtered, of one or more runs
                      (Figure 4: standard against higher-order runs of the
                      rotating square) with its reference curve when there is
                      one, and the spectrum of the part the filter removes with
                      the acoustic frequency marked.
  square RUN_DIR      Figures 3 and 5 (square patches): particles coloured by
                      pressure or vorticity at chosen times, with --ref the
                      reference's interface dashed.

Another code's output directory needs --case and, where its names or units
differ from ours, --fields and the unit options (doc/reference/postproc.md).

Each writes the PNG named by -o (default: RUN_DIR/<subcommand>.png).

Example:
  postproc/plots circle runs/circle2d -o doc/fig1.png
  postproc/plots pressure runs/sq_std runs/sq_ho --labels standard higher-order
"""
import argparse
import math
import os
import sys

from . import foreign
from .cli import main_guard
from .exceptions import PostprocError
from .figures import use_agg
from .filtering import add_filter_options, filter_from_args, filter_options, lowpass

PROG = "plots"


def marker_size(ax_width_in, extent, dx, fill=0.9):
    """Scatter marker area (points^2) so that a particle of spacing dx covers
    about its own share of an axis `ax_width_in` inches wide showing `extent`
    data units."""
    d_pt = fill * dx / extent * ax_width_in * 72
    return max(d_pt**2, 1.0)   # at least 1 point across, or the dots fade into the paper


def tex_time(c):
    """The case's time label in mathtext: $t A_0$, $t \\omega$, $t V_0/L$."""
    lab = c.time_label.replace("A0", "A_0").replace("omega", "\\omega").replace("V0", "V_0")
    return "$" + lab + "$"


UNIT_TEX = {"rho A0^2 R^2": r"$\rho A_0^2 R^2$", "rho omega^2 L^2": r"$\rho \omega^2 L^2$",
            "rho V0^2": r"$\rho V_0^2$"}


def pressure_panel(ax, run, fc, tw, label=None, raw=True, reference=None, color=None):
    """Raw (thin, light) and filtered (thick) probe pressure at the centre in
    the case's pressure unit, against t in the case's time unit; the exact /
    reference curve dashed."""
    import numpy as np
    c = run.case
    probe = run.centre_probe() or "p_probe_1"
    run.column(probe)
    # the probe's own samples: the time-series rows (another code's run: its
    # probe file, or one estimate per output file)
    t, p = run.probe_samples(probe)
    ref = reference or ("p_centre_exact" if "p_centre_exact" in run.ts else None)
    if ref == "p_centre_exact" and ref in run.ts:
        # an exact curve: the filtered pressure is P(t) + filter(p - P(t)),
        # the error filtered as postproc/errors does (sphpost.stretching_errors)
        _, _, pex = run.probe_signal(probe)
        tu, _, ef = lowpass(t, p - pex, fc, tw)
        pf = np.interp(tu, t, pex) + ef
    else:
        tu, _, pf = lowpass(t, p, fc, tw)
    lab = (label + ": ") if label else ""
    if raw:
        ax.plot(t * c.rate, p / c.p_unit, lw=0.6, alpha=0.45, color=color,
                label=f"{lab}SPH raw")
    ax.plot(tu * c.rate, pf / c.p_unit, lw=2.0, color=color, label=f"{lab}SPH filtered")
    if ref and ref in run.ts:
        tr, pr = (t, pex) if ref == "p_centre_exact" else (run.time, run.ts[ref])
        ax.plot(tr * c.rate, pr / c.p_unit, "k--", lw=1.2,
                label="exact (incompressible)" if ref == "p_centre_exact" else ref)
    ax.set_xlabel(tex_time(c))
    ax.set_ylabel(f"centre pressure / {UNIT_TEX.get(c.p_unit_label, c.p_unit_label)}")
    return np.nanmax(np.abs(p / c.p_unit))


def first_and_last(args, case, what):
    """The run of args.run_dir, which must be of `case` with at least two
    snapshots (for the plot `what`): the run, its filter's cut-off and
    transition, and its first and last snapshots."""
    run = foreign.open_run(args.run_dir, args)
    c = run.case
    if c.name != case:
        raise PostprocError(f"'{what}' plots {case} runs; {run.path} is {c.name}")
    if len(run.snapshots) < 2:
        raise PostprocError(f"{run.path} needs at least two snapshots (t = 0 and the end)")
    fc, tw, _ = filter_from_args(c, args)
    first, last = run.snapshot(0), run.snapshot(-1)
    for s in (first, last):
        # lengths in the case's scale (x / R) whatever the files' unit
        s["position"] = s["position"] / c.length
        for i in range(1, c.dim + 1):
            s["attrs"][f"semi_axes_exact_{i}"] = s["attrs"][f"semi_axes_exact_{i}"] / c.length
    if "pressure" not in first:
        raise PostprocError(f"{run.snapshots[0]}: no pressure, which '{what}' colours "
                               "the particles by")
    return run, fc, tw, first, last


def fig_circle(args):
    plt = use_agg()
    from matplotlib.patches import Ellipse
    run, fc, tw, s0, s1 = first_and_last(args, "circle2d", "circle")
    c = run.case
    t1 = s1["attrs"]["time"]
    fig = plt.figure(figsize=(13.5, 6.4))
    gs = fig.add_gridspec(1, 3, width_ratios=[1.5, 0.8, 2.1], wspace=0.42,
                          left=0.05, right=0.98, bottom=0.1, top=0.86)
    R = 1.0         # the positions are in units of R (first_and_last)
    for k, s in enumerate((s0, s1)):
        ax = fig.add_subplot(gs[0, k])
        a = [s["attrs"][f"semi_axes_exact_{i}"] for i in (1, 2)]
        lim = (1.15 * R, 1.15 * R) if k == 0 else (max(1.6 * a[0], 0.5 * R), 1.06 * a[1])
        x = s["position"]
        p = s["pressure"] / c.p_unit
        pc = s["attrs"]["p_centre_exact"] / c.p_unit
        ms = marker_size(5.0, 2 * lim[1], run.dx / c.length)
        # colours on the exact solution's range [0, P(t)]: SPH values outside
        # it (acoustic noise) saturate, as the colour bar's arrows show
        sc = ax.scatter(x[:, 0], x[:, 1], c=p, s=ms, cmap="viridis", linewidths=0,
                        vmin=0, vmax=pc, rasterized=True)
        ax.add_patch(Ellipse((0, 0), 2 * a[0], 2 * a[1], fill=False, ls="--", lw=1.3,
                             color="crimson", label="exact free surface"))
        ax.set_aspect("equal")
        ax.set_xlim(-lim[0], lim[0])
        ax.set_ylim(-lim[1], lim[1])
        ax.set_xlabel("x / R")
        ax.set_ylabel("y / R")
        ax.set_title(f"{tex_time(c)} = {s['attrs']['time'] * c.rate:.2f}")
        cb = fig.colorbar(sc, ax=ax, extend="both", pad=0.05, fraction=0.12,
                          shrink=0.75 if k == 0 else 1.0)
        cb.set_label(r"$p / (\rho A_0^2 R^2)$")
        if k == 0:
            ax.legend(loc="lower center", fontsize=8, bbox_to_anchor=(0.5, 1.07))
        else:
            ax.set_xticks([-0.4, 0.4])
    ax = fig.add_subplot(gs[0, 2])
    pressure_panel(ax, run, fc, tw)
    ax.set_title("pressure at the centre")
    ax.set_xlim(0, run.time[-1] * c.rate)
    ax.legend(fontsize=9)
    ax.grid(alpha=0.3)
    ax.text(0.98, 0.55, f"N = {run.n_particles:,}\n{c.c0_label}\n"
            f"filter cut-off {fc / c.rate:.3g} A0\n(= {fc / c.f_acoustic:.2g} x acoustic)",
            transform=ax.transAxes, ha="right", va="top", fontsize=9)
    fig.suptitle(f"Stretching circular patch (circle2d), N = {run.n_particles:,}: initial and "
                 f"final ({tex_time(c)} = {t1 * c.rate:.2f}) states, exact free surface dashed",
                 fontsize=12)
    return fig


def fig_ellipsoid(args):
    import numpy as np
    plt = use_agg()
    from matplotlib.patches import Ellipse
    run, fc, tw, s0, s1 = first_and_last(args, "ellipsoid3d", "ellipsoid")
    c = run.case
    fig = plt.figure(figsize=(13, 9))
    gs = fig.add_gridspec(2, 3, width_ratios=[1, 1, 0.8], height_ratios=[1.35, 1])
    th = np.linspace(0, 2 * np.pi, 200)
    half = np.linspace(-np.pi / 2, np.pi / 2, 100)
    pmax = max(np.max(s0["pressure"]), 1e-30) / c.p_unit
    for k, s in enumerate((s0, s1)):
        ax = fig.add_subplot(gs[0, k], projection="3d")
        a = [s["attrs"][f"semi_axes_exact_{i}"] for i in (1, 2, 3)]
        x = s["position"]
        keep = x[:, 1] <= 0          # half the domain: y <= 0, cut by the x-z plane
        p = s["pressure"][keep] / c.p_unit
        pc = s["attrs"]["p_centre_exact"] / c.p_unit
        sc = ax.scatter(x[keep, 0], x[keep, 1], x[keep, 2], c=p, s=2, cmap="viridis",
                        vmin=0, vmax=pc, linewidths=0, depthshade=False, rasterized=True)
        # exact surface: the meridians in the x-z plane (the cut) and in the
        # y-z plane (y <= 0 half), and the equator (y <= 0 half)
        ax.plot(a[0] * np.cos(th), 0 * th, a[2] * np.sin(th), "r-", lw=1.2,
                label="exact meridians, equator")
        ax.plot(0 * half, -a[1] * np.cos(half), a[2] * np.sin(half), "r-", lw=1.2)
        ax.plot(a[0] * np.sin(half), -a[1] * np.cos(half), 0 * half, "r-", lw=1.2)
        m = max(a)
        ext = [max(1.1 * v, 0.3 * m) for v in a]
        ax.set_xlim(-ext[0], ext[0])
        ax.set_ylim(-ext[1], ext[1])
        ax.set_zlim(-ext[2], ext[2])
        ax.set_box_aspect(ext)
        ax.view_init(elev=18, azim=60)     # from the +y side: the cut face y = 0
        from matplotlib.ticker import MaxNLocator
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_locator(MaxNLocator(3))
        ax.set_xlabel("x / R")
        ax.set_ylabel("y / R")
        ax.zaxis.set_rotate_label(False)
        ax.set_zlabel("z / R", rotation=90)
        ax.set_title(f"half domain ($y \\leq 0$), "
                     f"{tex_time(c)} = {s['attrs']['time'] * c.rate:.2f}")
        cb = fig.colorbar(sc, ax=ax, fraction=0.04, pad=0.08, shrink=0.7, extend="both")
        cb.set_label(r"$p / (\rho A_0^2 R^2)$")
        if k == 0:
            ax.legend(loc="upper left", fontsize=8)
    # central vertical cut at the end: particles within dx/2 of the x-z plane
    ax = fig.add_subplot(gs[0, 2])
    a = [s1["attrs"][f"semi_axes_exact_{i}"] for i in (1, 2, 3)]
    x = s1["position"]
    sel = np.abs(x[:, 1]) < 0.5 * run.dx / c.length
    sc = ax.scatter(x[sel, 0], x[sel, 2], c=s1["pressure"][sel] / c.p_unit, s=6,
                    cmap="viridis", linewidths=0, vmin=0,
                    vmax=s1["attrs"]["p_centre_exact"] / c.p_unit)
    ax.add_patch(Ellipse((0, 0), 2 * a[0], 2 * a[2], fill=False, ls="--", color="crimson",
                         lw=1.2, label="exact"))
    ax.set_aspect("equal")
    ax.set_xlim(-1.6 * a[0], 1.6 * a[0])
    ax.set_ylim(-1.05 * a[2], 1.05 * a[2])
    ax.set_xlabel("x / R")
    ax.set_ylabel("z / R")
    ax.set_title(f"cut $|y| < dx/2$, {tex_time(c)} = {s1['attrs']['time'] * c.rate:.2f}")
    ax.set_xticks([-0.5, 0.5] if a[0] > 0.4 else [-a[0], a[0]])
    cb = fig.colorbar(sc, ax=ax, fraction=0.1, extend="both")
    cb.set_label(r"$p / (\rho A_0^2 R^2)$")
    ax.legend(fontsize=8, loc="upper right")
    ax = fig.add_subplot(gs[1, :])
    pressure_panel(ax, run, fc, tw)
    ax.set_xlim(0, run.time[-1] * c.rate)
    ax.set_title("pressure at the centre")
    ax.legend(fontsize=9)
    ax.grid(alpha=0.3)
    fig.suptitle(f"Stretching sphere (ellipsoid3d), N = {run.n_particles:,}, "
                 f"{c.c0_label}, rates {run.nml.get('ellipsoid3d', {}).get('rates', '')}",
                 fontsize=12)
    fig.subplots_adjust(left=0.05, right=0.94, top=0.93, bottom=0.07, hspace=0.25, wspace=0.25)
    return fig


def fig_pressure(args):
    import numpy as np
    plt = use_agg()
    runs = [foreign.open_run(d, args) for d in args.run_dirs]
    labels = args.labels or [os.path.basename(r.path.rstrip("/")) for r in runs]
    if len(labels) != len(runs):
        raise PostprocError(f"--labels needs one label per run ({len(runs)})")
    fig, (ax, axs) = plt.subplots(2, 1, figsize=(10, 8), height_ratios=[1.6, 1])
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    c0 = runs[0].case
    for k, (run, lab) in enumerate(zip(runs, labels)):
        c = run.case
        if c.name != c0.name:
            raise PostprocError(f"the runs are of different cases ({c0.name}, {c.name})")
        fc, tw, _ = filter_from_args(c, args)
        col = colors[k % len(colors)]
        pressure_panel(ax, run, fc, tw, label=lab if len(runs) > 1 else None,
                       raw=not args.no_raw, reference=args.reference if k == 0 else "-",
                       color=col)
        probe = run.centre_probe() or "p_probe_1"
        tu, yu, yf = lowpass(*run.probe_samples(probe), fc, tw)
        rem = (yu - yf) / c.p_unit
        spec = np.abs(np.fft.rfft(rem * np.hanning(len(rem)))) * 2 / np.sum(np.hanning(len(rem)))
        freq = np.fft.rfftfreq(len(rem), tu[1] - tu[0]) / c.rate
        axs.plot(freq, spec, color=col, lw=1, label=lab)
    unit = c0.time_label.replace("t ", "")
    axs.axvline(c0.f_acoustic / c0.rate, color="k", ls=":",
                label=f"lowest acoustic frequency {c0.f_acoustic / c0.rate:.3g} {unit}")
    axs.axvline(fc / c0.rate, color="gray", ls="--",
                label=f"filter cut-off {fc / c0.rate:.3g} {unit}")
    axs.set_xlim(0, 4 * c0.f_acoustic / c0.rate)
    axs.set_xlabel(f"frequency (cycles per 1/{unit})")
    axs.set_ylabel(f"amplitude / {UNIT_TEX.get(c0.p_unit_label, c0.p_unit_label)}")
    axs.set_title("spectrum of the part removed by the filter (raw - filtered)")
    axs.legend(fontsize=9)
    axs.grid(alpha=0.3)
    ax.set_title(f"{c0.name}: pressure at the probe")
    ax.legend(fontsize=9)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def fig_square(args):
    import numpy as np
    plt = use_agg()
    run = foreign.open_run(args.run_dir, args)
    c = run.case
    if not c.square:
        raise PostprocError(f"'square' plots a square-patch run; {run.path} is {c.name}")
    if not run.snapshots:
        raise PostprocError(f"{run.path} has no snapshots")
    ref = None
    if getattr(args, "ref", None):
        from . import reference
        ref = reference.Reference(args.ref)
        reference.check_case(c, ref.setup)
    field = args.field or ("vorticity" if c.name == "square_vortical" else "pressure")
    times = args.times or ([0.0, 0.4, 1.5] if c.name == "square_vortical" else [0.0, 4.0])
    snap_t = run.snapshot_times() * c.rate
    fig, axes = plt.subplots(1, len(times), figsize=(4.6 * len(times), 4.8), squeeze=False)
    for ax, tw in zip(axes[0], times):
        i = int(np.argmin(np.abs(snap_t - tw)))
        s = run.snapshot(i)
        if field not in s and not args.field and "pressure" in s:
            field = "pressure"          # another code's files: no vorticity
        if field not in s:
            raise PostprocError(f"snapshot {run.snapshots[i]} has no dataset '{field}'")
        v = s[field] / (c.p_unit if field == "pressure" else c.rate)
        x = s["position"]
        # vorticity: a colour scale symmetric about 0
        if field == "pressure":      # 1st-99th percentiles: a few outliers would wash it out
            vmin, vmax = (float(q) for q in np.percentile(v, [1, 99]))
        else:                        # symmetric about 0, 99th percentile of |v| (same reason)
            vmax = float(np.percentile(np.abs(v), 99))
            vmin = -vmax
        ext = 1.1 * max(np.max(np.abs(x[:, 0])), np.max(np.abs(x[:, 1])))
        sc = ax.scatter(x[:, 0], x[:, 1], c=v, s=marker_size(3.8, 2 * ext, run.dx),
                        cmap="RdBu_r" if field != "pressure" else "viridis", linewidths=0,
                        vmin=vmin, vmax=vmax, rasterized=True)
        if ref is not None:
            # the reference's interface at this time, dashed (the paper's
            # Figure 3: the boundary-integral surface, or Gerris's 0.5 contour of T)
            lines = []
            for tr in ref.interface_times():
                if abs(snap_t[i] - tr) < 1e-6 * max(tr, 1.0):
                    lines = ref.interface(tr)
            for k, line in enumerate(lines):
                ax.plot(line[:, 0] * c.length, line[:, 1] * c.length, "k--", lw=0.9,
                        label=None if k else "reference interface")
            if lines:
                ax.legend(loc="lower left", fontsize=7)
        ax.set_aspect("equal")
        ax.set_xlim(-ext, ext)
        ax.set_ylim(-ext, ext)
        ax.set_xlabel("x / L")
        ax.set_ylabel("y / L")
        ax.set_title(f"{tex_time(c)} = {snap_t[i]:.2f}")
        cb = fig.colorbar(sc, ax=ax, fraction=0.046)
        unit = UNIT_TEX.get(c.p_unit_label) if field == "pressure" else \
            "(" + tex_time(c).replace("t ", "").replace("$t", "$") + ")"
        cb.set_label(f"{field} / {unit}")
    fig.suptitle(f"{c.name}, N = {run.n_particles:,}: particles coloured by {field}")
    fig.tight_layout()
    return fig


FIGURES = {"circle": fig_circle, "ellipsoid": fig_ellipsoid, "pressure": fig_pressure,
           "square": fig_square}


def save(args, echo=print):
    """Draws the figure args.what with the options args (as the command line
    parses them), writes it (-o, default RUN_DIR/<what>.png) and passes the
    line saying so to echo.  Returns the path written."""
    fig = FIGURES[args.what](args)
    first = args.run_dir if hasattr(args, "run_dir") else args.run_dirs[0]
    out = args.output or os.path.join(first, f"{args.what}.png")
    fig.savefig(out, dpi=args.dpi)
    use_agg().close(fig)     # callers in one process (validate) draw many figures
    echo(f"wrote {out}")
    return out


def draw(what, run_dirs, output=None, dpi=130, fopts=None, labels=None, reference=None,
         no_raw=False, field=None, times=None, echo=print, ref=None):
    """The figure `what` (circle, ellipsoid, pressure, square) of the run
    directories run_dirs (one, except for pressure), as the subcommand
    draws it with the same options; fopts: sphpost.filter_options (default
    the command line's); ref: a reference run directory (square).  Returns
    the path written."""
    if what != "pressure" and len(run_dirs) != 1:
        raise PostprocError(f"'{what}' plots one run, got {len(run_dirs)}")
    args = argparse.Namespace(what=what, output=output, dpi=dpi, labels=labels,
                              reference=reference, no_raw=no_raw, field=field, times=times,
                              ref=ref, **vars(fopts or filter_options()))
    if what == "pressure":
        args.run_dirs = list(run_dirs)
    else:
        args.run_dir = run_dirs[0]
    return save(args, echo)


def command(argv, prog="postproc/plots"):
    """The tool on the arguments argv (without the program name); prints its
    report and returns the exit status.  Raises PostprocError."""
    ap = argparse.ArgumentParser(prog=prog, description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="what", required=True, metavar="SUBCOMMAND")
    ps = {}
    for name, hlp in (("circle", "Figure 1: circle2d"), ("ellipsoid", "Figure 2: ellipsoid3d"),
                      ("square", "Figures 3 and 5: square patches")):
        p = sub.add_parser(name, help=hlp)
        p.add_argument("run_dir", help="the run directory")
        ps[name] = p
    p = sub.add_parser("pressure", help="probe pressure of one or more runs, and its spectrum")
    p.add_argument("run_dirs", nargs="+", metavar="RUN_DIR", help="run directories")
    p.add_argument("--labels", nargs="+", help="one legend label per run")
    p.add_argument("--reference", metavar="COLUMN",
                   help="time-series column of a reference curve "
                        "(default p_centre_exact if present)")
    p.add_argument("--no-raw", action="store_true", help="leave out the raw signals")
    foreign.add_options(p)
    ps["pressure"] = p
    ps["square"].add_argument("--field", help="dataset to colour by (default: vorticity for "
                              "square_vortical, pressure for square_rotation)")
    ps["square"].add_argument("--times", type=float, nargs="+",
                              help="times in the case's unit (default: the paper's)")
    ps["square"].add_argument("--ref", metavar="DIR",
                              help="a reference run (postproc/reference): its interface "
                              "dashed at the times it has")
    for name in ("circle", "ellipsoid", "square"):
        foreign.add_options(ps[name])
    for p in ps.values():
        p.add_argument("-o", "--output", metavar="PNG", help="output file")
        p.add_argument("--dpi", type=int, default=130)
        add_filter_options(p)
    args = ap.parse_args(argv)
    save(args)
    return 0


def main(argv=None, prog="postproc/plots"):
    """The command line (argv defaults to sys.argv[1:]): returns the exit
    status; a PostprocError becomes a one-line message and status 2."""
    return main_guard(PROG, lambda a: command(a, prog),
                         sys.argv[1:] if argv is None else argv)
