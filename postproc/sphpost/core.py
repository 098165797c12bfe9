"""sphpost.core: the shared library of the post-processing tools.

Reads an sph run directory (doc/reference/output.md), knows each case's scales and
lowest acoustic frequency (doc/theory/ X6), low-pass filters probe signals with
FFTW (a type-I discrete cosine transform, FFTW_REDFT00, through pyFFTW) and
computes the paper's errors against the exact solution.  The tools
(errors, filter, convergence, plots, validate) are command-line layers over
it; doc/reference/postproc.md documents them and the filter design.

Run with /usr/bin/python3 (Debian's numpy, h5py, matplotlib, pyfftw).
"""
import argparse
import csv
import glob
import math
import os
import re
import sys

import numpy as np

# ---------------------------------------------------------------------------
# Errors for the user
# ---------------------------------------------------------------------------


class PostprocError(Exception):
    """An error the user can fix (wrong directory, missing file, bad option):
    the scripts print its message alone and exit with status 2."""


def main_guard(prog, fn, argv):
    """Runs fn(argv); turns a PostprocError into a one-line message on stderr
    and exit status 2."""
    try:
        return fn(argv)
    except PostprocError as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2


# ---------------------------------------------------------------------------
# The input file written into the run directory (input.nml)
# ---------------------------------------------------------------------------

def _strip_comment(line):
    out, quote = [], None
    for ch in line:
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "!":
            break
        out.append(ch)
    return "".join(out)


def _split_values(text):
    vals, cur, quote = [], [], None
    for ch in text:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
            cur.append(ch)
        elif ch == ",":
            vals.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    if "".join(cur).strip():
        vals.append("".join(cur).strip())
    return vals


def _value(tok):
    if len(tok) >= 2 and tok[0] == tok[-1] and tok[0] in "'\"":
        return tok[1:-1].replace(tok[0] * 2, tok[0])
    low = tok.lower()
    if low in (".true.", "t", ".t."):
        return True
    if low in (".false.", "f", ".f."):
        return False
    try:
        return int(tok)
    except ValueError:
        pass
    try:
        return float(low.replace("d", "e"))
    except ValueError:
        return tok


def read_namelist(path):
    """The effective input that sph writes into a run directory, as
    {group: {variable: value}}; names in lower case; a list value for several
    comma-separated items.  Only the subset of namelist syntax that sph writes
    (one item per line) is understood."""
    groups, cur = {}, None
    with open(path) as f:
        for raw in f:
            line = _strip_comment(raw).strip()
            if not line:
                continue
            if line.startswith("&"):
                name = line[1:].split()[0].lower() if len(line) > 1 else ""
                cur = groups.setdefault(name, {})
                rest = line[1 + len(name):].strip()
                if rest == "/":
                    cur = None
                continue
            if line == "/":
                cur = None
                continue
            if cur is None or "=" not in line:
                continue
            key, val = line.split("=", 1)
            val = val.strip()
            if val.endswith("/"):
                val = val[:-1].strip()
            items = [_value(v) for v in _split_values(val)]
            cur[key.strip().lower()] = items[0] if len(items) == 1 else items
    return groups


# ---------------------------------------------------------------------------
# Cases: scales and the lowest acoustic frequency (doc/theory/ X6)
# ---------------------------------------------------------------------------

# First zero of the Bessel function J0: the lowest Dirichlet (p = 0 on the
# free surface) acoustic mode of a disc of radius R is f = J0_ZERO c0/(2 pi R).
J0_ZERO = 2.404825557695773


class CaseInfo:
    """What the post-processing needs to know about a run's case.

    name          case name (circle2d, ellipsoid3d, square_rotation, square_vortical)
    dim           2 or 3
    rho0, c0      reference density and speed of sound
    length        R (stretching cases) or L (squares)
    rate          the flow's rate: A0, omega, or V0/L; its time scale is 1/rate
    time_label    how times are written, e.g. 't A0'
    p_unit        the pressure unit of the paper's plots (rho A0^2 R^2, rho omega^2 L^2, rho V0^2)
    p_unit_label  its name
    f_acoustic    the lowest acoustic frequency of the patch at t = 0, in
                  cycles per unit time (doc/theory/ X6; sphere: c0/(2R), the
                  first zero of sin(kr)/r).  By the Faber-Krahn inequality the
                  disc (ball) has the lowest Dirichlet eigenvalue among all
                  shapes of equal area (volume), so the stretching patches
                  never go below their initial value; a deformed square could
                  fall to at most 4 % below its f0 (the disc of equal area).
    notes         warnings gathered while reading (e.g. defaults assumed)
    rates         the stretching cases' initial strain rates alpha_k(0) (A0 included)
    """

    def __init__(self, name, dim, rho0, c0, length, rate, time_label, p_unit,
                 p_unit_label, f_acoustic, notes=(), rates=None):
        self.name, self.dim, self.rho0, self.c0 = name, dim, rho0, c0
        self.rates = rates
        self.length, self.rate = length, rate
        self.time_label, self.p_unit, self.p_unit_label = time_label, p_unit, p_unit_label
        self.f_acoustic = f_acoustic
        self.notes = list(notes)

    @property
    def stretching(self):
        return self.name in ("circle2d", "ellipsoid3d")

    @property
    def square(self):
        return self.name.startswith("square")


def patch_volume(case):
    """The initial patch's area pi R^2 (circle2d), volume 4/3 pi R^3
    (ellipsoid3d) or area L^2 (squares); the flows keep it."""
    return {"circle2d": math.pi * case.length**2,
            "ellipsoid3d": 4 / 3 * math.pi * case.length**3}.get(case.name, case.length**2)


def _pick(group, names, default, notes, what):
    for n in names:
        if n in group:
            return float(group[n])
    notes.append(f"{what} not found in input.nml; assumed {default}")
    return default


def resolution_scale(nml, dim):
    """s = (n/n_ref)^(1/dim) of the input's resolution scaling (doc/studies/convergence.md
    S1), 1 without it: the run's c0 is physics.c0 s^c0_exponent, as the solver
    computes it (input.nml keeps the given values and the rule)."""
    part = nml.get("particles", {})
    n_ref = float(part.get("n_ref", 0.0))
    if not n_ref > 0:
        return 1.0
    return (float(part.get("n", n_ref)) / n_ref) ** (1.0 / dim)


def scaled_input(nml, dim, group, name, exponent, default):
    """The value the run used for &group name: the input's value times
    resolution_scale^exponent (the exponent read from the same group)."""
    g = nml.get(group, {})
    return float(g.get(name, default)) * resolution_scale(nml, dim) ** float(g.get(exponent, 0.0))


def case_info(nml, case=None, dim=None):
    """CaseInfo from the parsed input.nml (nml may be {} when absent, then
    the case name must be given, e.g. from a snapshot's attributes)."""
    notes = []
    run = nml.get("run", {})
    name = (case or run.get("case") or "").lower()
    phys = nml.get("physics", {})
    rho0 = float(phys.get("rho0", 1.0))
    c0 = scaled_input(nml, 3 if name == "ellipsoid3d" else 2, "physics", "c0", "c0_exponent",
                      10.0)
    if not nml:
        notes.append("no input.nml: assumed rho0 = 1, c0 = 10 and unit scales")
    if name == "circle2d":
        g = nml.get("circle2d", {})
        r = float(g.get("radius", 1.0))
        a0 = float(g.get("a0", 1.0))
        return CaseInfo(name, 2, rho0, c0, r, a0, "t A0", rho0 * a0**2 * r**2,
                        "rho A0^2 R^2", J0_ZERO * c0 / (2 * math.pi * r), notes,
                        rates=(-a0, a0))
    if name == "ellipsoid3d":
        g = nml.get("ellipsoid3d", {})
        r = float(g.get("radius", 1.0))
        a0 = float(g.get("a0", 1.0))
        rates = g.get("rates", [-1.0, -1.0, 2.0])
        rates = tuple(a0 * float(x) for x in (rates if isinstance(rates, (list, tuple)) else [rates]))
        return CaseInfo(name, 3, rho0, c0, r, a0, "t A0", rho0 * a0**2 * r**2,
                        "rho A0^2 R^2", c0 / (2 * r), notes, rates=rates)
    if name == "square_rotation":
        # Variable names of issue 5's input/square_rotation.nml; the first
        # one found is used.
        g = nml.get("square_rotation", {})
        side = _pick(g, ("side", "l", "length"), 1.0, notes, "square_rotation side")
        omega = _pick(g, ("omega",), 1.0, notes, "square_rotation omega")
        return CaseInfo(name, 2, rho0, c0, side, omega, "t omega",
                        rho0 * omega**2 * side**2, "rho omega^2 L^2",
                        c0 / (math.sqrt(2) * side), notes)
    if name == "square_vortical":
        g = nml.get("square_vortical", {})
        side = _pick(g, ("side", "l", "length"), 1.0, notes, "square_vortical side")
        v0 = _pick(g, ("v0",), 1.0, notes, "square_vortical v0")
        return CaseInfo(name, 2, rho0, c0, side, v0 / side, "t V0/L", rho0 * v0**2,
                        "rho V0^2", c0 / (math.sqrt(2) * side), notes)
    raise PostprocError(f"unknown case '{name}': the post-processing knows circle2d, "
                        "ellipsoid3d, square_rotation and square_vortical")


# ---------------------------------------------------------------------------
# A run directory
# ---------------------------------------------------------------------------

def read_timeseries(path):
    """timeseries.csv as {column: float64 array} in file order."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise PostprocError(f"{path} is empty")
    header, data = rows[0], rows[1:]
    if not data:
        raise PostprocError(f"{path} has a header but no rows")
    arr = np.array([[float(v) for v in r] for r in data], dtype=float)
    return {name: arr[:, k] for k, name in enumerate(header)}


IMAGE_ID_STRIDE = 2 ** 32


def mirror_copies(mask):
    return 2 ** bin(mask).count("1")


def mirror_attrs(attrs):
    """A snapshot's mirror planes (doc/reference/output.md): their mask (0: none) and
    the copies of the part the file holds (1: the part)."""
    return (int(round(float(attrs.get("symmetry_mask", 0)))),
            int(round(float(attrs.get("mirror_copies", 1)))))


def plane_sets(x, mask):
    """(M5) For each particle (rows of x, (N, dim)) the mask of the planes
    of `mask` it lies on (its coordinate exactly 0, of either sign)."""
    on = np.zeros(len(x), dtype=np.int64)
    for k in range(min(3, x.shape[1])):
        if mask >> k & 1:
            on |= np.where(x[:, k] == 0, 1 << k, 0)
    return on


def set_weights(on):
    """(M5) The weights of particles on the plane sets `on` (plane_sets):
    2^-k on k planes."""
    return 0.5 ** sum((on >> k) & 1 for k in range(3))


def plane_weights(x, mask):
    """(M5) Each particle's weight: 2^-k on k of the planes of `mask`."""
    return set_weights(plane_sets(x, mask))


def unfold_mirrors(fields, mask):
    """The whole body from the part of a run with mirror planes (M3): the
    part, then its reflection by each nonzero submask (code) of mask in
    ascending order, as the solver's output.mirror writes it: vectors
    (N, dim) flip the code's columns, ids become id + code 2^32, the 2D
    vorticity (a pseudo-scalar) takes the sign s_x s_y, scalars are copied.
    (M5) A particle on planes P (its position's coordinate 0) is one
    particle with its images across them: it appears once per code that
    flips none of P, with the mass 2^|P| m."""
    codes = [0] + [c for c in range(1, 8) if c & mask == c]
    pos = fields.get("position", fields.get("position_initial"))
    on = w = None
    if pos is not None:
        on = plane_sets(np.asarray(pos), mask)
        w = set_weights(on)
    out = {}
    for name, a in fields.items():
        blocks = []
        for c in codes:
            b = np.array(a, copy=True)
            if name == "id":
                b = b + np.int64(c) * IMAGE_ID_STRIDE
            elif b.ndim == 2:
                for k in range(b.shape[1]):
                    if c >> k & 1:
                        b[:, k] = -b[:, k]
            elif name == "vorticity" and bin(c & 3).count("1") == 1:
                b = -b
            if on is not None:
                if name == "mass":
                    b = b / w
                b = b[(on & c) == 0]
            blocks.append(b)
        out[name] = np.concatenate(blocks)
    return out


class Run:
    """An sph run directory: its input, time series and snapshots.

    Raises PostprocError with a clear message when the directory is not one.
    """

    def __init__(self, path):
        self.path = os.path.abspath(str(path))
        if not os.path.exists(self.path):
            raise PostprocError(f"run directory '{path}' does not exist")
        if not os.path.isdir(self.path):
            raise PostprocError(f"'{path}' is not a directory (give the run directory, "
                                "output.dir of the run)")
        ts = os.path.join(self.path, "timeseries.csv")
        self.snapshots = sorted(glob.glob(os.path.join(self.path, "snap_*.h5")))
        if not os.path.exists(ts):
            raise PostprocError(f"'{path}' has no timeseries.csv: is it the output.dir of an "
                                "sph run? (a run writes it at its first snapshot)")
        self.ts = read_timeseries(ts)
        nml_path = os.path.join(self.path, "input.nml")
        self.nml = read_namelist(nml_path) if os.path.exists(nml_path) else {}
        case = None
        dim = None
        if not self.nml.get("run", {}).get("case"):
            if not self.snapshots:
                raise PostprocError(f"'{path}' has neither input.nml nor snapshots: "
                                    "cannot tell the case")
            attrs = self.snapshot_attrs(self.snapshots[0])
            case, dim = attrs["case"], attrs["dim"]
        self.case = case_info(self.nml, case, dim)
        self.time = self.ts["time"]
        self._n = None

    # -- snapshots ---------------------------------------------------------
    @staticmethod
    def snapshot_attrs(path):
        import h5py
        with h5py.File(path, "r") as f:
            a = dict(f.attrs)
        c = a.get("case", b"")
        a["case"] = (c.decode() if isinstance(c, bytes) else str(c)).strip()
        a["time"] = float(a["time"])
        a["dim"] = int(a["dim"])
        return a

    def snapshot_times(self):
        return np.array([self.snapshot_attrs(p)["time"] for p in self.snapshots])

    def snapshot(self, index):
        """Snapshot `index` (negative counts from the end) as a dict of arrays
        sorted by particle id, plus 'attrs'.  A run with mirror planes
        (particles.symmetry) is given as the whole body: a snapshot of the
        part is unfolded by its reflections (doc/theory/mirrors.md, M3)."""
        import h5py
        path = self.snapshots[index]
        with h5py.File(path, "r") as f:
            out = {k: f[k][:] for k in f if k != "connectivity"}
        attrs = self.snapshot_attrs(path)
        mask, held = mirror_attrs(attrs)
        if mask and held == 1:
            out = unfold_mirrors(out, mask)
        order = np.argsort(out["id"])
        out = {k: v[order] for k, v in out.items()}
        out["attrs"] = attrs
        return out

    def window(self, until):
        """Cuts the time series at t rate = until (in the case's flow time,
        e.g. t A0), so that runs of different lengths, such as a level stopped
        at a checkpoint, are compared over the same interval [0, until]: the
        rows before it, and a last row at exactly `until` interpolated
        linearly between the two rows around it.  Raises PostprocError when
        the run ends before `until`."""
        c = self.case
        t_cut = until / c.rate
        t = self.time
        # a run asked to end at `until` ends there up to the rounding of t
        if t[-1] < t_cut * (1 - 1e-9):
            raise PostprocError(f"'{self.path}' ends at {c.time_label} = {t[-1] * c.rate:g}, "
                                f"before --until {until:g}")
        k = int(np.searchsorted(t, t_cut, side="right"))     # rows t[:k] <= t_cut
        if k < 2:
            raise PostprocError(f"'{self.path}' has fewer than two rows with {c.time_label} "
                                f"<= {until:g}")
        cut = {name: v[:k] for name, v in self.ts.items()}
        if k < len(t) and t[k - 1] < t_cut:
            w = (t_cut - t[k - 1]) / (t[k] - t[k - 1])
            cut = {name: np.append(v, (1 - w) * self.ts[name][k - 1] + w * self.ts[name][k])
                   for name, v in cut.items()}
            cut["time"][-1] = t_cut
        self.ts = cut
        self.time = cut["time"]
        return self

    @property
    def n_particles(self):
        if self._n is None:
            if self.snapshots:
                # the whole body's count: a run with mirror planes writes
                # the part (mirror_copies 1) or the whole body
                import h5py
                mask, held = mirror_attrs(self.snapshot_attrs(self.snapshots[0]))
                with h5py.File(self.snapshots[0], "r") as f:
                    x = f["position"][...]
                if held > 1 or mask == 0:
                    self._n = len(x)
                else:
                    # (M5) a particle on k planes stands for 2^-k of the copies
                    self._n = int(round(float(np.sum(plane_weights(x, mask)))
                                        * mirror_copies(mask)))
            else:
                self._n = int(self.nml.get("particles", {}).get("n", 0))
        return self._n

    @property
    def dx(self):
        """Equivalent particle spacing (volume per particle)^(1/dim): the
        initial patch's area pi R^2 / volume 4/3 pi R^3 / square L^2."""
        return (patch_volume(self.case) / self.n_particles) ** (1 / self.case.dim)

    def column(self, name):
        if name not in self.ts:
            raise PostprocError(f"{self.path}/timeseries.csv has no column '{name}' "
                                f"(case {self.case.name})")
        return self.ts[name]

    def centre_probe(self):
        """Column name of the probe at the centre (all coordinates 0), or None."""
        return self.probe_at((0.0,) * self.case.dim, 1e-12)

    def probe_at(self, point, tol):
        """Column name of the first probe within tol of point in each of the
        point's coordinates (output.probes of input.nml; a probe not set is
        at the origin), or None."""
        out = self.nml.get("output", {})
        n = int(out.get("n_probes", 1)) if self.nml else 1
        for k in range(1, n + 1):
            key = f"p_probe_{k}"
            if key not in self.ts:
                continue
            pos = [0.0, 0.0, 0.0]
            for i in range(3):
                v = out.get(f"probes({i + 1},{k})")
                if v is not None:
                    pos[i] = float(v)
            sec = out.get(f"probes(1:3,{k})")
            if isinstance(sec, list):
                pos = [float(v) for v in sec[:3]]
            if all(abs(p - q) < tol for p, q in zip(pos, point)):
                return key
        return None

    def probe_samples(self, name):
        """The samples (t, p) of the probe column `name`: the time series' rows."""
        return self.time, self.ts[name]

    def probe_signal(self, name):
        """The samples (t, p, P(t)) of the centre probe `name` with the exact
        centre pressure at the same times."""
        t, p = self.probe_samples(name)
        return t, p, self.column("p_centre_exact")


def solver_summary(text):
    """The solver's closing summary (its stdout) as a dict of numbers in %:
    'mean_axis', 'mean_pos', 'mean_vel', 'mean_p_raw', 'n_samples'."""
    pats = {"mean_axis": r"max semi-axis error\s+(\S+) %",
            "mean_pos": r"Time-averaged.*?RMS position error\s+(\S+) %",
            "mean_vel": r"Time-averaged.*?RMS velocity error\s+(\S+) %",
            "mean_p_raw": r"centre pressure \(raw\)\s+(\S+) % of P\(0\)",
            "n_samples": r"Time-averaged over (\d+) samples"}
    out = {}
    for k, p in pats.items():
        m = re.search(p, text, re.S)
        if m:
            out[k] = float(m.group(1))
    return out


# ---------------------------------------------------------------------------
# Exact solution of the stretching patch (doc/theory/ X1), for tests and plots
# ---------------------------------------------------------------------------

def exact_ellipse(t, rates=(-1.0, 1.0), radius=1.0, rho=1.0):
    """Exact semi-axes a_k(t) (shape (len(t), dim)), rates alpha_k(t) and
    centre pressure P(t) of the stretching patch with alpha_k(0) = rates:
    a_k' = alpha_k a_k, alpha_k' = 2P/(rho a_k^2) - alpha_k^2,
    P/rho = Sum alpha_k^2 / (2 Sum 1/a_k^2).  Integrated by scipy's DOP853 to
    1e-12 relative."""
    from scipy.integrate import solve_ivp
    t = np.atleast_1d(np.asarray(t, dtype=float))
    rates = np.asarray(rates, dtype=float)
    d = len(rates)

    def rhs(_, s):
        a, al = s[:d], s[d:]
        p = np.sum(al**2) / (2 * np.sum(1 / a**2))
        return np.concatenate([al * a, 2 * p / a**2 - al**2])

    tt = np.unique(np.concatenate([[0.0], t]))
    if tt[-1] == 0:             # t = 0 alone: the initial state (no interval to integrate)
        tt = np.array([0.0, 1e-300])
    sol = solve_ivp(rhs, (0.0, tt[-1]), np.concatenate([np.full(d, radius), rates]),
                    t_eval=tt, rtol=1e-12, atol=1e-14, method="DOP853")
    idx = np.searchsorted(tt, t)
    a = sol.y[:d, idx].T
    al = sol.y[d:, idx].T
    p = rho * np.sum(al**2, axis=1) / (2 * np.sum(1 / a**2, axis=1))
    return a, al, p


# ---------------------------------------------------------------------------
# Low-pass filtering by the type-I DCT (FFTW REDFT00)
# ---------------------------------------------------------------------------

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
    unit = case.time_label.replace("t ", "")
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


# ---------------------------------------------------------------------------
# Errors against the exact solution (stretching cases)
# ---------------------------------------------------------------------------

def time_mean(t, e):
    """Time average of e over [t0, t1] (trapezoidal rule on the samples)."""
    t = np.asarray(t, float)
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    t, e = t[ok], e[ok]
    if len(t) < 2 or t[-1] <= t[0]:
        return float(e[0]) if len(e) else float("nan")
    return float(np.trapz(e, t) / (t[-1] - t[0]))


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
    return float(np.trapz(ew, tw) / (b - a))


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


def centre_pressure_derivatives(a, al, rho=1.0):
    """P(t), P'(t) and P''(t) of X1 from the semi-axes a and rates al
    (arrays (n, dim)): with P = rho N/D, N = Sum al^2, D = 2 Sum 1/a^2,
    a' = al a, al' = 2P/(rho a^2) - al^2 and
    al'' = 2P'/(rho a^2) - 4 P al/(rho a^2) - 2 al al',
    P' = rho (N' D - N D')/D^2,
    P'' = rho ((N'' D - N D'')/D^2 - 2 D' (N' D - N D')/D^3)."""
    a, al = np.atleast_2d(a), np.atleast_2d(al)
    n, d = np.sum(al**2, 1), 2 * np.sum(1 / a**2, 1)
    p = rho * n / d
    al1 = 2 * p[:, None] / (rho * a**2) - al**2
    n1, d1 = 2 * np.sum(al * al1, 1), -4 * np.sum(al / a**2, 1)
    p1 = rho * (n1 * d - n * d1) / d**2
    al2 = (2 * p1[:, None] - 4 * p[:, None] * al) / (rho * a**2) - 2 * al * al1
    n2 = 2 * np.sum(al1**2 + al * al2, 1)
    d2 = -4 * np.sum((al1 - 2 * al**2) / a**2, 1)
    p2 = rho * ((n2 * d - n * d2) / d**2 - 2 * d1 * (n1 * d - n * d1) / d**3)
    return p, p1, p2


def centre_pressure_accel(a, al, rho=1.0):
    """P''(t) of X1 from the semi-axes a and rates al (centre_pressure_derivatives)."""
    return centre_pressure_derivatives(a, al, rho)[2]


def compressibility_floor(t, rates=(-1.0, 1.0), radius=1.0, rho=1.0, c0=10.0):
    """(I2, doc/theory/solutions.md) The weakly compressible model's own departure
    of the centre pressure of the stretching patch (X1, initial rates
    `rates`) from the incompressible P(t), over P(0):
    delta p(0, t) = -P''(t) R^2 (dim + 4) / (4 dim (dim + 2) c0^2).  It
    falls as 1/c0^2 and is slow, so the low-pass filter keeps it: a floor
    of the filtered error at any resolution."""
    d = len(rates)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    a, al, _ = exact_ellipse(t, rates=rates, radius=radius, rho=rho)
    p0 = rho * np.sum(np.square(rates)) * radius**2 / (2 * d)
    p2 = centre_pressure_accel(a, al, rho)
    return -p2 * radius**2 * (d + 4) / (4 * d * (d + 2) * c0**2) / p0


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


# ---------------------------------------------------------------------------
# Convergence
# ---------------------------------------------------------------------------

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


def use_agg():
    """matplotlib with the headless Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt
