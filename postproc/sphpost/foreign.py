"""sphpost.foreign: other particle codes' output read as runs.

A foreign run is a directory (or a glob pattern) of one file per output
time in one of three formats (doc/reference/other-codes.md):

  plain   CSV or .npz with the columns id, x, y[, z], u, v[, w], p[, rho, m],
          the time in a '# time = T' line (CSV), a 'time' entry (.npz) or
          the file name (NAME_t0.25.csv);
  vtk     legacy .vtk (polydata or unstructured grid), XML .vtu or .vtp,
          as DualSPHysics' PartVTK and SPHinXsys write them, read by VTK
          (Debian's python3-vtk9); field names mapped by --fields;
  pysph   PySPH's own .npz and .hdf5 dumps (pysph.solver.utils.dump).

ForeignRun turns the files into what core.Run gives for our runs: a time
series, one row per file, with the columns of our timeseries.csv
(kinetic_energy, semi_axis_k_error, rms_position_error, rms_velocity_error,
kinetic_energy_exact, p_centre_exact, p_probe_1 ...), so that errors,
convergence and filter report a foreign run exactly as one of ours.  The
exact solution comes from sphpost.exact in the units the options give
(--length, --rate, --v0, --rho), and any file that does not fit is refused
with one message naming the file, the field and what was expected.
"""
import math
import os
import re

import numpy as np

from . import exact
from .cases import CASES, PROBES, case_info, patch_volume
from .exceptions import PostprocError
from .particles import fitted_semi_axes, free_surface_outline, pressure_at
from .readers.plain import read_plain_csv, read_plain_npz
from .readers.pysph import read_pysph
from .readers.series import FORMATS, find_files
from .readers.sph import Run, read_timeseries
from .readers.vtk import pvd_times, read_vtk

# The scalar fields of a particle, by their names in the plain format; a
# vector field ('position', 'velocity') stands for its three components.
SCALARS = ("id", "x", "y", "z", "u", "v", "w", "p", "rho", "m")
VECTORS = {"position": ("x", "y", "z"), "velocity": ("u", "v", "w")}
WHAT = {"id": "particle ids", "x": "positions", "y": "positions", "z": "positions",
        "u": "velocities", "v": "velocities", "w": "velocities", "p": "pressures",
        "rho": "densities", "m": "masses", "position": "positions",
        "velocity": "velocities"}

# Names tried, in this order, for each field of a VTK file when --fields
# does not give it (DualSPHysics PartVTK: Idp, Vel, Press, Rhop, Mass;
# SPHinXsys: Velocity, Pressure, Density, MassiveMeasure; ParaView's own
# exports of sph runs: id, velocity, pressure, density, mass).
VTK_NAMES = {"id": ("Idp", "id", "ID", "Id", "ParticleID", "OriginalID", "SortedID", "gid"),
             "velocity": ("Vel", "Velocity", "velocity", "vel", "U"),
             "p": ("Press", "Pressure", "pressure", "p"),
             "rho": ("Rhop", "Density", "density", "rho"),
             "m": ("Mass", "MassiveMeasure", "mass", "m")}
# PySPH's particle properties (get_particle_array): gid is the global id
PYSPH_NAMES = {"id": ("gid",), "x": ("x",), "y": ("y",), "z": ("z",), "u": ("u",),
               "v": ("v",), "w": ("w",), "p": ("p",), "rho": ("rho",), "m": ("m",)}
PLAIN_NAMES = {k: (k,) for k in SCALARS}
UINT_MAX = 2**32 - 1            # PySPH's gid of a particle never given one

# the probe of each case (the shipped inputs'): the centre, A for the
# rotating square, (L/4, L/4) for the vortical one, in units of R or L

UNIT_TOLERANCE = 30.0           # a scale this far off is a wrong unit, not a bad run


def add_options(ap):
    """The options that describe a foreign run (doc/reference/other-codes.md); our own
    run directories need none of them."""
    g = ap.add_argument_group("other codes' runs (doc/reference/other-codes.md)")
    g.add_argument("--case", choices=tuple(CASES),
                   help="the prototype problem of a run that is not ours (required for it)")
    g.add_argument("--format", choices=FORMATS,
                   help="sph (our run directory), plain, vtk or pysph; default: from the "
                        "directory's contents")
    g.add_argument("--pattern", metavar="GLOB",
                   help="which files of the directory are the output times, e.g. "
                        "'PartFluid_*.vtk' (default: all files of the format)")
    g.add_argument("--fields", metavar="KEY=NAME,...",
                   help="the file's names of the fields: keys id, position, velocity, "
                        "x, y, z, u, v, w, p (or pressure), rho (or density), m (or mass); "
                        "e.g. velocity=Vel,pressure=Press,id=Idp")
    g.add_argument("--pysph-array", metavar="NAME",
                   help="the particle array of a PySPH file (default: 'fluid', or the only one)")
    g.add_argument("--probe-file", metavar="CSV",
                   help="the centre (or probe) pressure as a time series, columns t,p; '{}' "
                        "in it stands for the run's path; without it the pressure is "
                        "estimated from the particles")
    g.add_argument("--probe-h", type=float, metavar="H",
                   help="smoothing length of that estimate, in the file's length unit "
                        "(default 2 dx, dx the mean particle spacing)")
    g.add_argument("--output-dt", type=float, metavar="DT",
                   help="time between output files, for files that carry no time: the time "
                        "of a file is DT times the last number in its name")
    g.add_argument("--centre", metavar="X,Y[,Z]",
                   help="where the patch's centre is in the file's coordinates (default 0)")
    u = ap.add_argument_group("units of a foreign run (default: the non-dimensional 1)")
    u.add_argument("--length", type=float, metavar="R_OR_L",
                   help="the initial radius R (stretching cases) or side L (squares)")
    u.add_argument("--rate", type=float, metavar="A0_OR_OMEGA",
                   help="A0 (stretching cases) or omega (rotating square), per unit time")
    u.add_argument("--v0", type=float, metavar="V0", help="V0 of the vortical square")
    u.add_argument("--rho", type=float, metavar="RHO", help="the fluid's density")
    u.add_argument("--c0", type=float, metavar="C0",
                   help="the run's speed of sound, for the filter's cut-off and the "
                        "compressibility floor (default 10 A0 R, 7 omega L, 14 V0)")
    u.add_argument("--rates", metavar="A,B,C",
                   help="ellipsoid3d's initial rates in units of A0 (default -1,-1,2)")


def open_run(path, args):
    """Our run directory (core.Run) or a foreign run (ForeignRun), as the
    options `args` (add_options) say."""
    fmt = getattr(args, "format", None)
    case = getattr(args, "case", None)
    ours = os.path.isdir(path) and os.path.exists(os.path.join(path, "timeseries.csv"))
    if fmt == "sph" or (fmt is None and (ours or not case)):
        try:
            run = Run(path)
        except PostprocError as e:
            if fmt is None and os.path.isdir(path):
                raise PostprocError(f"{e}; for another code's output give --case circle2d, "
                                    "ellipsoid3d, square_rotation or square_vortical "
                                    "(doc/reference/other-codes.md)")
            raise
        if case and case != run.case.name:
            raise PostprocError(f"'{path}' is a {run.case.name} run, not {case}")
        return run
    return ForeignRun(path, args)


def parse_fields(text):
    """--fields KEY=NAME,... as {key: name}, the keys normalised."""
    alias = {"pressure": "p", "density": "rho", "mass": "m", "ids": "id"}
    out = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        if "=" not in item:
            raise PostprocError(f"--fields: '{item}' is not KEY=NAME")
        k, v = (s.strip() for s in item.split("=", 1))
        k = alias.get(k.lower(), k.lower())
        if k not in SCALARS and k not in VECTORS:
            raise PostprocError(f"--fields: unknown key '{k}' (keys: id, position, velocity, "
                                "x, y, z, u, v, w, p, rho, m)")
        out[k] = v
    return out


def _numbers(text, what, n=None):
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise PostprocError(f"{what}: '{text}' is not a comma-separated list of numbers")
    if n is not None and len(vals) not in n:
        raise PostprocError(f"{what}: '{text}' has {len(vals)} numbers, expected "
                            + " or ".join(str(k) for k in n))
    return vals


# ---------------------------------------------------------------------------


TIME_IN_NAME = re.compile(r"(?:^|[_.\-])t=?([0-9]+(?:\.[0-9]*)?(?:[eE][-+]?[0-9]+)?)(?=[_.\-]|$)")


# One output time as canonical particle arrays
# ---------------------------------------------------------------------------

class Frame:
    """One output file: time t, ids (or None), positions x (n, dim) about the
    centre, velocities u (n, dim), pressures p, densities rho and masses m
    (None when the file has none)."""

    def __init__(self, path, t, ids, x, u, p, rho, m):
        self.path, self.t, self.ids, self.x, self.u = path, t, ids, x, u
        self.p, self.rho, self.m = p, rho, m

    @property
    def n(self):
        return len(self.x)


def _field(data, path, key, names, fmt, n=None):
    """The array of field `key` (a scalar key or 'velocity'/'position'),
    or None; names the file's candidate names."""
    for name in names:
        if name in data:
            a = np.asarray(data[name])
            if a.dtype.kind not in "fiub":
                raise PostprocError(f"{path}: field '{name}' ({WHAT[key]}) is not numeric")
            if n is not None and a.shape[0] != n:
                raise PostprocError(f"{path}: field '{name}' ({WHAT[key]}) has {a.shape[0]} "
                                    f"values for {n} particles")
            return a
    return None


def canonical(path, data, points, time, fmt, fields, case_dim):
    """Frame from one file's arrays: picks the fields by the mapping
    `fields` (--fields) and the format's usual names, checks the
    dimension against the case, and refuses what is missing."""
    defaults = {"plain": PLAIN_NAMES, "pysph": PYSPH_NAMES, "vtk": VTK_NAMES}[fmt]
    have = ", ".join(sorted(data)) or "none"

    def names(key):
        return (fields[key],) if key in fields else defaults.get(key, ())

    def missing(key, expected):
        raise PostprocError(f"{path}: no {WHAT[key]}: expected {expected} (the file has: "
                            f"{have}); map a name with --fields {key}=NAME")

    # positions: a vector field, the VTK points, or the columns x, y[, z]
    pos = _field(data, path, "position", names("position"), fmt)
    if pos is None and points is not None and "position" not in fields:
        pos = points
    if pos is None:
        comps = [_field(data, path, c, names(c), fmt) for c in "xyz"]
        if comps[0] is None or comps[1] is None:
            missing("x", "columns " + " and ".join(f"'{names(c)[0]}'" for c in "xy")
                    + (" and 'z'" if case_dim == 3 else ""))
        if case_dim == 3 and comps[2] is None:
            raise PostprocError(f"{path}: 2D data (no column '{names('z')[0]}') for a 3D case "
                                "(ellipsoid3d needs x, y, z and u, v, w)")
        pos = np.stack([c for c in comps if c is not None], axis=1)
    pos = np.asarray(pos, float).reshape(len(pos), -1)
    n = len(pos)
    vel = _field(data, path, "velocity", names("velocity") if fmt == "vtk"
                 or "velocity" in fields else (), fmt, n)
    if vel is None:
        comps = [_field(data, path, c, names(c), fmt, n) for c in "uvw"]
        if comps[0] is None or comps[1] is None:
            if fmt == "vtk":
                missing("velocity", "a point array named one of "
                        + ", ".join(names("velocity")))
            missing("u", "columns " + " and ".join(f"'{names(c)[0]}'" for c in "uv")
                    + (" and 'w'" if case_dim == 3 else ""))
        if case_dim == 3 and comps[2] is None and pos.shape[1] == 3:
            raise PostprocError(f"{path}: no column '{names('w')[0]}' (velocities) for a 3D "
                                "case")
        vel = np.stack([c for c in comps if c is not None], axis=1)
    vel = np.asarray(vel, float).reshape(n, -1)
    if vel.shape[1] != pos.shape[1] and not (vel.shape[1] == 3 and pos.shape[1] == 2):
        raise PostprocError(f"{path}: velocities have {vel.shape[1]} components, positions "
                            f"{pos.shape[1]}")
    # the plane of a 2D run: constant z (x, y), or constant y (x, z), the
    # plane DualSPHysics runs 2D cases in
    if pos.shape[1] == 3:
        spread = np.ptp(pos, axis=0)
        flat = spread <= 1e-12 * max(float(np.max(spread)), 1e-300)
        if case_dim == 3:
            if flat.any():
                raise PostprocError(f"{path}: 2D data (all {'xyz'[int(np.argmax(flat))]} "
                                    "equal) for a 3D case (ellipsoid3d)")
        else:
            if not flat.any():
                raise PostprocError(f"{path}: 3D data (x, y and z all vary) for a 2D case")
            keep = [0, 1] if flat[2] else ([0, 2] if flat[1] else [1, 2])
            pos = pos[:, keep]
            vel = vel[:, keep] if vel.shape[1] == 3 else vel
    elif case_dim == 3:
        raise PostprocError(f"{path}: 2D data (2 coordinates) for a 3D case (ellipsoid3d)")
    if vel.shape[1] == 3 and case_dim == 2:
        vel = vel[:, :2]
    ids = _field(data, path, "id", names("id"), fmt, n)
    if ids is not None:
        ids = np.asarray(ids).astype(np.int64)
        if fmt == "pysph" and np.all(ids == UINT_MAX):
            ids = None          # gid never set (get_particle_array's default)
        else:
            u, counts = np.unique(ids, return_counts=True)
            if len(u) != n:
                raise PostprocError(f"{path}: the ids repeat (id {u[np.argmax(counts)]} "
                                    f"{counts.max()} times): expected one id per particle, "
                                    "or no ids")
    pres = _field(data, path, "p", names("p"), fmt, n)
    rho = _field(data, path, "rho", names("rho"), fmt, n)
    mass = _field(data, path, "m", names("m"), fmt, n)
    for key, a in (("x", pos), ("u", vel), ("p", pres), ("rho", rho), ("m", mass)):
        if a is not None and not np.all(np.isfinite(a)):
            raise PostprocError(f"{path}: {WHAT[key]} not finite (NaN or infinity)")
    return Frame(path, time, ids, pos, vel,
                 None if pres is None else np.asarray(pres, float),
                 None if rho is None else np.asarray(rho, float),
                 None if mass is None else np.asarray(mass, float))


def read_frame(path, fmt, fields, case_dim, pysph_array=None):
    """One output file as a Frame (its time may still be None)."""
    if fmt == "plain":
        reader = read_plain_npz if path.lower().endswith(".npz") else read_plain_csv
        data, time, points = reader(path)
    elif fmt == "vtk":
        data, time, points = read_vtk(path)
    elif fmt == "pysph":
        data, time, points = read_pysph(path, pysph_array)
    else:
        raise PostprocError(f"{path}: unknown format '{fmt}'")
    return canonical(path, data, points, time, fmt, fields, case_dim)


# ---------------------------------------------------------------------------
# A foreign run
# ---------------------------------------------------------------------------

class ForeignRun(Run):
    """Another code's output as a run: the attributes of core.Run (path,
    case, ts, time, n_particles, dx, snapshots: the files) with a time
    series of one row per file, computed here from the particles against
    the exact solution (sphpost.exact) in the units of the options.

    missing   {measure: reason} of what the run cannot give (no ids: no
              Lagrangian position error)
    outlines  {time: free-surface polylines} of the first and last files (2D)
    """

    def __init__(self, path, args):
        self.path = os.path.abspath(str(path))
        self.nml = {}
        self._n = None
        self.missing = {}
        self.probe = None
        self.outlines = {}
        self._probe_h = getattr(args, "probe_h", None)
        self._notes = set()
        name = getattr(args, "case", None)
        if not name:
            raise PostprocError(f"'{path}' is not an sph run directory (no timeseries.csv): "
                                "for another code's output give --case circle2d, ellipsoid3d, "
                                "square_rotation or square_vortical")
        self.case = self._case(name, args)
        c = self.case
        self._fields = parse_fields(getattr(args, "fields", None))
        self._pysph_array = getattr(args, "pysph_array", None)
        self._output_dt = getattr(args, "output_dt", None)
        self.snapshots, self.format = find_files(str(path), getattr(args, "format", None),
                                                 getattr(args, "pattern", None))
        self._centre = np.zeros(c.dim)
        if getattr(args, "centre", None):
            self._centre = np.array(_numbers(args.centre, "--centre", (c.dim,)))
        self._pvd = pvd_times(os.path.dirname(self.snapshots[0]) or ".")
        rows, first, prev = [], None, None
        for f in self.snapshots:
            fr = self._frame(f)
            if prev is not None and not fr.t > prev.t:
                raise PostprocError(f"{f}: time {fr.t:g} is not after the time {prev.t:g} of "
                                    f"{os.path.basename(prev.path)}: the times are not sorted "
                                    "in the order of the file names (or repeat)")
            if first is None:
                first = fr
                self._check_units(fr)
                self._n = fr.n
                if not abs(fr.t) <= 1e-9 / c.rate:
                    self.missing["pos"] = (f"the first file is at {c.time_label} = "
                                           f"{fr.t * c.rate:g}, not 0: no initial positions")
                    self.case.notes.append(f"{self.missing['pos']}; the semi-axes and the "
                                           "exact kinetic energy are the continuum's")
                elif fr.ids is None:
                    self.missing["pos"] = ("no particle ids: the Lagrangian position error "
                                           "needs each particle's initial position")
            elif "pos" not in self.missing and fr.ids is None:
                raise PostprocError(f"{f}: no particle ids (the first file, "
                                    f"{os.path.basename(first.path)}, has them)")
            elif "pos" not in self.missing and (fr.n != first.n or not np.array_equal(
                    np.sort(fr.ids), first.sorted_ids)):
                raise PostprocError(f"{f}: its particle ids are not those of "
                                    f"{os.path.basename(first.path)} ({fr.n} particles "
                                    f"against {first.n})")
            if first is fr and fr.ids is not None:
                order = np.argsort(fr.ids)
                fr.sorted_ids, fr.x0_by_id = fr.ids[order], fr.x[order]
            rows.append(self._row(fr, first))
            if c.square and (fr is first or f == self.snapshots[-1]):
                self.outlines[fr.t] = free_surface_outline(fr.x, self._volume(fr), self._dx)
            prev = fr
        if len(rows) < 2:
            raise PostprocError(f"'{path}': one output file ({self.snapshots[0]}); the time "
                                "means need at least two")
        self.ts = {k: np.array([r[k] for r in rows]) for k in rows[0]}
        self.time = self.ts["time"]
        if getattr(args, "probe_file", None):
            # '{}' stands for the run's path: one option for several runs
            self.probe = self._read_probe(args.probe_file.replace("{}", str(path)))

    def _frame(self, path):
        """One output file as a Frame, its time set and its positions taken
        about --centre."""
        fr = read_frame(path, self.format, self._fields, self.case.dim, self._pysph_array)
        fr.t = self._time(fr, self._pvd, self._output_dt)
        fr.x = fr.x - self._centre
        return fr

    # -- the case in the options' units --------------------------------
    @staticmethod
    def _case(name, args):
        """The case (CaseInfo) in the units of the options; the options'
        values, given or assumed, in its units."""
        length = getattr(args, "length", None) or 1.0
        rho = getattr(args, "rho", None) or 1.0
        nml = {"run": {"case": name}, "physics": {"rho0": rho}}
        opts = [("--length", length)]
        if name in ("circle2d", "ellipsoid3d"):
            a0 = getattr(args, "rate", None) or 1.0
            nml[name] = {"radius": length, "a0": a0}
            speed = a0 * length
            opts.append(("--rate", a0))
            if name == "ellipsoid3d" and getattr(args, "rates", None):
                rates = _numbers(args.rates, "--rates", (3,))
                if abs(sum(rates)) > 1e-12 * max(map(abs, rates)):
                    raise PostprocError(f"--rates {args.rates}: the rates must sum to 0")
                nml[name]["rates"] = rates
        elif name == "square_rotation":
            omega = getattr(args, "rate", None) or 1.0
            nml[name] = {"side": length, "omega": omega}
            speed = omega * length
            opts.append(("--rate", omega))
        else:
            v0 = getattr(args, "v0", None) or 1.0
            nml[name] = {"side": length, "v0": v0}
            speed = v0
            opts.append(("--v0", v0))
        c0 = CASES[name].c0 * speed         # the shipped input's, in the options' units
        given = getattr(args, "c0", None)
        nml["physics"]["c0"] = given or c0
        c = case_info(nml)
        if not given:
            c.notes.append(f"c0 not given (--c0): assumed {c0:g}, the shipped input's "
                           f"{CASES[name].c0:g} {CASES[name].speed}")
        opts += [("--rho", rho), ("--c0", given or c0)]
        c.units = " ".join(f"{k} {v:g}" for k, v in opts) + f" ({c.c0_label})"
        return c

    def _time(self, fr, pvd, output_dt):
        if fr.t is not None:
            return fr.t
        base = os.path.basename(fr.path)
        if base in pvd:
            return pvd[base]
        if output_dt:
            nums = re.findall(r"\d+", os.path.splitext(base)[0])
            if nums:
                return output_dt * int(nums[-1])
        m = TIME_IN_NAME.search(os.path.splitext(base)[0])
        if m:
            return float(m.group(1))
        raise PostprocError(f"{fr.path}: no time: expected a '# time = T' line (CSV), a "
                            "'time' entry (.npz), TimeValue field data or a .pvd collection "
                            "(VTK), solver_data t (PySPH), a name like NAME_t0.25.csv, or "
                            "--output-dt")

    def _volume(self, fr):
        if fr.m is not None and fr.rho is not None:
            return fr.m / fr.rho
        return np.full(fr.n, self._patch_volume() / fr.n)

    def _patch_volume(self):
        return patch_volume(self.case)

    @property
    def _dx(self):
        return (self._patch_volume() / self._n) ** (1 / self.case.dim)

    def _masses(self, fr):
        if fr.m is not None:
            return fr.m
        if "mass" not in self._notes:
            self._notes.add("mass")
            self.case.notes.append("no masses in the files: each particle has rho V / N")
        return np.full(fr.n, self.case.rho0 * self._patch_volume() / fr.n)

    def _check_units(self, fr):
        """Refuses a first file whose scales are off the case's by more than
        UNIT_TOLERANCE (a run in mm, or in kg/m^3 against rho = 1)."""
        c = self.case

        def off(what, got, want, option):
            if got > 0 and want > 0 and not 1 / UNIT_TOLERANCE < got / want < UNIT_TOLERANCE:
                raise PostprocError(
                    f"{fr.path}: the {what} is {got:.4g}, the case expects about {want:.4g} "
                    f"(ratio {got / want:.3g}): the file's units are not the case's; give "
                    f"{option}")
        extent = float(np.max(np.abs(fr.x)))
        off("largest |position| about the centre", extent,
            c.length * (1.0 if c.stretching else 0.5 * math.sqrt(2)), "--length (or --centre)")
        speed = float(np.sqrt(np.mean(np.sum(fr.u**2, axis=1))))
        off("RMS speed", speed, c.rate * c.length * (0.5 if c.square else 0.7),
            "--rate or --v0")
        if fr.rho is not None:
            off("mean density", float(np.mean(fr.rho)), c.rho0, "--rho")
        if fr.p is not None:
            off("largest |pressure|", float(np.max(np.abs(fr.p))), 0.2 * c.p_unit,
                "--rho (and --length, --rate)")

    def _row(self, fr, first):
        c = self.case
        m = self._masses(fr)
        row = {"time": fr.t, "kinetic_energy": 0.5 * float(np.sum(m * np.sum(fr.u**2, 1)))}
        if c.stretching:
            s = exact.stretching(fr.t, c.rates, c.length, c.rho0)
            a, al, big_p = s.a[0], s.alpha[0], float(s.P[0])
            fit = fitted_semi_axes(fr.x, m)
            if abs(first.t) > 1e-9 / c.rate:          # no initial positions
                fit_exact = a
                ke_exact = float(exact.stretching_kinetic_energy(al, a, c.length, np.sum(m)
                                                                 / self._patch_volume()))
            else:
                m0 = self._masses(first)
                fit_exact = fitted_semi_axes(first.x, m0) * a / c.length
                ke_exact = 0.5 * float(np.sum(m0 * np.sum((al * first.x * a / c.length)**2, 1)))
            row["kinetic_energy_exact"] = ke_exact
            for k in range(c.dim):
                row[f"semi_axis_{k + 1}"] = fit[k]
                row[f"semi_axis_{k + 1}_exact"] = a[k]
                row[f"semi_axis_{k + 1}_error"] = fit[k] / fit_exact[k] - 1
            if "pos" not in self.missing:
                x0 = first.x0_by_id[np.searchsorted(first.sorted_ids, fr.ids)]
                xe = exact.lagrangian_map(x0, a, c.length)
                row["rms_position_error"] = math.sqrt(np.mean(np.sum((fr.x - xe)**2, 1))) \
                    / c.length
            du = fr.u - exact.stretching_velocity(fr.x, al)
            row["rms_velocity_error"] = math.sqrt(np.mean(np.sum(du**2, 1))) / (c.rate * c.length)
            row["p_centre_exact"] = big_p
        row["p_probe_1"] = self._probe_estimate(fr)
        return row

    def _probe_estimate(self, fr):
        c = self.case
        if fr.p is None:
            if "p" not in self._notes:
                self._notes.add("p")
                self.case.notes.append(f"{fr.path}: no pressures (the centre pressure needs "
                                       "them, or --probe-file)")
            return float("nan")
        h = self._h
        point = np.array(PROBES[c.name]) * c.length
        return pressure_at(point, fr.x, fr.p, self._volume(fr), h)

    @property
    def _h(self):
        return getattr(self, "_probe_h", None) or 2 * self._dx

    def _read_probe(self, path):
        """--probe-file: columns t (or time) and p, times increasing."""
        if not os.path.isfile(path):
            raise PostprocError(f"probe file '{path}' does not exist")
        try:
            ts = read_timeseries(path)
        except ValueError as e:
            raise PostprocError(f"{path}: not a CSV of numbers with a header t,p ({e})")
        tcol = "t" if "t" in ts else ("time" if "time" in ts else None)
        if tcol is None or "p" not in ts:
            raise PostprocError(f"{path}: expected the columns t (or time) and p, found "
                                f"{', '.join(ts)}")
        t, p = ts[tcol], ts["p"]
        bad = np.nonzero(np.diff(t) <= 0)[0]
        if len(bad):
            raise PostprocError(f"{path} line {bad[0] + 3}, column '{tcol}': time {t[bad[0] + 1]:g}"
                                f" is not after {t[bad[0]]:g} (expected increasing times)")
        return t, p

    # -- what core.Run's users ask for ----------------------------------
    @property
    def n_particles(self):
        return self._n

    def snapshot_times(self):
        return self.time

    def snapshot(self, index):
        """Output file `index` as core.Run.snapshot gives ours: position,
        velocity and what else the file has (pressure, density, mass, id),
        sorted by id when there are ids, and 'attrs' with the time and, for
        the stretching cases, the exact semi-axes and centre pressure."""
        fr = self._frame(self.snapshots[index])
        order = np.argsort(fr.ids) if fr.ids is not None else np.arange(fr.n)
        out = {"position": fr.x[order], "velocity": fr.u[order]}
        for key, v in (("pressure", fr.p), ("density", fr.rho), ("mass", fr.m),
                       ("id", fr.ids)):
            if v is not None:
                out[key] = v[order]
        if "mass" not in out:
            out["mass"] = self._masses(fr)[order]
        if "density" not in out:
            out["density"] = out["mass"] / self._volume(fr)[order]
        c = self.case
        attrs = {"time": fr.t, "dim": c.dim, "case": c.name}
        if c.stretching:
            ex = exact.stretching(fr.t, c.rates, c.length, c.rho0)
            for k in range(c.dim):
                attrs[f"semi_axes_exact_{k + 1}"] = float(ex.a[0][k])
            attrs["p_centre_exact"] = float(ex.P[0])
        out["attrs"] = attrs
        return out

    def centre_probe(self):
        if self.probe is not None or np.isfinite(self.ts["p_probe_1"]).sum() >= 2:
            return "p_probe_1"
        return None

    def probe_samples(self, name):
        """The probe file's samples (--probe-file) for p_probe_1 when given,
        else the estimates from the particles, one per file."""
        if self.probe is not None and name == "p_probe_1":
            return self.probe
        return super().probe_samples(name)

    def probe_signal(self, name):
        if self.probe is None:
            return super().probe_signal(name)
        t, p = self.probe
        c = self.case
        return t, p, exact.stretching(t, c.rates, c.length, c.rho0).P

    def window(self, until):
        super().window(until)
        if self.probe is not None:
            t, p = self.probe
            keep = t <= self.time[-1] * (1 + 1e-12)
            self.probe = (t[keep], p[keep])
        return self
