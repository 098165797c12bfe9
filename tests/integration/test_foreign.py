"""Other codes' runs (sphpost.foreign, issue 36): the plain format, VTK and
PySPH files written here from a known exact field, with known perturbations,
give back the errors put in; one of our runs written in every format gives
its own report; bad files are refused with one line; the exact solutions'
API (sphpost.exact) against doc/theory/'s reference values."""
import json
import math
import subprocess
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.image  # noqa: E402
import numpy as np
import pytest

from common import ROOT, run_sph, read_timeseries

POSTPROC = ROOT / "postproc"
sys.path.insert(0, str(POSTPROC))
import sphpost as sp  # noqa: E402
from sphpost import exact  # noqa: E402


def errors(*args, check=True):
    p = subprocess.run([str(POSTPROC / "errors")] + [str(a) for a in args],
                       capture_output=True, text=True, timeout=120)
    if check:
        assert p.returncode == 0, f"errors {args}: exit {p.returncode}\n{p.stdout}{p.stderr}"
    return p


def report(*args):
    return json.loads(errors(*args, "--json").stdout)


# ---------------------------------------------------------------------------
# Writers of each format (what another code would write)
# ---------------------------------------------------------------------------

def write_plain_csv(d, frames, ids=True, time_in="header"):
    """The plain format as doc/reference/other-codes.md specifies it."""
    d.mkdir(parents=True, exist_ok=True)
    for k, f in enumerate(frames):
        dim = f["x"].shape[1]
        cols = (["id"] if ids else []) + ["x", "y", "z"][:dim] + ["u", "v", "w"][:dim] + \
            ["p", "rho", "m"]
        data = ([f["id"]] if ids else []) + [f["x"][:, i] for i in range(dim)] + \
            [f["u"][:, i] for i in range(dim)] + [f["p"], f["rho"], f["m"]]
        name = f"frame_{k:04d}.csv" if time_in == "header" else f"frame_t{f['t']!r}.csv"
        with open(d / name, "w") as out:
            if time_in == "header":
                out.write(f"# time = {f['t']!r}\n")
            out.write(",".join(cols) + "\n")
            for row in zip(*data):
                out.write(",".join(repr(float(v)) for v in row) + "\n")
    return d


def write_plain_npz(d, frames):
    d.mkdir(parents=True, exist_ok=True)
    for k, f in enumerate(frames):
        dim = f["x"].shape[1]
        cols = {c: f["x"][:, i] for i, c in enumerate("xyz"[:dim])}
        cols.update({c: f["u"][:, i] for i, c in enumerate("uvw"[:dim])})
        np.savez(d / f"frame_{k:04d}.npz", time=f["t"], id=f["id"], p=f["p"], rho=f["rho"],
                 m=f["m"], **cols)
    return d


def write_vtk(d, frames, kind="vtp", plane="xy", names=("Idp", "Vel", "Press", "Rhop", "Mass"),
              time=True):
    """VTK files as DualSPHysics' PartVTK (legacy binary .vtk, points in 3D,
    a 2D case in the x-z plane, no time) or SPHinXsys (.vtp) write them."""
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk
    d.mkdir(parents=True, exist_ok=True)
    for k, f in enumerate(frames):
        n, dim = f["x"].shape
        x3, u3 = np.zeros((n, 3)), np.zeros((n, 3))
        cols = list(range(dim)) if plane == "xy" else [0, 2]
        x3[:, cols], u3[:, cols] = f["x"], f["u"]
        pts = vtk.vtkPoints()
        pts.SetData(numpy_to_vtk(x3, deep=True))
        ds = vtk.vtkUnstructuredGrid() if kind == "vtu" else vtk.vtkPolyData()
        ds.SetPoints(pts)
        for name, a in zip(names, (f["id"].astype(np.int32), u3, f["p"], f["rho"], f["m"])):
            if name:
                va = numpy_to_vtk(np.ascontiguousarray(a), deep=True)
                va.SetName(name)
                ds.GetPointData().AddArray(va)
        if time:
            tv = numpy_to_vtk(np.array([f["t"]]), deep=True)
            tv.SetName("TimeValue")
            ds.GetFieldData().AddArray(tv)
        w = {"vtp": vtk.vtkXMLPolyDataWriter, "vtu": vtk.vtkXMLUnstructuredGridWriter,
             "vtk": vtk.vtkPolyDataWriter}[kind]()
        w.SetFileName(str(d / f"PartFluid_{k:04d}.{kind}"))
        if kind == "vtk":
            w.SetFileTypeToBinary()
        w.SetInputData(ds)
        w.Write()
    return d


def pysph_props(f):
    """A fluid ParticleArray's output arrays as PySPH names them (gid the
    global id), 3 components always."""
    n, dim = f["x"].shape
    out = {"gid": f["id"].astype(np.uint32), "pid": np.zeros(n, np.int32),
           "tag": np.zeros(n, np.int32), "p": f["p"], "rho": f["rho"], "m": f["m"],
           "h": np.full(n, 0.05)}
    for i, c in enumerate("xyz"):
        out[c] = f["x"][:, i] if i < dim else np.zeros(n)
    for i, c in enumerate("uvw"):
        out[c] = f["u"][:, i] if i < dim else np.zeros(n)
    return out


def write_pysph(d, frames, ext="npz"):
    """PySPH's dump layout (pysph.solver.utils.dump, output format version
    2): npz entries version, particles {array: {properties, constants,
    output_property_arrays, arrays}}, solver_data {t, dt, count}; hdf5
    groups particles/ARRAY/arrays/PROP (attributes name, type, default,
    stride, stored) and particles/ARRAY/constants, attributes of
    solver_data.  Files NAME_COUNT.EXT."""
    import h5py
    d.mkdir(parents=True, exist_ok=True)
    for k, f in enumerate(frames):
        arrays = pysph_props(f)
        props = {p: {"name": p, "type": "double" if a.dtype.kind == "f" else "int",
                     "default": 0, "stride": 1, "data": None} for p, a in arrays.items()}
        solver = {"t": f["t"], "dt": 1e-3, "count": 10 * k}
        path = d / f"drop_{10 * k}.{ext}"
        if ext == "npz":
            np.savez(path, version=2, solver_data=solver,
                     particles={"fluid": {"properties": props, "constants": {},
                                          "output_property_arrays": list(arrays),
                                          "arrays": arrays}})
        else:
            with h5py.File(path, "w") as h:
                sd = h.create_group("solver_data")
                for key, v in solver.items():
                    sd.attrs[key] = v
                g = h.create_group("particles").create_group("fluid")
                g.create_group("constants")
                ag = g.create_group("arrays")
                for p, a in arrays.items():
                    ds = ag.create_dataset(p, data=a, compression="gzip")
                    ds.attrs["stored"] = True
                    for key, v in props[p].items():
                        ds.attrs[key] = "None" if v is None else v
                ds = ag.create_dataset("au", (0,))          # a property not output
                ds.attrs["stored"] = False
    return d


# ---------------------------------------------------------------------------
# A known field: the exact stretching patch with perturbations put in
# ---------------------------------------------------------------------------

def disc_lattice(n_side, dim=2):
    g = (np.arange(n_side) + 0.5) / n_side * 2 - 1
    pts = np.stack([a.ravel() for a in np.meshgrid(*[g] * dim)], axis=1)
    return pts[np.sum(pts**2, axis=1) < 1]


def exact_frames(times, rates=(-1.0, 1.0), n_side=30, shift=None, bias=None, dp=0.0,
                 R=1.0, A0=1.0, rho=1.0):
    """Frames of the exact flow (X1) in units R, A0, rho, with each file's
    particles in its own random order and ids 10.. permuted; after t = 0
    the positions shifted by `shift` R (a wrong path), at every time a
    velocity bias `bias` A0 R, and a pressure offset dp P(0)."""
    dim = len(rates)
    x0 = disc_lattice(n_side, dim) * R
    n = len(x0)
    vol = math.pi * R**2 if dim == 2 else 4 / 3 * math.pi * R**3
    m = np.full(n, rho * vol / n)
    ids = np.random.default_rng(5).permutation(n) + 10
    rates = np.asarray(rates, float) * A0
    sol = exact.stretching(np.asarray(times) / A0, rates, R, rho)
    frames = []
    for k, t in enumerate(times):
        a, al, big_p = sol.a[k], sol.alpha[k], sol.P[k]
        x = exact.lagrangian_map(x0, a, R)
        if shift is not None and t > 0:
            x = x + np.asarray(shift) * R
        u = exact.stretching_velocity(x, al)
        if bias is not None:
            u = u + np.asarray(bias) * A0 * R
        # the exact pressure at the particle (relative to the ellipse's
        # centre, which the shift moves with the particles)
        xc = x - (np.asarray(shift) * R if shift is not None and t > 0 else 0)
        p = exact.stretching_pressure(xc, a, big_p) + dp * sol.P[0]
        o = np.random.default_rng(k).permutation(n)
        frames.append({"t": t / A0, "id": ids[o], "x": x[o], "u": u[o], "p": p[o],
                       "rho": np.full(n, rho), "m": m[o], "x_exact": exact.lagrangian_map(
                           x0, a, R)[o], "alpha": al, "a": a,
                       "P": big_p, "P0": sol.P[0], "dp": dp, "shift": shift})
    return frames


def expected_means(frames, shift, bias, R=1.0, A0=1.0):
    """The errors the perturbations put in, computed here from the frames:
    the shift moves the pressure field too, so the pressure at the centre
    is P (1 - Sum (shift_k R/a_k)^2) + dp P(0) after t = 0."""
    t = np.array([f["t"] for f in frames]) * A0
    pos = np.array([np.linalg.norm(shift) if f["t"] > 0 else 0.0 for f in frames])
    vel = np.full(len(t), np.linalg.norm(bias))
    ke = np.array([np.sum(f["m"] * np.sum(f["u"]**2, 1)) /
                   np.sum(f["m"] * np.sum((f["alpha"] * f["x_exact"])**2, 1)) - 1
                   for f in frames])
    p_raw = np.array([(f["P"] * (-np.sum((np.asarray(shift) * R / f["a"])**2) if f["t"] > 0
                                  else 0.0)) / f["P0"] + f["dp"] for f in frames])
    mean = {k: float(np.trapz(np.abs(v), t) / (t[-1] - t[0]))
            for k, v in (("pos", pos), ("vel", vel), ("ke", ke), ("p_raw", p_raw))}
    return mean, {"pos": pos[-1], "vel": vel[-1], "ke": ke[-1], "p_raw": p_raw[-1]}


TIMES = np.linspace(0.0, 1.0, 11)
SHIFT, BIAS, DP = (0.003, -0.002), (0.004, 0.001), 0.0125


@pytest.fixture(scope="module")
def perturbed(tmp_path_factory):
    """The perturbed exact circle2d in every format."""
    d = tmp_path_factory.mktemp("foreign_exact")
    fr = exact_frames(TIMES, shift=SHIFT, bias=BIAS, dp=DP)
    runs = {"csv": (write_plain_csv(d / "csv", fr), []),
            "csv_t_in_name": (write_plain_csv(d / "csvname", fr, time_in="name"), []),
            "npz": (write_plain_npz(d / "npz", fr), []),
            "vtp": (write_vtk(d / "vtp", fr), []),
            "vtu": (write_vtk(d / "vtu", fr, "vtu"), []),
            "vtk_xz": (write_vtk(d / "vtk", fr, "vtk", "xz", time=False), ["--output-dt", 0.1]),
            "pysph_npz": (write_pysph(d / "pysph_npz", fr, "npz"), []),
            "pysph_hdf5": (write_pysph(d / "pysph_hdf5", fr, "hdf5"), [])}
    return fr, runs, d


def test_every_reader_gives_back_the_errors_put_in(perturbed):
    frames, runs, _ = perturbed
    mean, final = expected_means(frames, SHIFT, BIAS)
    for name, (d, extra) in runs.items():
        r = report("--case", "circle2d", d, *extra)
        assert r["n"] == len(frames[0]["id"]), name
        # (the KE error is a difference of two KEs, each to 1e-12: the
        # exact solution's own integration)
        # the centre estimate (a weighted quadratic fit) is exact for the
        # quadratic pressure plus a constant
        for k in ("pos", "vel", "ke", "p_raw"):
            assert math.isclose(r["mean"][k], mean[k], rel_tol=1e-9, abs_tol=1e-11), \
                (name, k, r["mean"][k], mean[k])
            assert math.isclose(r["final"][k], final[k], rel_tol=1e-9, abs_tol=1e-11), \
                (name, k)
        # a rigid shift moves the centre of mass, not the second moments
        assert r["mean"]["axis_max"] < 1e-12, (name, r["mean"])
        # the filter keeps the offset (its gain at f = 0 is 1); the shift's
        # part is below 3e-5 of P(0)
        assert abs(r["final"]["p_filt"] - DP) < 3e-5, (name, r["final"])


def test_snapshot_tools_refuse_a_foreign_run(perturbed):
    # the options that read what only our snapshots hold (initial positions,
    # exact velocities) refuse another code's run with one line naming them
    _, runs, _ = perturbed
    d, _ = runs["csv"]
    for opt in ("--check-snapshots", "--velocity-split", "--plane-bands"):
        p = errors("--case", "circle2d", d, opt, check=False)
        assert p.returncode == 2, (opt, p.returncode, p.stdout, p.stderr)
        assert "another code's output" in p.stderr and "--plane-bands" in p.stderr, p.stderr


def test_units_of_a_run_in_si(tmp_path):
    # the same field with R = 0.25 m, A0 = 4 /s, rho = 1000 kg/m^3: the
    # options give the same relative errors; without them it is refused
    fr = exact_frames(TIMES, shift=SHIFT, bias=BIAS, dp=DP, R=0.25, A0=4.0, rho=1000.0)
    d = write_plain_npz(tmp_path / "si", fr)
    mean, _ = expected_means(fr, SHIFT, BIAS, R=0.25, A0=4.0)
    r = report("--case", "circle2d", d, "--length", 0.25, "--rate", 4, "--rho", 1000)
    for k in ("pos", "vel", "ke"):
        assert math.isclose(r["mean"][k], mean[k], rel_tol=1e-9, abs_tol=1e-11), k
    assert math.isclose(r["mean"]["p_raw"], mean["p_raw"], rel_tol=1e-9)
    p = errors("--case", "circle2d", d, "--length", 0.25, "--rate", 4, check=False)
    assert p.returncode == 2 and "mean density is 1000" in p.stderr and "--rho" in p.stderr, \
        p.stderr


def test_ellipsoid3d_and_a_run_without_ids(tmp_path):
    times = np.linspace(0.0, 0.5, 6)
    shift, bias = (0.002, 0.0, -0.001), (0.0, 0.003, 0.001)
    fr = exact_frames(times, (-1.0, -1.0, 2.0), 14, shift, bias)
    mean, _ = expected_means(fr, shift, bias)
    r = report("--case", "ellipsoid3d", write_plain_csv(tmp_path / "e3", fr))
    for k in ("pos", "vel", "ke"):
        assert math.isclose(r["mean"][k], mean[k], rel_tol=1e-9, abs_tol=1e-11), k
    # the same 3D particles as .vtu
    v = report("--case", "ellipsoid3d", write_vtk(tmp_path / "e3vtu", fr, "vtu"))
    for k, val in r["mean"].items():
        assert math.isclose(v["mean"][k], val, rel_tol=1e-12, abs_tol=1e-13), k
    # without ids: the position error is left out and said so, the rest the same
    d = write_plain_csv(tmp_path / "noid", fr, ids=False)
    q = report("--case", "ellipsoid3d", d)
    assert "pos" not in q["mean"] and "no particle ids" in q["missing"]["pos"]
    for k in ("axis_max", "vel", "ke", "p_raw", "p_filt"):
        assert math.isclose(q["mean"][k], r["mean"][k], rel_tol=1e-9, abs_tol=1e-14), k
    text = errors("--case", "ellipsoid3d", d).stdout
    assert "left out: pos (no particle ids" in text


# ---------------------------------------------------------------------------
# One of our runs, written in the other formats
# ---------------------------------------------------------------------------

def our_frames(run_dir):
    run = sp.Run(run_dir)
    out = []
    for i in range(len(run.snapshots)):
        s = run.snapshot(i)
        out.append({"t": s["attrs"]["time"], "id": s["id"], "x": s["position"],
                    "u": s["velocity"], "p": s["pressure"], "rho": s["density"],
                    "m": s["mass"]})
    return out


@pytest.fixture(scope="module")
def our_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("foreign_ours")
    p = run_sph(["input/circle2d.nml", "particles.n=1250", "run.t_end=0.5", "output.dt=0.05",
                 f"output.dir={d / 'run'}"])
    assert p.returncode == 0, p.out
    ts = read_timeseries(d / "run" / "timeseries.csv")
    with open(d / "centre.csv", "w") as f:
        f.write("t,p\n" + "".join(f"{t!r},{p!r}\n" for t, p in zip(ts["time"], ts["p_probe_1"])))
    fr = our_frames(d / "run")
    return d, {"plain": write_plain_csv(d / "plain", fr), "vtk": write_vtk(d / "vtk", fr),
               "pysph": write_pysph(d / "pysph", fr, "hdf5")}


def test_our_run_in_every_format_gives_its_own_report(our_run):
    d, runs = our_run
    ours = report(d / "run")
    ts = read_timeseries(d / "run" / "timeseries.csv")
    t = np.array(ts["time"])
    c0 = sp.Run(d / "run").case.c0
    reps = {}
    for name, path in runs.items():
        reps[name] = report("--case", "circle2d", path, "--c0", c0,
                            "--probe-file", d / "centre.csv")
    for name, r in reps.items():
        # every format the same numbers
        for k, v in reps["plain"]["mean"].items():
            assert math.isclose(r["mean"][k], v, rel_tol=1e-12, abs_tol=1e-15), (name, k)
        # the pressure from the same probe series: our report's to round-off
        for k in ("p_raw", "p_filt", "p_filt_bias"):
            assert math.isclose(r["mean"][k], ours["mean"][k], rel_tol=1e-9), (name, k)
            assert math.isclose(r["final"][k], ours["final"][k], rel_tol=1e-9, abs_tol=1e-12), k
        # the particle measures at the output times: the solver's time series
        # there, so their means are those of its rows at those times
        rows = [int(np.argmin(np.abs(t - tt))) for tt in sp.Run(d / "run").snapshot_times()]
        for k, col in (("pos", "rms_position_error"), ("vel", "rms_velocity_error"),
                       ("axis_1", "semi_axis_1_error")):
            ref = np.trapz(np.abs(np.array(ts[col])[rows]), t[rows]) / (t[rows][-1] - t[0])
            assert math.isclose(r["mean"][k], ref, rel_tol=1e-9), (name, k, r["mean"][k], ref)
            assert math.isclose(r["final"][k], ours["final"][k], rel_tol=1e-9), (name, k)
        assert math.isclose(r["final"]["ke"], ours["final"]["ke"], rel_tol=1e-9)


def test_convergence_filter_and_plots_take_foreign_runs(our_run, tmp_path):
    d, runs = our_run
    p = subprocess.run([str(POSTPROC / "convergence"), "--case", "circle2d", runs["plain"],
                        runs["vtk"], d / "run", "-o", tmp_path / "c.png", "--json",
                        tmp_path / "c.json"], capture_output=True, text=True, timeout=120)
    # three runs of the same resolution: no order, but the table
    assert p.returncode == 0, p.stdout + p.stderr
    rows = json.loads((tmp_path / "c.json").read_text())["rows"]
    assert len(rows) == 3 and len({r["n"] for r in rows}) == 1
    p = subprocess.run([str(POSTPROC / "filter"), "--case", "circle2d", runs["plain"],
                        "--probe-file", "{}/../centre.csv", "--c0", str(sp.Run(d / "run").case.c0),
                        "-o", tmp_path / "f.csv"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    q = subprocess.run([str(POSTPROC / "filter"), d / "run", "-o", tmp_path / "g.csv"],
                       capture_output=True, text=True, timeout=120)
    a = np.genfromtxt(tmp_path / "f.csv", delimiter=",", names=True)
    b = np.genfromtxt(tmp_path / "g.csv", delimiter=",", names=True)
    assert np.allclose(a["p_probe_1_filtered"], b["p_probe_1_filtered"], rtol=0, atol=1e-12)
    png = tmp_path / "p.png"
    p = subprocess.run([str(POSTPROC / "plots"), "pressure", "--case", "circle2d", runs["vtk"],
                        d / "run", "--probe-file", d / "centre.csv", "-o", png, "--dpi", "40"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and png.read_bytes()[:4] == b"\x89PNG", p.stdout + p.stderr


def test_square_report_ours_and_foreign(tmp_path):
    p = run_sph(["input/square_rotation.nml", "particles.n=400", "run.t_end=0.3",
                 "output.dt=0.1", f"output.dir={tmp_path / 'run'}"])
    assert p.returncode == 0, p.out
    ours = report(tmp_path / "run")
    plain = report("--case", "square_rotation", "--c0", 7,
                   write_plain_csv(tmp_path / "plain", our_frames(tmp_path / "run")))
    assert math.isclose(plain["ke_first"], ours["ke_first"], rel_tol=1e-12)
    assert math.isclose(plain["ke_end"], ours["ke_end"], rel_tol=1e-12)
    assert plain["outline"] == ours["outline"]
    # p_A(0) of the series (X3); the solver's probe within 3 % of P at 400 particles
    assert math.isclose(ours["p0_exact"], -0.147343, abs_tol=2e-6)
    assert abs(ours["p0_error"]) < 0.005 and abs(plain["p0_error"]) < 0.005
    assert ours["reference"] is None
    for tt, m in ours["outline"].items():
        assert abs(m["area"] - 1) < 0.03 and m["curves"] == 1, (tt, m)
    text = errors(tmp_path / "run").stdout
    assert "reference solution: none given" in text and "free surface at" in text


# ---------------------------------------------------------------------------
# Bad files: one line, the file, the field, what was expected; status 2
# ---------------------------------------------------------------------------

CIRCLE = ["--case", "circle2d"]


def bad_runs(base, good, frames):
    """The table: (name, run, options, words the message must hold); the
    runs are copies of the good plain run `good` with one fault each."""
    out = []

    def plain(name, edit, words, args=CIRCLE):
        d = base / name
        d.mkdir()
        for k, f in enumerate(sorted(good.glob("*.csv"))):
            (d / f.name).write_text(edit(k, f.read_text()))
        out.append((name, d, args, words))

    def drop(*names):
        def edit(_, text):
            lines = text.splitlines()
            head = lines[1].split(",")
            keep = [i for i, c in enumerate(head) if c not in names]
            return "\n".join(lines[:1] + [",".join(r.split(",")[i] for i in keep)
                                         for r in lines[1:]]) + "\n"
        return edit

    def in_mm(_, text):
        lines = text.splitlines()
        rows = [r.split(",") for r in lines[2:]]
        return "\n".join(lines[:2] + [",".join([r[0], repr(1000 * float(r[1])),
                                                repr(1000 * float(r[2]))] + r[3:])
                                      for r in rows]) + "\n"

    def set_line(k0, i, text_of):
        def edit(k, text):
            if k != k0:
                return text
            lines = text.splitlines()
            lines[i] = text_of(lines[i])
            return "\n".join(lines) + "\n"
        return edit

    plain("no_velocity", drop("u", "v"), ["frame_0000.csv", "no velocities", "'u' and 'v'",
                                          "--fields u=NAME"])
    plain("no_y", drop("y"), ["frame_0000.csv", "no positions", "'x' and 'y'"])
    plain("two_d_for_3d", lambda k, t: t, ["frame_0000.csv", "2D data", "3D case"],
          ["--case", "ellipsoid3d"])
    plain("unsorted", set_line(2, 0, lambda ln: "# time = 0.05"),
          ["frame_0002.csv", "time 0.05 is not after", "not sorted"])
    plain("in_mm", in_mm, ["frame_0000.csv", "largest |position|", "ratio 967", "--length"])
    plain("not_a_number", set_line(0, 2, lambda ln: ",".join(ln.split(",")[:5] + ["abc"]
                                                             + ln.split(",")[6:])),
          ["frame_0000.csv line 3, column 'p'", "'abc' is not a number"])
    plain("short_row", set_line(1, 4, lambda ln: "1,2"),
          ["frame_0001.csv line 5", "2 values, expected 8"])
    plain("no_time", lambda k, t: t.split("\n", 1)[1], ["frame_0000.csv", "no time"])
    plain("other_ids", set_line(3, 2, lambda ln: "999999" + ln[ln.index(","):]),
          ["frame_0003.csv", "particle ids are not those of frame_0000.csv"])
    def repeat_id(k, text):
        lines = text.splitlines()
        if k == 0:                  # the second particle gets the first one's id
            lines[3] = lines[2].split(",")[0] + lines[3][lines[3].index(","):]
        return "\n".join(lines) + "\n"

    plain("repeated_id", repeat_id, ["frame_0000.csv", "the ids repeat", "2 times",
                                     "expected one id per particle"])
    plain("nan_rho", set_line(1, 3, lambda ln: ",".join(ln.split(",")[:6] + ["nan"]
                                                       + ln.split(",")[7:])),
          ["frame_0001.csv", "densities not finite"])
    probes = base / "probes"
    probes.mkdir()
    (probes / "p.csv").write_text("t,p\n0,0.5\n0.2,0.4\n0.1,0.45\n")
    (probes / "q.csv").write_text("time,pressure\n0,0.5\n")
    out.append(("probe_unsorted", good, CIRCLE + ["--probe-file", probes / "p.csv"],
                ["p.csv line 4, column 't'", "expected increasing times"]))
    out.append(("probe_columns", good, CIRCLE + ["--probe-file", probes / "q.csv"],
                ["q.csv", "expected the columns t (or time) and p"]))
    d = base / "garbage_vtk"
    d.mkdir()
    (d / "PartFluid_0000.vtk").write_text("not vtk\n")
    out.append(("garbage_vtk", d, CIRCLE, ["PartFluid_0000.vtk", "not a readable VTK file"]))
    d = write_vtk(base / "vtk_no_velocity", frames[:2],
                  names=("Idp", None, "Press", "Rhop", "Mass"))
    out.append(("vtk_no_velocity", d, CIRCLE,
                ["PartFluid_0000.vtp", "no velocities", "one of Vel, Velocity",
                 "the file has: Idp, Mass, Press, Rhop", "--fields velocity=NAME"]))
    d = base / "fake_pysph"
    d.mkdir()
    np.savez(d / "drop_0.npz", particles=np.zeros(3))
    out.append(("pysph_no_version", d, CIRCLE, ["drop_0.npz", "not a PySPH .npz"]))
    d = base / "two_series"
    d.mkdir()
    for f in sorted(good.glob("*.csv"))[:2]:
        (d / f.name).write_text(f.read_text())
        (d / f.name.replace("frame", "bound")).write_text(f.read_text())
    out.append(("two_series", d, CIRCLE, ["several series", "--pattern"]))
    out += [("no_case", good, [], ["has no timeseries.csv", "give --case"]),
            ("bad_field_key", good, CIRCLE + ["--fields", "speed=Vel"],
             ["--fields: unknown key 'speed'"]),
            ("missing", base / "nothing", CIRCLE, ["does not exist"])]
    return out


def test_bad_files_are_refused_with_one_line(perturbed, tmp_path):
    frames, runs, _ = perturbed
    table = bad_runs(tmp_path, runs["csv"][0], frames)
    table += [("vtk_wrong_map", runs["vtp"][0], CIRCLE + ["--fields", "velocity=U"],
               ["no velocities", "one of U"]),
              ("vtk_xz_for_3d", runs["vtk_xz"][0], ["--case", "ellipsoid3d", "--output-dt", 0.1],
               ["PartFluid_0000.vtk", "2D data (all y equal)"])]
    for name, path, args, words in table:
        p = errors(*args, path, check=False)
        assert p.returncode == 2, (name, p.returncode, p.stdout, p.stderr)
        assert p.stdout == "" and "Traceback" not in p.stderr, (name, p.stderr)
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("errors: error: "), (name, p.stderr)
        for w in words:
            assert w in lines[0], (name, w, lines[0])


# ---------------------------------------------------------------------------
# The exact solutions as a library (doc/theory/ X1-X4, doc/theory/solutions.md I2)
# ---------------------------------------------------------------------------

def test_exact_api_against_the_reference_values():
    s = exact.stretching([0.5, 1.0, 2.0])
    assert np.allclose(s.a[:, 0], [0.627053, 0.439461, 0.271814], atol=1e-6)
    assert np.allclose(s.a[:, 1], [1.594763, 2.275516, 3.678985], atol=1e-6)
    assert np.allclose(s.P, [0.231943, 0.069327, 0.010799], atol=1e-6)
    assert np.allclose(np.prod(s.a, axis=1), 1.0, rtol=1e-11)          # area kept
    # P' against a central difference of P
    h = 1e-5
    q = exact.stretching([1.0 - h, 1.0 + h])
    assert math.isclose(s.dPdt[1], (q.P[1] - q.P[0]) / (2 * h), rel_tol=1e-7)
    s3 = exact.stretching(1.0, rates=(-1, -1, 2))
    assert np.allclose(s3.a[0], [0.54708, 0.54708, 3.34112], atol=1e-5)
    s30 = exact.stretching(0.0, (-1, -1, 2))
    assert math.isclose(s30.dPdt[0], -2.0 * s30.P[0], rel_tol=1e-12)     # P'(0) = -2 P(0) A0
    # KE = pi rho A0^2 R^4/4 in 2D and 4 pi/5 in 3D, kept in time
    assert np.allclose(exact.stretching_kinetic_energy(s.alpha, s.a), math.pi / 4, rtol=1e-10)
    assert math.isclose(float(exact.stretching_kinetic_energy(s3.alpha[0], s3.a[0])),
                        4 * math.pi / 5, rel_tol=1e-10)
    # I2 at t = 0: 1.5 % (2D) and 7/6 % (3D) of P(0) at c0 = 10
    assert math.isclose(exact.compressibility_floor(0.0)[0], 0.015, rel_tol=1e-10)
    assert math.isclose(exact.compressibility_floor(0.0, (-1, -1, 2))[0], 7 / 600, rel_tol=1e-10)
    # the squares' initial pressures by the sine series (X3, X4)
    p = exact.square_rotation_pressure([0.0, 0.25, 0.25], [0.0, 0.0, 0.25])
    assert np.allclose(p, [-0.147343, -0.114670, -0.090572], atol=2e-6), p
    assert math.isclose(exact.square_rotation_pressure(0.0, 0.0, 2.0, 3.0, 1000.0)[0],
                        -0.1473427 * 1000 * 9 * 4, rel_tol=1e-5)          # rho omega^2 L^2
    p = exact.square_vortical_pressure([0.25, 0.25], [0.25, -0.25])
    assert np.allclose(p, [-0.22945174776874602, 0.22945174776874602], atol=2e-7), p
    assert math.isclose(exact.square_rotation_kinetic_energy(), 1 / 12)
    with pytest.raises(ValueError):
        exact.stretching(1.0, rates=(-1, 2))


def test_the_papers_figures_of_a_foreign_run_are_ours(our_run, tmp_path):
    # Figure 1 drawn from our run directory and from the same run written as
    # plain CSV and as VTK: the same picture to the pixel (same particles,
    # same probe series, same exact solution)
    d, runs = our_run
    c0 = str(sp.Run(d / "run").case.c0)
    pictures = {}
    for name, args in (("ours", [d / "run"]),
                       ("plain", ["--case", "circle2d", runs["plain"], "--c0", c0,
                                  "--probe-file", d / "centre.csv"]),
                       ("vtk", ["--case", "circle2d", runs["vtk"], "--c0", c0,
                                "--probe-file", d / "centre.csv"])):
        png = tmp_path / f"{name}.png"
        p = subprocess.run([str(POSTPROC / "plots"), "circle", *args, "-o", png, "--dpi", "50"],
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0, p.stdout + p.stderr
        pictures[name] = matplotlib.image.imread(png)
    assert pictures["ours"].shape == pictures["plain"].shape
    assert np.array_equal(pictures["ours"], pictures["plain"])
    assert np.array_equal(pictures["ours"], pictures["vtk"])


def test_side_files_are_told_apart(perturbed, tmp_path):
    # a DualSPHysics PartVTK folder with the CSV tables a run writes beside
    # it and a ParaView collection, a plain-CSV folder with a probe's table:
    # read without --pattern, with the errors of the files alone
    import shutil
    frames, runs, _ = perturbed
    mean, _ = expected_means(frames, SHIFT, BIAS)
    d = shutil.copytree(runs["vtk_xz"][0], tmp_path / "dsph")
    (d / "Run.csv").write_text("Part;TimeStep;Time;Np\n0;0.001;0;316\n")
    (d / "RunPARTs.csv").write_text("Part;Time;TotalSteps\n0;0;0\n1;0.1;100\n")
    (d / "CfgInit_Domain.vtk").write_text("# vtk DataFile Version 3.0\n")
    c = shutil.copytree(runs["csv"][0], tmp_path / "plain")
    (c / "centre_probe.csv").write_text("t,p\n0,0.25\n1,0.07\n")
    for path, extra in ((d, ["--output-dt", 0.1]), (c, [])):
        r = report("--case", "circle2d", path, *extra)
        for k in ("pos", "vel", "ke"):
            assert math.isclose(r["mean"][k], mean[k], rel_tol=1e-9, abs_tol=1e-11), (path, k)
    # two numbered series that both hold particles: the message names them
    # with their real extensions and a --pattern taken from them
    for f in sorted(c.glob("frame_000[0-3].csv")):
        (c / f.name.replace("frame", "bound")).write_text(f.read_text())
    p = errors("--case", "circle2d", c, check=False)
    assert p.returncode == 2
    assert ("several series of particle files (frame_*.csv (11 files), bound_*.csv (4 files)): "
            "choose one with --pattern, e.g. --pattern 'frame_*.csv'") in p.stderr, p.stderr
