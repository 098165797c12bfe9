"""reference: the square patches computed by an independent incompressible
two-phase solver, Gerris, as the reference for any particle run.

  postproc/reference run CASE --level N      writes and runs the Gerris case, then analyses it
  postproc/reference run CASE --level N --resume
                                             continues a run stopped early from its newest
                                             complete checkpoint
  postproc/reference analyse DIR             analyses a finished Gerris run again
  postproc/reference study DIR DIR...        the reference's own resolution study
  postproc/reference compare RUN DIR         an sph run against a reference

CASE is square_rotation or square_vortical; the side, the rate (omega, V0),
rho0 and t_end are read from the case's input file (--input, default
input/CASE.nml), so that the reference and the SPH run describe the same
flow.  Gerris (Debian's gerris2D, Popinet 2003, 2009) solves the
incompressible Euler equations of two phases on an adaptive quadtree: a VOF
tracer T marks the dense phase (the square's fluid, density rho0), the light
phase (density --ratio rho0: 1e-3 rotating, 1e-4 vortical) stands for the
void; no gravity, no surface tension, no viscosity unless --viscosity or
--light-viscosity is given (doc/validation/reference.md says what was tried and why
these choices).

What `run` writes into DIR (default runs/reference/CASE/level_N), all plain
CSV with a header line, in the case's own units (doc/validation/reference.md):
  pressure.csv      t, p, p_far: the pressure at the case's probe (A = the
                    centre for the rotating square, (L/4, L/4) for the vortical
                    one) less the mean of the light phase's within three cells
                    of the interface (p), or less the light phase's at the far
                    corner (p_far), every 0.01 time units
  integrals.csv     t, area, kinetic_energy of the dense phase, every 0.01
  interface_T.csv   piece, x, y: the 0.5 contour of the volume fraction at the
                    case's interface times (1, 2, 3, 4 / omega; 0.4, 1.0, 1.2,
                    1.5 L/V0), one file per time
  cavities.csv      t, cavities, largest_cavity_area (vortical square): light-
                    phase regions enclosed by the dense phase
  summary.json      the settings, the initial probe pressure against the sine
                    series, the first cavity's time and the reconnection's (the
                    first cavity of at least 0.01 L^2), the area and energy drift,
                    the wall time
plus the Gerris input (sim.gfs), its log (gerris.log) and its last two
checkpoints (checkpoint-T.gfs, every CHECKPOINT_DT time units).  A resumed
run's tables continue the earlier ones: Gerris rewrites probe.dat and the other
tables from the checkpoint's time, so the earlier ones are kept as probe.dat.1,
probe.dat.2, ... and read as one series.
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

import numpy as np

import sphpost as sp

from . import cli, exact, figures, particles
from .cases import PROBES

PROG = "reference"
CASES = ("square_rotation", "square_vortical")

# The initial probe pressures by the sine series (doc/theory/ X3, X4), in
# rho omega^2 L^2 and rho V0^2: -0.147343 at A, -0.229452 at (L/4, L/4).
SERIES_P0 = {"square_rotation": float(exact.square_rotation_pressure(0.0, 0.0)[0]),
             "square_vortical": float(exact.square_vortical_pressure(0.25, 0.25)[0])}
# The times of the interfaces written, in the case's time unit.
INTERFACE_TIMES = {"square_rotation": (1.0, 2.0, 3.0, 4.0),
                   "square_vortical": (0.4, 1.0, 1.2, 1.5)}
# Where the vortical square's cavities are looked for, in t V0/L: the free
# surface reconnects at about 1.2 (the paper; our SPH runs: 1.195-1.226).
CAVITY_WINDOW = (1.1, 1.35)
# The scans' spacing there (default; --scan-dt): the first cavity's time is
# known to half of it.
CAVITY_DT = 0.0025
# The reconnection: the first cavity at least this large (in L^2).  The arms
# touching enclose 0.032 L^2 at once (levels 9 and 10); at 256 cells per L
# the interface also sheds light-phase bubbles of 0.0018-0.0034 L^2 before it.
RECONNECTION_AREA = 0.01
# The shorter windows [0, w] over which the study also compares the probe
# pressure (the rotating square's surface is Rayleigh-Taylor unstable, so
# that its later evolution depends on the grid: doc/validation/reference.md).
WINDOWS = {"square_rotation": (1.0, 1.5, 2.0), "square_vortical": (0.2,)}
# The filtered pressure is compared away from the ends of the record, where
# the filter's even extension bends it: over [TRIM, end - TRIM].
TRIM = 0.1
# Output spacing of the tabulated series, in the case's time unit.
DT_OUT = 0.01
# A checkpoint (Gerris's whole state, binary) every so many time units; the
# last CHECKPOINTS_KEPT complete ones are kept.
CHECKPOINT_DT = 0.05
CHECKPOINTS_KEPT = 2
# Samples whose step is shorter than this fraction of the median step around
# them are left out: Gerris shortens a step to land on an output time, and
# the projection's pressure after a very short step carries its residual
# divided by that step.
SHORT_STEP = 0.5


# The light phase's density over the dense phase's, by case (doc/validation/reference.md,
# "The light phase delays the reconnection"): for the vortical square at 128
# cells per L, 1e-4 gives 1e-5's reconnection to the scan and its probe
# pressure within 0.018 % of |p0|, while 1e-3 delays the reconnection by
# 1.2 %; the rotating square keeps 1e-3 (1e-4 moves its p_A by 0.08 % to
# t omega = 1, and stopped on a VOF assertion in one start tried).
DEFAULT_RATIO = {"square_rotation": 1e-3, "square_vortical": 1e-4}


class Setup:
    """A reference run's physical and numerical settings (ratio None: the
    case's DEFAULT_RATIO)."""

    def __init__(self, case, side, rate, rho0, t_end, level, ratio=None, light="continue",
                 light_viscosity=0.0, box=8.0, tolerance=1e-6, min_level=4, viscosity=0.0,
                 tension=0.0, scan_dt=CAVITY_DT):
        if case not in CASES:
            raise sp.PostprocError(f"case '{case}': the reference knows {', '.join(CASES)}")
        if ratio is None:
            ratio = DEFAULT_RATIO[case]
        self.case, self.side, self.rate, self.rho0 = case, side, rate, rho0
        self.t_end, self.level, self.ratio, self.light = t_end, level, ratio, light
        self.light_viscosity, self.box, self.tolerance = light_viscosity, box, tolerance
        self.min_level, self.viscosity, self.tension = min_level, viscosity, tension
        self.scan_dt = scan_dt
        for name, ok, what in (("level", 5 <= level <= 14, "5 <= level <= 14"),
                               ("ratio", 0 < ratio < 1, "0 < ratio < 1"),
                               ("light", light in ("rest", "continue"),
                                "'rest' or 'continue'"),
                               ("light_viscosity", light_viscosity >= 0,
                                "light_viscosity >= 0"),
                               ("viscosity", viscosity >= 0, "viscosity >= 0"),
                               ("tension", tension >= 0, "tension >= 0"),
                               ("scan_dt", 0 < scan_dt <= 0.05, "0 < scan_dt <= 0.05"),
                               ("box", box >= 2, "box >= 2 (in units of the side)")):
            if not ok:
                raise sp.PostprocError(f"--{name.replace('_', '-')} "
                                       f"{getattr(self, name)!r}: allowed {what}")

    method = "gerris"

    @property
    def dx(self):
        """The finest cell's side, in units of L."""
        return self.box / 2**self.level

    @property
    def resolution(self):
        return self.level

    @property
    def label(self):
        return f"Gerris, {1 / self.dx:g} cells per L"

    @property
    def probe(self):
        """The probe's position in units of L."""
        return PROBES[self.case]

    @property
    def p_unit(self):
        """The case's pressure unit: rho omega^2 L^2 or rho V0^2."""
        return self.rho0 * (self.rate * self.side) ** 2 if self.case == "square_rotation" \
            else self.rho0 * self.rate**2

    @property
    def time_unit(self):
        """1/omega or L/V0."""
        return 1.0 / self.rate if self.case == "square_rotation" else self.side / self.rate

    def as_dict(self):
        return {k: getattr(self, k) for k in ("case", "side", "rate", "rho0", "t_end", "level",
                                              "ratio", "light", "light_viscosity", "box",
                                              "tolerance", "min_level", "viscosity", "tension",
                                              "scan_dt")}

    @classmethod
    def from_input(cls, case, path, **kw):
        if not os.path.isfile(path):
            raise sp.PostprocError(f"input file '{path}' does not exist (run from the sph "
                                   "repository, or give --input)")
        nml = sp.read_namelist(path)
        name = str(nml.get("run", {}).get("case", case)).lower()
        if name != case:
            raise sp.PostprocError(f"{path}: run.case is '{name}', not '{case}'")
        c = sp.case_info(nml, case)
        rate = c.rate if case == "square_rotation" else c.rate * c.length   # omega or V0
        t_end = float(nml.get("run", {}).get("t_end", 4.0 if case == "square_rotation"
                                                else 1.5))
        return cls(case, c.length, rate, c.rho0, t_end, **kw)


# ---------------------------------------------------------------------------
# The Gerris input
# ---------------------------------------------------------------------------

def _velocity(s):
    """The initial velocity (U, V) as Gerris expressions of x and y (doc/theory/
    X3, X4), and the indicator of the square."""
    h = s.side / 2
    inside = f"(fabs(x) < {h!r} && fabs(y) < {h!r})"
    if s.case == "square_rotation":
        u, v = f"{s.rate!r}*y", f"-{s.rate!r}*x"
        if s.light == "continue":
            # rigid rotation within the circle through the corners, r_c = L/sqrt(2),
            # the potential vortex of the same circulation outside: the light
            # phase's own pressure then falls off as 1/r^2 instead of growing
            # as r^2 towards the walls
            rc2 = s.side**2 / 2
            g = f"(x*x + y*y < {rc2!r} ? 1. : {rc2!r}/(x*x + y*y))"
            u, v = f"{g}*{u}", f"{g}*{v}"
    else:
        k = 4.0 / s.side
        u = f"{s.rate!r}*(exp(-{k!r}*{k!r}*y*y) - exp(-4.))"
        v = f"-{s.rate!r}*(exp(-{k!r}*{k!r}*x*x) - exp(-4.))"
    if s.light == "rest":
        u, v = f"({inside} ? {u} : 0.)", f"({inside} ? {v} : 0.)"
    return u, v


def gerris_file(s):
    """The Gerris simulation file of a Setup."""
    L = s.side
    h = L / 2
    box = s.box * L
    u, v = _velocity(s)
    xp, yp = (c * L for c in s.probe)
    far = 0.45 * box
    # 1/density: the dense phase rho0, the light one ratio rho0, arithmetic
    # in the cells the interface cuts (T1: T smoothed once, Gerris's
    # recommendation for density ratios of 1000)
    alpha = f"1./({s.rho0!r}*(T1 + {s.ratio!r}*(1. - T1)))"
    visc = ""
    if s.light_viscosity > 0 or s.viscosity > 0:
        # the dynamic viscosity: rho0 nu in the dense phase, rho_light (nu +
        # nu_light) in the light one
        nu = s.side**2 / s.time_unit                  # omega L^2 or V0 L
        mu_d = s.rho0 * s.viscosity * nu
        mu_l = s.ratio * s.rho0 * (s.viscosity + s.light_viscosity) * nu
        visc = f"  SourceViscosity ({mu_d!r}*T1 + {mu_l!r}*(1. - T1))\n"
    vof, tension = "VariableTracerVOF T", ""
    if s.tension > 0:
        # surface tension sigma = tension p_unit L, the curvature by height
        # functions (Popinet, J. Comput. Phys. 228, 2009)
        vof = "VariableTracerVOFHeight T\n  VariableCurvature K T"
        tension = f"  SourceTension T {s.tension * s.p_unit * s.side!r} K\n"
    # the light phase's cells within three cells of the interface: their
    # mean pressure is the surface's, the reference of the probe's
    band = "(T < 1e-6 && T3 > 1e-6 ? 1. : 0.)"
    times = INTERFACE_TIMES[s.case]
    outs = "".join(
        f"  OutputSimulation {{ start = {t * s.time_unit!r} }} field-{t:g}.txt "
        "{ format = text variables = T,P,U,V }\n" for t in times if t * s.time_unit
        <= s.t_end * (1 + 1e-12))
    if s.case == "square_vortical":
        t0, t1 = (t * s.time_unit for t in CAVITY_WINDOW)
        outs += (f"  OutputSimulation {{ step = {s.scan_dt * s.time_unit!r} start = {t0!r} "
                 f"end = {t1!r} }} scan-%g.txt {{ format = text variables = T }}\n")
    return f"""# {s.case}: reference by postproc/reference (sph), {json.dumps(s.as_dict())}
1 0 GfsSimulation GfsBox GfsGEdge {{}} {{
  PhysicalParams {{ L = {box!r} }}
  Time {{ end = {s.t_end * s.time_unit!r} }}
  Refine (fabs(x) < {0.6 * L!r} && fabs(y) < {0.6 * L!r} ? {s.level} : {s.min_level})
  {vof}
  VariableFiltered T1 T 1
  VariableFiltered T3 T 3
  InitFraction T ({{ return MIN({h!r} - fabs(x), {h!r} - fabs(y)); }})
  Init {{}} {{ U = {u} V = {v} }}
  PhysicalParams {{ alpha = {alpha} }}
{visc}{tension}  ApproxProjectionParams {{ tolerance = {s.tolerance!r} }}
  ProjectionParams {{ tolerance = {s.tolerance!r} }}
  AdaptFunction {{ istep = 1 }} {{ cmax = 0.01 maxlevel = {s.level} minlevel = {s.min_level} }} T
  AdaptGradient {{ istep = 1 }} {{ cmax = 1e-3 maxlevel = {s.level} minlevel = {s.min_level} }} T
  OutputTime {{ istep = 10 }} stderr
  OutputLocation {{ istep = 1 }} probe.dat {{ {xp!r} {yp!r} 0 }}
  OutputLocation {{ istep = 1 }} far.dat {{ {far!r} {far!r} 0 }}
  OutputScalarSum {{ istep = 1 }} area.dat {{ v = T }}
  OutputScalarSum {{ istep = 1 }} band.dat {{ v = {band} }}
  OutputScalarSum {{ istep = 1 }} band_p.dat {{ v = {band}*P }}
  OutputScalarSum {{ istep = 1 }} energy.dat {{ v = {0.5 * s.rho0!r}*T*(U*U + V*V) }}
{outs}  OutputSimulation {{ step = {CHECKPOINT_DT * s.time_unit!r} }} checkpoint-%g.gfs
}}
GfsBox {{}}
"""


# ---------------------------------------------------------------------------
# Running Gerris
# ---------------------------------------------------------------------------

def checkpoints(out_dir):
    """The checkpoints in out_dir as a sorted list of (t, path), t in
    Gerris's time."""
    found = []
    for name in os.listdir(out_dir):
        m = re.match(r"checkpoint-(.*)\.gfs$", name)
        if m:
            found.append((float(m.group(1)), os.path.join(out_dir, name)))
    return sorted(found)


_STEP = re.compile(r"step:\s*(\d+)\s+t:\s*(\S+)\s+dt:\s*(\S+)")


def _last_logged_time(out_dir):
    """The time of the last step gerris.log reports (-inf without one)."""
    t = -math.inf
    path = os.path.join(out_dir, "gerris.log")
    if os.path.isfile(path):
        with open(path, errors="replace") as f:
            for line in f:
                m = _STEP.search(line)
                if m:
                    t = float(m.group(2))
    return t


def complete_checkpoints(out_dir, t_log=None):
    """The checkpoints written completely: those before the last step the
    log reports, t_log (read from gerris.log unless given; Gerris writes an
    output within its step, so a later step means the file was closed)."""
    if t_log is None:
        t_log = _last_logged_time(out_dir)
    return [c for c in checkpoints(out_dir) if c[0] < t_log]


def _prune_checkpoints(out_dir, t_log):
    """Removes all but the last CHECKPOINTS_KEPT checkpoints complete at the
    logged step t_log."""
    for _, path in complete_checkpoints(out_dir, t_log)[:-CHECKPOINTS_KEPT]:
        os.remove(path)


def _segments(path):
    """The files of one Gerris table across resumed runs: path.1, path.2, ...
    (the earlier runs'), then path itself."""
    k, found = 1, []
    while os.path.isfile(f"{path}.{k}"):
        found.append(f"{path}.{k}")
        k += 1
    return found + ([path] if os.path.isfile(path) else [])


def _join_segments(parts):
    """Rows (t first) of successive segments as one series: each segment is
    cut where the next one starts (the resumed run writes again from its
    checkpoint's time)."""
    parts = [a for a in parts if len(a)]
    for k in range(len(parts) - 1):
        parts[k] = parts[k][parts[k][:, 0] < parts[k + 1][0, 0]]
    return np.concatenate(parts) if parts else np.zeros((0, 2))


def run_gerris(s, out_dir, echo=print, progress_interval=30.0, resume=False):
    """Writes sim.gfs into out_dir and runs gerris2D there, its messages to
    gerris.log; prints the progress with an ETA every progress_interval
    seconds.  With resume, continues the run in out_dir (which must have
    the same settings) from its newest complete checkpoint.  Returns the
    wall time, the earlier runs' included."""
    exe = shutil.which("gerris2D")
    if exe is None:
        raise sp.PostprocError("gerris2D not found: install Debian's packages gerris and "
                               "libgfs-dev (setup.sh does)")
    t_end = s.t_end * s.time_unit
    t0, segment = 0.0, 0
    if resume:
        old = load_setup(out_dir)
        diff = [k for k, v in s.as_dict().items() if old.as_dict()[k] != v]
        if diff:
            raise sp.PostprocError(f"--resume: {out_dir} was run with other settings ("
                                   + ", ".join(f"{k} {old.as_dict()[k]!r} not {getattr(s, k)!r}"
                                               for k in diff) + ")")
        done = complete_checkpoints(out_dir)
        if not done:
            raise sp.PostprocError(f"--resume: {out_dir} has no complete checkpoint (one is "
                                   f"written every {CHECKPOINT_DT:g} time units): run it again "
                                   "without --resume")
        t0, start_file = done[-1]
        # the earlier runs' tables become segments; Gerris writes them anew
        # from t0
        while os.path.isfile(os.path.join(out_dir, f"wall-{segment}.txt")):
            segment += 1
        for name in sorted(os.listdir(out_dir)):
            if name.endswith(".dat"):
                path = os.path.join(out_dir, name)
                os.replace(path, f"{path}.{len(_segments(path))}")
        echo(f"  resuming from {os.path.basename(start_file)} (t {t0 / s.time_unit:g})")
    else:
        os.makedirs(out_dir, exist_ok=True)
        for old in os.listdir(out_dir):
            if re.match(r"(field|scan)-.*\.txt$|.*\.dat(\.\d+)?$|.*\.csv$|summary\.json$|"
                        r"checkpoint-.*\.gfs$|wall-\d+\.txt$", old):
                os.remove(os.path.join(out_dir, old))
        with open(os.path.join(out_dir, "sim.gfs"), "w") as f:
            f.write(gerris_file(s))
        start_file = os.path.join(out_dir, "sim.gfs")
    earlier = sum(float(open(os.path.join(out_dir, f"wall-{k}.txt")).read() or 0)
                  for k in range(segment))
    wall_file = os.path.join(out_dir, f"wall-{segment}.txt")
    start = last = time.monotonic()

    def note_wall():
        with open(wall_file, "w") as f:
            f.write(f"{time.monotonic() - start:.1f}\n")

    with open(os.path.join(out_dir, "gerris.log"), "a" if resume else "w") as log:
        proc = subprocess.Popen([exe, os.path.basename(start_file)], cwd=out_dir, stdout=log,
                                stderr=subprocess.PIPE, text=True)
        try:
            for line in proc.stderr:
                log.write(line)
                log.flush()
                m = _STEP.search(line)
                if not m:
                    continue
                t = float(m.group(2))
                # the step just logged: the checkpoints before it are complete
                _prune_checkpoints(out_dir, t)
                now = time.monotonic()
                if now - last >= progress_interval:
                    last = now
                    note_wall()
                    eta = (f"{(now - start) * (t_end - t) / (t - t0):8.1f} s" if t > t0
                           else "unknown")
                    echo(f"  step {int(m.group(1)):7d}  t {t / s.time_unit:8.4f}  "
                         f"dt {float(m.group(3)):.3e}  wall {earlier + now - start:8.1f} s  "
                         f"ETA {eta}")
        except KeyboardInterrupt:
            proc.terminate()
            proc.wait()
            raise
        rc = proc.wait()
    note_wall()
    wall = earlier + time.monotonic() - start
    if rc != 0:
        raise sp.PostprocError(f"gerris2D stopped with status {rc} in {out_dir}: see its "
                               "gerris.log (postproc/reference run ... --resume continues "
                               "from its newest checkpoint)")
    return wall


# ---------------------------------------------------------------------------
# Reading Gerris's outputs
# ---------------------------------------------------------------------------

def _columns(path):
    """A Gerris table (OutputLocation, text OutputSimulation): {name: array}
    from its header '# 1:t 2:x ...'."""
    files = _segments(path)
    if not files:
        raise sp.PostprocError(f"{path} is missing: did the Gerris run finish?")
    with open(files[-1]) as f:
        head = f.readline()
    names = [m.group(2) for m in re.finditer(r"(\d+):(\S+)", head)]
    data = _join_segments([np.loadtxt(f, comments="#", ndmin=2) for f in files])
    if data.shape[0] == 0 or data.shape[1] < len(names):
        raise sp.PostprocError(f"{path} has no rows or fewer columns than its header")
    return {n: data[:, k] for k, n in enumerate(names)}


def _sums(path):
    """An OutputScalarSum file as arrays (t, sum)."""
    files = _segments(path)
    if not files:
        raise sp.PostprocError(f"{path} is missing: did the Gerris run finish?")
    pat = re.compile(r"time:\s*(\S+)\s+sum:\s*(\S+)")
    a = _join_segments([np.array([tuple(float(v) for v in m.groups())
                                  for m in map(pat.search, open(f)) if m]).reshape(-1, 2)
                        for f in files])
    if not len(a):
        raise sp.PostprocError(f"{path} has no 'time: ... sum: ...' lines")
    return a[:, 0], a[:, 1]


def pressure_samples(t, p):
    """The samples p(t) of a probe pressure at the middle of each step
    (Gerris's projection pressure belongs to t - dt/2 of the output at t),
    without the first output (before any projection) and those after a short
    step (SHORT_STEP).  Returns (t, p, number of samples dropped)."""
    dt = np.diff(t)
    tm, p = t[1:] - dt / 2, p[1:]
    n = len(dt)
    med = np.array([np.median(dt[max(0, k - 10):k + 11]) for k in range(n)])
    keep = dt >= SHORT_STEP * med
    return tm[keep], p[keep], int(n - keep.sum())


def surface_pressure(ref_dir, t):
    """The mean pressure of the light phase's cells within three cells of the
    interface, at the probe's output times t."""
    tb, band = _sums(os.path.join(ref_dir, "band.dat"))
    tp, band_p = _sums(os.path.join(ref_dir, "band_p.dat"))
    if len(tb) != len(t) or len(tp) != len(t) or np.any(np.abs(tb - t) > 1e-9 * (1 + t)):
        raise sp.PostprocError(f"{ref_dir}: band.dat, band_p.dat and probe.dat are not "
                               "at the same times: did the Gerris run finish?")
    return band_p / np.maximum(band, 1e-300)


def tabulate(t, y, t_end, dt=DT_OUT, t0_value=None):
    """y(t) every dt over [0, t_end] by linear interpolation; t0_value (if
    given) is the value at t = 0."""
    grid = np.round(np.arange(0.0, t_end + dt / 2, dt), 10)
    if t0_value is not None and t[0] > 0:
        t, y = np.concatenate(([0.0], t)), np.concatenate(([t0_value], y))
    return grid, np.interp(grid, t, y)


def initial_value(t, p, window):
    """p(0) by a least-squares line through the samples of the first `window`
    time units."""
    sel = t <= window
    if sel.sum() < 3:
        sel = np.arange(len(t)) < 3
    c = np.polyfit(t[sel], p[sel], 1)
    return float(np.polyval(c, 0.0))


def fraction_grid(cells, s):
    """The volume fraction on the uniform grid of the finest cells, cropped to
    the cells that hold dense phase with a margin of light phase: (x0, y0,
    dx, T[j, i]).  A coarser cell (in the light phase, or a wisp of dense
    phase below the refinement threshold) fills the fine cells it covers."""
    dx = s.dx * s.side
    half = s.box * s.side / 2
    x, y, T = cells["x"] + half, cells["y"] + half, np.clip(cells["T"], 0.0, 1.0)
    # (Gerris writes 6 significant digits: the centres are on the grid to
    # within a few hundredths of a cell)
    size = np.zeros(len(T), dtype=int)          # the cell's side in fine cells
    for k in range(s.level + 1):
        w = 2**k
        ix, iy = x / (w * dx) - 0.5, y / (w * dx) - 0.5
        hit = (size == 0) & (np.abs(ix - np.round(ix)) < 0.05) & \
            (np.abs(iy - np.round(iy)) < 0.05)
        size[hit] = w
    if (size == 0).any():
        raise sp.PostprocError("cells whose centres are not on Gerris's grid: the box or "
                               "the level of sim.gfs does not match the output")
    i0c = np.round(x / dx - size / 2).astype(int)     # the first fine cell covered
    j0c = np.round(y / dx - size / 2).astype(int)
    dense = T > 1e-6
    if not dense.any():
        raise sp.PostprocError("no cell holds dense phase")
    lo_i, hi_i = i0c[dense].min() - 2, (i0c + size)[dense].max() + 2
    lo_j, hi_j = j0c[dense].min() - 2, (j0c + size)[dense].max() + 2
    grid = np.zeros((hi_j - lo_j, hi_i - lo_i))
    for c in np.nonzero(dense)[0]:
        grid[max(j0c[c] - lo_j, 0):j0c[c] + size[c] - lo_j,
             max(i0c[c] - lo_i, 0):i0c[c] + size[c] - lo_i] = T[c]
    return -half + (lo_i + 0.5) * dx, -half + (lo_j + 0.5) * dx, dx, grid


# the `level` contour of a grid as polylines (the particles' free surface
# uses the same tracer)
contour = particles.contour

def cavities(grid, min_cells=4):
    """The light-phase regions (T < 0.5, 4-connected) that the dense phase
    encloses: not touching the grid's border, of at least min_cells cells.
    Returns their sizes in cells."""
    from scipy import ndimage
    lab, n = ndimage.label(grid < 0.5)
    border = set(np.unique(np.concatenate((lab[0], lab[-1], lab[:, 0], lab[:, -1]))))
    sizes = ndimage.sum_labels(np.ones_like(grid), lab, index=np.arange(1, n + 1))
    return [int(sz) for k, sz in zip(range(1, n + 1), sizes)
            if k not in border and sz >= min_cells]


def write_csv(path, header, rows, comment=None, digits=9):
    """A CSV file written completely or not at all (a '#' comment line
    first, if given; floats to `digits` significant digits)."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        if comment:
            f.write(comment.rstrip("\n") + "\n")
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(f"{v:.{digits}g}" if isinstance(v, float) else str(v) for v in r)
                    + "\n")
    os.replace(tmp, path)


def read_csv(path):
    if not os.path.isfile(path):
        raise sp.PostprocError(f"{path} is missing: analyse the reference run first")
    with open(path) as f:
        skip = 0
        while f.readline().startswith("#"):
            skip += 1
    a = np.genfromtxt(path, delimiter=",", names=True, skip_header=skip)
    return {n: np.atleast_1d(a[n]) for n in a.dtype.names}


def load_setup(ref_dir):
    """A reference directory's settings: a boundary-integral run's
    (setup.json, sphpost.bem) or a Gerris run's (the first line of sim.gfs)."""
    bem_json = os.path.join(ref_dir, "setup.json")
    if os.path.isfile(bem_json):
        from . import bem
        with open(bem_json) as f:
            d = json.load(f)
        d.pop("method", None)
        return bem.BemSetup(**d)
    path = os.path.join(ref_dir, "sim.gfs")
    if not os.path.isfile(path):
        raise sp.PostprocError(f"'{ref_dir}' has no sim.gfs: is it a reference run directory?")
    with open(path) as f:
        first = f.readline()
    m = re.search(r"(\{.*\})\s*$", first)
    if not m:
        raise sp.PostprocError(f"{path}: its first line does not hold the settings")
    return Setup(**json.loads(m.group(1)))


def analyse(ref_dir, echo=print, wall=None, partial=False):
    """Turns a finished Gerris run into the CSV files and summary.json.  With
    partial, a run still going (or stopped early) is analysed up to its last
    output time on the DT_OUT grid, less one output (its newest files may be
    half written): the series end there, the interfaces and cavity scans
    after it are left out, and the summary's partial_until says where."""
    s = load_setup(ref_dir)
    tu, pu = s.time_unit, s.p_unit
    t_end = s.t_end
    tl = "t omega" if s.case == "square_rotation" else "t V0/L"
    probe = _columns(os.path.join(ref_dir, "probe.dat"))
    far = _columns(os.path.join(ref_dir, "far.dat"))
    if partial:
        last = min(probe["t"][-1], far["t"][-1]) / tu
        t_end = min(s.t_end, math.floor(last / DT_OUT + 1e-9) * DT_OUT - DT_OUT)
        if t_end < 2 * DT_OUT:
            raise sp.PostprocError(f"{ref_dir}: the Gerris run has not reached "
                                   f"{tl} = {3 * DT_OUT:g} yet")
    elif probe["t"][-1] < s.t_end * tu * (1 - 1e-9):
        raise sp.PostprocError(f"{ref_dir}: the Gerris run ends at t = {probe['t'][-1]:g}, "
                               f"before t_end = {s.t_end * tu:g} (postproc/reference analyse "
                               "--partial analyses it as far as it went)")
    tg = probe["t"]

    def tabulated(p_ambient):
        """The probe's pressure less p_ambient every DT_OUT, p(0) and the
        samples dropped."""
        t, p, dropped = pressure_samples(tg, probe["P"] - p_ambient)
        t, p = t / tu, p / pu
        p0 = initial_value(t, p, 0.02)
        return tabulate(t, p, t_end, t0_value=p0), p0, dropped

    (grid_t, grid_p), p0, dropped = tabulated(surface_pressure(ref_dir, tg))
    # the same against the light phase at the far corner, for comparison
    (_, grid_pf), _, _ = tabulated(far["P"])
    # no pressure where the probe is in the light phase (the vortical square's
    # probe at (L/4, L/4) is left by the fluid at about t V0/L = 0.39)
    wet = np.interp(grid_t, tg / tu, probe["T"]) >= 0.5
    grid_p, grid_pf = np.where(wet, grid_p, np.nan), np.where(wet, grid_pf, np.nan)
    write_csv(os.path.join(ref_dir, "pressure.csv"), ("t", "p", "p_far"),
              zip(grid_t, grid_p, grid_pf))
    ta, area = _sums(os.path.join(ref_dir, "area.dat"))
    te, energy = _sums(os.path.join(ref_dir, "energy.dat"))
    ga = np.interp(grid_t, ta / tu, area / s.side**2)
    ke_unit = s.rho0 * (s.rate * s.side**2) ** 2 if s.case == "square_rotation" \
        else s.rho0 * s.rate**2 * s.side**2
    ge = np.interp(grid_t, te / tu, energy / ke_unit)
    write_csv(os.path.join(ref_dir, "integrals.csv"), ("t", "area", "kinetic_energy"),
              zip(grid_t, ga, ge))
    interfaces = {}
    for tk in INTERFACE_TIMES[s.case]:
        path = os.path.join(ref_dir, f"field-{tk:g}.txt")
        if tk > t_end * (1 + 1e-12):
            continue
        x0, y0, dx, g = fraction_grid(_columns(path), s)
        lines = contour(x0, y0, dx, g)
        rows = [(k, float(x), float(y)) for k, c in enumerate(lines) for x, y in c / s.side]
        write_csv(os.path.join(ref_dir, f"interface_{tk:g}.csv"), ("piece", "x", "y"), rows)
        interfaces[f"{tk:g}"] = {"pieces": len(lines), "cavities": len(cavities(g))}
    first_cavity = reconnection = None
    if s.case == "square_vortical":
        scans = []
        for name in os.listdir(ref_dir):
            m = re.match(r"scan-(.*)\.txt$", name)
            if m and float(m.group(1)) <= t_end * tu * (1 + 1e-9):
                scans.append((float(m.group(1)), os.path.join(ref_dir, name)))
        rows = []
        for tk, path in sorted(scans):
            x0, y0, dx, g = fraction_grid(_columns(path), s)
            cav = cavities(g)
            rows.append((tk / tu, len(cav), float(max(cav, default=0) * dx**2 / s.side**2)))
        if rows:
            write_csv(os.path.join(ref_dir, "cavities.csv"),
                      ("t", "cavities", "largest_cavity_area"), rows)
            first_cavity = first_scan(rows, 0.0)
            reconnection = first_scan(rows, RECONNECTION_AREA)
    steps = len(probe["t"]) - 1
    summary = {
        "settings": s.as_dict(),
        "cells_per_side": 1.0 / s.dx,
        "steps": steps,
        "smallest_step": float(np.min(np.diff(probe["t"])) / tu),
        "pressure_samples_dropped": dropped,
        "p_probe_initial": p0,
        "p_probe_series": SERIES_P0[s.case],
        "p_probe_initial_error": p0 / SERIES_P0[s.case] - 1,
        "area_drift_max": float(np.max(np.abs(ga / ga[0] - 1))),
        "kinetic_energy_change_end": float(ge[-1] / ge[0] - 1),
        "interfaces": interfaces,
        "first_cavity": first_cavity,
        "reconnection": reconnection,
    }
    if t_end < s.t_end:
        summary["partial_until"] = t_end
    if wall is not None:
        summary["wall_time_s"] = wall
    else:
        old = os.path.join(ref_dir, "summary.json")
        if os.path.isfile(old):
            with open(old) as f:
                w = json.load(f).get("wall_time_s")
            if w is not None:
                summary["wall_time_s"] = w
    tmp = os.path.join(ref_dir, "summary.json.tmp")
    with open(tmp, "w") as f:
        json.dump(summary, f, indent=1)
    os.replace(tmp, os.path.join(ref_dir, "summary.json"))
    echo(f"{s.case} reference, level {s.level} ({1 / s.dx:g} cells per L), {steps} steps"
         + (f", {summary['wall_time_s']:.0f} s" if "wall_time_s" in summary else "")
         + (f"; partial: to {tl} = {t_end:g} of {s.t_end:g}" if t_end < s.t_end
            else ""))
    echo(f"  initial probe pressure {p0:.6f} (series {SERIES_P0[s.case]:.6f}: "
         f"{100 * summary['p_probe_initial_error']:+.3f} %)")
    echo(f"  area drift at most {100 * summary['area_drift_max']:.4f} %, kinetic energy "
         f"change at the end {100 * summary['kinetic_energy_change_end']:+.3f} %")
    if s.case == "square_vortical":
        echo(f"  first cavity at t V0/L = {first_cavity}, reconnection (a cavity of at least "
             f"{RECONNECTION_AREA:g} L^2) at {reconnection}")
    return summary


# ---------------------------------------------------------------------------
# Comparing references (the resolution study) and runs with a reference
# ---------------------------------------------------------------------------

def first_scan(rows, min_area):
    """The time of the first scan (t, cavities, largest area) with a cavity
    larger than min_area: half-way between it and the scan before it; None
    without one."""
    hit = [k for k, r in enumerate(rows) if r[1] > 0 and r[2] > min_area]
    if not hit:
        return None
    k = hit[0]
    return 0.5 * (rows[k][0] + rows[k - 1][0]) if k > 0 else rows[k][0]


def read_interface(path):
    """An interface file as a list of (n, 2) polylines."""
    d = read_csv(path)
    return [np.column_stack((d["x"][d["piece"] == k], d["y"][d["piece"] == k]))
            for k in np.unique(d["piece"])]


def tip_radius(lines):
    """The free surface's farthest point from the centre (the arm tips; the
    square's corners at the start), in the lines' unit."""
    return max(float(np.max(np.hypot(c[:, 0], c[:, 1]))) for c in lines if len(c))


def densify(lines, ds):
    """The points of polylines resampled at a spacing of at most ds."""
    pts = []
    for c in lines:
        seg = np.diff(c, axis=0)
        n = np.maximum(1, np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / ds).astype(int))
        for k in range(len(seg)):
            w = np.arange(n[k])[:, None] / n[k]
            pts.append(c[k] + w * seg[k])
        pts.append(c[-1:])
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def curve_distance(a, b, ds=1e-3):
    """Mean and largest distance between two sets of polylines: each point of
    one (resampled at ds) to the nearest point of the other, both ways."""
    from scipy.spatial import cKDTree
    pa, pb = densify(a, ds), densify(b, ds)
    if len(pa) == 0 or len(pb) == 0:
        return float("nan"), float("nan")
    da, _ = cKDTree(pb).query(pa)
    db, _ = cKDTree(pa).query(pb)
    d = np.concatenate((da, db))
    return float(d.mean()), float(d.max())


# The rotating square's boundary-integral reference shipped with the package
# (make reference-bem writes it); `--reference bem` names it.
SHIPPED_BEM = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data",
                           "square_rotation_bem")


class Reference:
    """A reference run directory, analysed: its settings, summary and series
    ('bem': the boundary-integral reference shipped with the package)."""

    def __init__(self, path):
        if path == "bem":
            path = SHIPPED_BEM
        self.path = path
        self.setup = load_setup(path)
        sj = os.path.join(path, "summary.json")
        if not os.path.isfile(sj):
            raise sp.PostprocError(f"'{path}' has no summary.json: run or analyse it first")
        with open(sj) as f:
            self.summary = json.load(f)
        self.pressure = read_csv(os.path.join(path, "pressure.csv"))
        self.integrals = read_csv(os.path.join(path, "integrals.csv"))
        # where its analysis ends: the case's end, or a partial run's last output
        self.t_end = min(self.summary.get("partial_until", self.setup.t_end),
                         self.summary.get("converged_until", np.inf))

    def interface(self, t):
        return read_interface(os.path.join(self.path, f"interface_{t:g}.csv"))

    def interface_times(self):
        """The times of the interfaces the reference holds, within its
        analysed interval."""
        ts = []
        for name in os.listdir(self.path):
            m = re.match(r"interface_([0-9.]+)\.csv$", name)
            if m and float(m.group(1)) <= self.t_end * (1 + 1e-12):
                ts.append(float(m.group(1)))
        return sorted(ts)

    def cavity_time(self):
        """The reconnection's time (the first cavity of a summary written
        before the reconnection was told apart)."""
        return self.summary.get("reconnection", self.summary.get("first_cavity"))


def level_gap(a, b):
    """Level b's probe pressure minus level a's, in |p(0)| of the series, at
    b's tabulated times from TRIM to the end of both runs, where both probes
    are in the fluid: (t, d)."""
    t = b.pressure["t"]
    keep = (t >= TRIM - 1e-9) & (t <= min(t[-1], a.pressure["t"][-1]) + 1e-9)
    d = (b.pressure["p"][keep] - np.interp(t[keep], a.pressure["t"], a.pressure["p"])) \
        / abs(SERIES_P0[b.setup.case])
    ok = np.isfinite(d)
    return t[keep][ok], d[ok]


def converged_until(a, b, bar=0.003):
    """The longest interval [0, w] over which the probe pressures of two
    reference levels differ by at most `bar` of |p(0)| on average from
    TRIM on (the issue's bar for the two finest levels): w, or None."""
    t, d = level_gap(a, b)
    if len(t) < 2:
        return None
    mean = np.cumsum(np.abs(d)) / np.arange(1, len(d) + 1)
    ok = np.nonzero(mean <= bar)[0]
    return float(t[ok[-1]]) if len(ok) else None


def pressure_difference(a, b, until=None):
    """Mean and largest |p_a - p_b| over their common tabulated times (up to
    `until`), relative to |p(0)| of the series."""
    t = a.pressure["t"]
    end = min(t[-1], b.pressure["t"][-1], until if until is not None else np.inf)
    sel = t <= end + 1e-9
    d = np.abs(a.pressure["p"][sel] - np.interp(t[sel], b.pressure["t"], b.pressure["p"]))
    d = d[np.isfinite(d)]           # where both probes are in the dense phase
    p0 = abs(SERIES_P0[a.setup.case])
    if len(d) == 0:
        return float("nan"), float("nan")
    return float(d.mean() / p0), float(d.max() / p0)


def study(dirs, echo=print):
    """The reference's resolution study: each level and the differences
    between successive levels, as markdown; returns the numbers."""
    refs = sorted((Reference(d) for d in dirs), key=lambda r: r.setup.level)
    if len({r.setup.case for r in refs}) != 1:
        raise sp.PostprocError("the study's directories hold different cases")
    case = refs[0].setup.case
    tl = "t omega" if case == "square_rotation" else "t V0/L"
    echo(f"### {case}: the reference at {len(refs)} levels\n")
    echo("| level | cells per L | steps | wall time | p(0) against the series | "
         "largest area drift | KE change at the end | first cavity | reconnection |")
    echo("|---|---|---|---|---|---|---|---|---|")
    rows = []
    for r in refs:
        sm = r.summary
        cav = sm.get("first_cavity")
        wall = sm.get("wall_time_s")
        echo(f"| {r.setup.level} | {sm['cells_per_side']:g} | {sm['steps']} | "
             + (f"{wall:.0f} s" if wall is not None else "") + " | "
             f"{100 * sm['p_probe_initial_error']:+.3f} % | {100 * sm['area_drift_max']:.3f} % | "
             f"{100 * sm['kinetic_energy_change_end']:+.2f} % | "
             + (f"{cav:.4f}" if cav is not None else "") + " | "
             + (f"{r.cavity_time():.4f}" if r.cavity_time() is not None else "") + " |")
        rows.append({"level": r.setup.level, "summary": sm})
    times = INTERFACE_TIMES[case]
    echo(f"\nBetween successive levels: the probe pressure's mean and largest difference "
         f"over {tl} in [0, {refs[0].t_end:g}] where both probes are in the dense phase "
         f"(of |p(0)|), the interfaces' mean "
         f"distance (in L) at {tl} = {', '.join(f'{t:g}' for t in times)}, and the "
         "reconnection's time:\n")
    wins = [w for w in WINDOWS[case] if w < min(r.t_end for r in refs)]
    echo("| levels | p mean | p max | " + "".join(f"p mean to {w:g} | " for w in wins)
         + " | ".join(f"interface {t:g}" for t in times) + " | reconnection |")
    echo("|---|---|---|" + "---|" * (len(times) + len(wins)) + "---|")
    pairs = []
    for a, b in zip(refs[:-1], refs[1:]):
        pm, px = pressure_difference(b, a)
        pw = [pressure_difference(b, a, until=w)[0] for w in wins]
        dist = []
        for t in times:
            try:
                dist.append(curve_distance(a.interface(t), b.interface(t),
                                           ds=b.setup.dx / 4)[0])
            except sp.PostprocError:
                dist.append(float("nan"))
        ca, cb = a.cavity_time(), b.cavity_time()
        dc = (cb - ca) / cb if ca is not None and cb is not None else None
        echo(f"| {a.setup.level}-{b.setup.level} | {100 * pm:.3f} % | {100 * px:.3f} % | "
             + "".join(f"{100 * v:.3f} % | " for v in pw)
             + " | ".join(f"{d:.4f}" for d in dist) + " | "
             + (f"{100 * dc:+.2f} %" if dc is not None else "") + " |")
        pairs.append({"levels": [a.setup.level, b.setup.level], "p_mean": pm, "p_max": px,
                      "p_mean_to": dict(zip((f"{w:g}" for w in wins), pw)),
                      "interface_mean": dict(zip((f"{t:g}" for t in times), dist)),
                      "cavity_time_change": dc})
    return {"case": case, "levels": rows, "pairs": pairs}


def colour_contour(snap, h, dx, level=0.5):
    """The free surface of a particle snapshot: the `level` contour of the
    colour function with smoothing length h, sampled at dx / 2
    (particles.free_surface_outline)."""
    return particles.free_surface_outline(snap["position"], snap["mass"] / snap["density"], dx,
                                        h, level)


def probe_column(run, pos):
    """The time-series column of the run's probe at pos (in units of L)."""
    L = run.case.length
    key = run.probe_at((pos[0] * L, pos[1] * L), 1e-9 * L)
    if key is None:
        raise sp.PostprocError(f"{run.path} has no probe at ({pos[0]:g} L, {pos[1]:g} L), the "
                               "reference's: add it to &output (n_probes, probes)")
    return key


def check_case(c, s):
    """Refuses a run (CaseInfo c) that is not the reference's flow (Setup s)."""
    if c.name != s.case:
        raise sp.PostprocError(f"the run is {c.name}, the reference {s.case}")
    for what, mine, theirs in (("side", c.length, s.side), ("rho0", c.rho0, s.rho0),
                               ("rate", c.rate if s.case == "square_rotation"
                                else c.rate * c.length, s.rate)):
        if abs(mine - theirs) > 1e-9 * abs(theirs):
            raise sp.PostprocError(f"the run's {what} is {mine:g}, the reference's {theirs:g}")


def series_against(c, ref, t, p, t_ke, ke, fc=None, transition=sp.DEFAULT_TRANSITION,
                   until=None):
    """A run's probe pressure p(t) and kinetic energy ke(t_ke) (in the run's
    units; c its CaseInfo) against a Reference: the probe pressure's mean
    |difference| raw and low-pass filtered (over the whole common interval
    where both probes are in the fluid, and over WINDOWS), in |p(0)| of the
    series, and the mean |difference| of the kinetic energy's relative
    change; with `until`, the filtered pressure over [TRIM, until] as well
    (p_until_*: where the reference has converged).  Returns the numbers and
    the interval's end (in the case's time)."""
    s = ref.setup
    check_case(c, s)
    tu, pu = s.time_unit, s.p_unit
    t, p = np.asarray(t, dtype=float) / tu, np.asarray(p, dtype=float) / pu
    # where both the run's probe and the reference's are in the fluid
    wet_ref = ref.pressure["t"][np.isfinite(ref.pressure["p"])]
    end = min(t[-1], ref.pressure["t"][-1])
    dry = np.nonzero(~np.isfinite(p))[0]
    if len(dry):
        end = min(end, t[max(dry[0] - 1, 0)])
    end = min(end, wet_ref[-1] if len(wet_ref) else 0.0)
    sel = t <= end + 1e-9
    if sel.sum() < 8:
        raise sp.PostprocError("the probe is in the fluid for fewer than 8 samples")
    if fc is None:
        fc, _ = sp.cutoff(c)
    tf, _, pf = sp.lowpass(t[sel] * tu, p[sel], fc, transition)
    tf = tf / tu
    p0 = abs(SERIES_P0[s.case])
    ok = np.isfinite(ref.pressure["p"])
    pr = np.interp(tf, ref.pressure["t"][ok], ref.pressure["p"][ok])
    raw = np.abs(p[sel] - np.interp(t[sel], ref.pressure["t"][ok], ref.pressure["p"][ok]))
    out = {"p_raw_mean": float(raw.mean() / p0),
           "p_filtered_mean": float(np.mean(np.abs(pf - pr)) / p0),
           "p_filtered_max": float(np.max(np.abs(pf - pr)) / p0)}
    out["p_filtered_mean_to"] = {f"{w:g}": float(np.mean(np.abs(pf - pr)[tf <= w + 1e-9]) / p0)
                                 for w in WINDOWS[s.case] if w < end}
    # away from the filter's ends: [TRIM, end - TRIM], the signed mean too
    # (the paper's "mean evolution slightly lower")
    def window(name, hi):
        part = (tf >= TRIM - 1e-9) & (tf <= hi + 1e-9)
        if part.sum() >= 2:
            d = (pf - pr)[part]
            out.update({name: (TRIM, float(hi)), f"{name}_mean": float(np.mean(np.abs(d)) / p0),
                        f"{name}_max": float(np.max(np.abs(d)) / p0),
                        f"{name}_bias": float(np.mean(d) / p0)})
    window("p_trim", end - TRIM)
    if until is not None:
        window("p_until", min(until, end - TRIM))
    tk = np.asarray(t_ke, dtype=float) / tu
    kel = tk <= min(tk[-1], ref.integrals["t"][-1]) + 1e-9
    ke = np.asarray(ke, dtype=float)[kel]
    ker = np.interp(tk[kel], ref.integrals["t"], ref.integrals["kinetic_energy"])
    out["ke_change_difference_mean"] = float(np.mean(np.abs(ke / ke[0] - ker / ker[0])))
    out["p_interval_end"] = float(end)
    return out, end


def compare(run_dir, ref_dir, echo=print, fc=None, transition=sp.DEFAULT_TRANSITION,
            until=None):
    """An sph run of a square patch against a reference: the probe pressure
    raw and filtered, the kinetic energy's change, the free surface at the
    interface times and the first cavity.  Returns the numbers."""
    run = sp.Run(run_dir)
    ref = Reference(ref_dir)
    s = ref.setup
    c = run.case
    tu = s.time_unit
    t = run.time / tu
    out, end = series_against(c, ref, run.time, run.column(probe_column(run, s.probe)),
                              run.time, run.column("kinetic_energy"), fc, transition, until)
    n = run.n_particles
    dx = s.side / math.sqrt(n)
    h = float(run.nml.get("particles", {}).get("h_over_dx", 2.0)) * dx
    stimes = run.snapshot_times() / tu
    out["interface"] = {}
    for tk in ref.interface_times():
        k = int(np.argmin(np.abs(stimes - tk))) if len(stimes) else -1
        if k < 0 or abs(stimes[k] - tk) > 1e-6 * max(1.0, tk):
            continue
        mine = [cc / s.side for cc in colour_contour(run.snapshot(k), h, dx)]
        theirs = ref.interface(tk)
        out["interface"][f"{tk:g}"] = curve_distance(mine, theirs, ds=dx / 8)
        out.setdefault("tip", {})[f"{tk:g}"] = tip_radius(mine) - tip_radius(theirs)
    if "fluid_cavities" in run.ts:
        cav = run.ts["fluid_cavities"]
        hit = np.nonzero(cav > cav[0])[0]
        out["first_cavity"] = float(t[hit[0]]) if len(hit) else None
        out["first_cavity_reference"] = ref.cavity_time()
    tl = "t omega" if s.case == "square_rotation" else "t V0/L"
    echo(f"{run.path} against the reference {ref.path} ({s.label}); the probe pressure "
         f"over {tl} in [0, {end:.3g}]:")
    echo(f"  probe pressure: mean |difference| raw {100 * out['p_raw_mean']:.3f} %, filtered "
         f"{100 * out['p_filtered_mean']:.3f} % (largest {100 * out['p_filtered_max']:.3f} %) "
         "of |p(0)|; filtered over [0, w]: " + ", ".join(
             f"{100 * v:.3f} % to {w}" for w, v in out["p_filtered_mean_to"].items()))
    echo(f"  kinetic energy's relative change: mean |difference| "
         f"{100 * out['ke_change_difference_mean']:.3f} %")
    if "p_trim_mean" in out:
        a, b = out["p_trim"]
        echo(f"  filtered over [{a:g}, {b:.3g}]: mean |difference| {100 * out['p_trim_mean']:.3f} "
             f"%, largest {100 * out['p_trim_max']:.3f} %, mean difference (run - reference) "
             f"{100 * out['p_trim_bias']:+.3f} %")
    for tk, (dm, dmax) in out["interface"].items():
        echo(f"  free surface at {tl} = {tk}: mean distance {dm:.4f} L ({dm / dx * s.side:.2f} "
             f"dx), largest {dmax:.4f} L; arm tips' radius {out['tip'][tk]:+.4f} L")
    if "first_cavity" in out:
        echo(f"  first cavity at {tl} = {out['first_cavity']} (the reference's reconnection: "
             f"{out['first_cavity_reference']})")
    return out


def figure(runs, refs, output, labels=None, dpi=110):
    """The probe pressure of sph runs (filtered, raw faint) against the
    references' (the paper's Figure 4 with a reference), and the free
    surfaces at the interface times: the particles and the finest
    reference's interface (Figures 3 and 5).  Written to output (PNG)."""
    plt = figures.use_agg()
    # the boundary-integral reference, if given, is the principal one
    refs = sorted((Reference(d) for d in refs), key=lambda r: (r.setup.method == "bem",
                                                               r.setup.resolution))
    runs = [sp.Run(d) for d in runs]
    if not refs:
        raise sp.PostprocError("give at least one reference directory (--ref)")
    s = refs[-1].setup
    labels = labels or [os.path.basename(r.path.rstrip("/")) for r in runs]
    if len(labels) != len(runs):
        raise sp.PostprocError(f"--labels needs one label per run ({len(runs)})")
    times = [t for t in refs[-1].interface_times()
             if t in INTERFACE_TIMES[s.case] or t == refs[-1].interface_times()[-1]]
    fig = plt.figure(figsize=(12, 10))
    gs = fig.add_gridspec(2, len(times), height_ratios=[1.1, 1])
    ax = fig.add_subplot(gs[0, :])
    tl = r"$t\,\omega$" if s.case == "square_rotation" else r"$t\,V_0/L$"
    grey = np.linspace(0.75, 0.0, len(refs))
    for g, r in zip(grey, refs):
        ax.plot(r.pressure["t"], r.pressure["p"], color=str(g), ls="--",
                lw=1.0 + (r is refs[-1]), label=r.setup.label)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (run, lab) in enumerate(zip(runs, labels)):
        tu = s.time_unit
        p = run.column(probe_column(run, s.probe)) / s.p_unit
        fc, _ = sp.cutoff(run.case)
        tf, _, pf = sp.lowpass(run.time, p, fc, sp.DEFAULT_TRANSITION)
        col = colors[k % len(colors)]
        ax.plot(run.time / tu, p, color=col, lw=0.5, alpha=0.35)
        ax.plot(tf / tu, pf, color=col, lw=1.8, label=f"{lab} (SPH, filtered)")
    ax.set_xlabel(tl)
    unit = r"$\rho\,\omega^2 L^2$" if s.case == "square_rotation" else r"$\rho\,V_0^2$"
    where = "A" if s.case == "square_rotation" else "(L/4, L/4)"
    ax.set_ylabel(f"p at {where} / {unit}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    for j, tk in enumerate(times):
        a2 = fig.add_subplot(gs[1, j])
        for k, run in enumerate(runs):
            st = run.snapshot_times() / s.time_unit
            i = int(np.argmin(np.abs(st - tk))) if len(st) else -1
            if i >= 0 and abs(st[i] - tk) < 1e-6 * max(1, tk):
                x = run.snapshot(i)["position"] / s.side
                a2.scatter(x[:, 0], x[:, 1], s=0.05, color=colors[k % len(colors)],
                           rasterized=True)
        for c in refs[-1].interface(tk):
            a2.plot(c[:, 0], c[:, 1], "k-", lw=0.6)
        a2.set_aspect("equal")
        a2.set_title(f"{tl} = {tk:g}", fontsize=9)
        a2.set_xlabel("x / L", fontsize=8)
        if j == 0:
            a2.set_ylabel("y / L", fontsize=8)
        a2.tick_params(labelsize=7)
    fig.suptitle(f"{s.case}: SPH against the reference (black: {refs[-1].setup.label})")
    fig.tight_layout()
    tmp = output + ".tmp.png"
    fig.savefig(tmp, dpi=dpi)
    os.replace(tmp, output)
    plt.close(fig)


# ---------------------------------------------------------------------------
# The command line
# ---------------------------------------------------------------------------

def command(argv, prog="postproc/reference"):
    ap = argparse.ArgumentParser(prog=prog, description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="verb", required=True)
    r = sub.add_parser("run", help="write and run the Gerris case, then analyse it")
    r.add_argument("case", choices=CASES)
    r.add_argument("--input", help="the case's input file (default input/CASE.nml)")
    r.add_argument("--level", type=int, required=True,
                   help="Gerris's finest level: cells of side box L / 2^level")
    r.add_argument("--ratio", type=float,
                   help="light to dense density ratio (default 1e-3 for square_rotation, "
                   "1e-4 for square_vortical)")
    r.add_argument("--light", choices=("rest", "continue"), default="continue",
                   help="the light phase's initial velocity: at rest, or the dense phase's "
                   "field continued (default)")
    r.add_argument("--light-viscosity", type=float, default=0.0,
                   help="the light phase's additional kinematic viscosity, in the same "
                   "unit (default 0)")
    r.add_argument("--viscosity", type=float, default=0.0,
                   help="the kinematic viscosity of both phases, in L^2 times the rate "
                   "(omega, V0/L): 1/Re (default 0: inviscid)")
    r.add_argument("--tension", type=float, default=0.0,
                   help="surface tension in p_unit L (rho omega^2 L^3, rho V0^2 L): 1/We, "
                   "a regularisation of the Rayleigh-Taylor unstable surface (default 0)")
    r.add_argument("--scan-dt", type=float, default=CAVITY_DT,
                   help="the vortical square's cavity scans' spacing in t V0/L over "
                   f"[{CAVITY_WINDOW[0]:g}, {CAVITY_WINDOW[1]:g}]: the reconnection's time is "
                   f"known to half of it (default {CAVITY_DT:g})")
    r.add_argument("--box", type=float, default=8.0,
                   help="the side of Gerris's square domain in units of L (default 8)")
    r.add_argument("--dir", help="the output directory (default "
                   "runs/reference/CASE/level_N)")
    r.add_argument("--resume", action="store_true",
                   help="continue the run in the output directory, stopped early, from its "
                   "newest complete checkpoint (the same settings are required)")
    a = sub.add_parser("analyse", help="analyse a finished Gerris run again")
    a.add_argument("dir")
    a.add_argument("--partial", action="store_true",
                   help="a run still going or stopped early: analyse it up to its last "
                   "output (the summary's partial_until)")
    st = sub.add_parser("study", help="the reference's resolution study (markdown)")
    st.add_argument("dirs", nargs="+", help="reference run directories of one case")
    st.add_argument("--json", help="also write the numbers to this file")
    cp = sub.add_parser("compare", help="an sph run against a reference")
    cp.add_argument("run", help="the sph run directory")
    cp.add_argument("dir", help="the reference run directory")
    cp.add_argument("--json", help="also write the numbers to this file")
    pl = sub.add_parser("plot", help="a figure of sph runs against references")
    pl.add_argument("runs", nargs="*", help="sph run directories")
    pl.add_argument("--ref", nargs="+", required=True, help="reference run directories")
    pl.add_argument("--labels", nargs="+", help="one label per run")
    pl.add_argument("-o", "--output", required=True, help="the PNG file to write")
    b = sub.add_parser("bem", help="the rotating square by the boundary-integral method "
                       "(sphpost.bem): the reference the paper compares with")
    b.add_argument("--input", default=os.path.join("input", "square_rotation.nml"),
                   help="the case's input file: side, omega, rho0, t_end (default "
                   "%(default)s)")
    b.add_argument("--nodes", type=int, default=1536,
                   help="nodes on the surface, a multiple of 8 (default %(default)s)")
    b.add_argument("--dt", type=float, default=0.005,
                   help="the RK4 step in 1/omega, dividing 0.01; it shrinks as the nodes "
                   "crowd at the tips (default %(default)s)")
    b.add_argument("--t-end", type=float, help="end time in 1/omega (default the input's)")
    b.add_argument("--n-corner", type=int, default=24,
                   help="the corners' rounding: the superellipse's exponent (default "
                   "%(default)s)")
    b.add_argument("--filter-order", type=int, default=12,
                   help="the Fourier filter's order (default %(default)s)")
    b.add_argument("--remap-every", type=int, default=5,
                   help="steps between redistributions of the nodes (default %(default)s)")
    b.add_argument("--dir", help="the output directory (default "
                   "runs/reference/square_rotation/bem_NODES)")
    bs = sub.add_parser("bem-study", help="the boundary-integral reference's own resolution "
                        "study (markdown)")
    bs.add_argument("dirs", nargs="+", help="boundary-integral reference directories")
    bs.add_argument("--json", help="also write the numbers to this file")
    bs.add_argument("--ship", metavar="DIR", help="write the finest run, cut at the interval "
                    "of convergence, with the study into DIR (the reference shipped with the "
                    "package: postproc/sphpost/data/square_rotation_bem)")
    args = ap.parse_args(argv)
    if args.verb == "bem":
        from . import bem
        s = Setup.from_input("square_rotation", args.input, level=8)
        t_end = args.t_end if args.t_end is not None else s.t_end
        try:
            params = bem.Params(nodes=args.nodes, dt=args.dt, t_end=t_end,
                                n_corner=args.n_corner, filter_order=args.filter_order,
                                remap_every=args.remap_every)
        except ValueError as e:
            raise sp.PostprocError(str(e))
        bs_ = bem.BemSetup("square_rotation", s.side, s.rate, s.rho0, t_end, params)
        out = args.dir or os.path.join("runs", "reference", "square_rotation",
                                       f"bem_{args.nodes}")
        print(f"{prog}: square_rotation by boundary integrals in {out}: {params.header()}",
              flush=True)
        rec = bem.run(params, echo=lambda m: print(m, flush=True))
        sm = bem.write_run(rec, bs_, out, SERIES_P0["square_rotation"])
        print(f"{prog}: {rec.stop_reason}; p_A(0) {100 * sm['p_probe_initial_error']:+.4f} % "
              f"from the series, area drift {sm['area_drift_max']:.1e}, kinetic energy drift "
              f"{sm['kinetic_energy_drift_max']:.1e}, {rec.steps} steps, {rec.wall:.0f} s")
        return 0
    if args.verb == "bem-study":
        from . import bem
        lines = []

        def echo(m):
            print(m)
            lines.append(m)
        try:
            res = bem.study(args.dirs, echo=echo)
        except ValueError as e:
            raise sp.PostprocError(str(e))
        if args.ship:
            if "converged_until" not in res:
                raise sp.PostprocError("--ship needs two runs that differ in their nodes alone")
            bem.ship(res["base"], args.ship, res, "\n".join(lines) + "\n")
            print(f"{prog}: wrote {args.ship} (to t omega = {res['converged_until']:g})",
                  file=sys.stderr)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(res, f, indent=1)
        return 0
    if args.verb == "run":
        inp = args.input or os.path.join("input", f"{args.case}.nml")
        s = Setup.from_input(args.case, inp, level=args.level, ratio=args.ratio,
                             light=args.light, light_viscosity=args.light_viscosity,
                             box=args.box, viscosity=args.viscosity,
                             tension=args.tension, scan_dt=args.scan_dt)
        out = args.dir or os.path.join("runs", "reference", args.case, f"level_{args.level}")
        print(f"{prog}: {args.case} at level {args.level} ({1 / s.dx:g} cells per L) in {out}",
              flush=True)
        wall = run_gerris(s, out, echo=lambda m: print(m, flush=True), resume=args.resume)
        analyse(out, wall=wall)
    elif args.verb == "analyse":
        analyse(args.dir, partial=args.partial)
    elif args.verb == "plot":
        figure(args.runs, args.ref, args.output, args.labels)
    elif args.verb in ("study", "compare"):
        res = study(args.dirs) if args.verb == "study" else compare(args.run, args.dir)
        if args.json:
            with open(args.json, "w") as f:
                json.dump(res, f, indent=1)
    return 0


def main(argv=None, prog="postproc/reference"):
    return cli.main_guard(prog, lambda a: command(a, prog), sys.argv[1:] if argv is None
                         else argv)
