"""The package as a user installs it: `pip install ./postproc` into a fresh
virtual environment without system packages gives the command sphpost,
which reads, from another directory, a plain-CSV run and a PySPH output
directory with PySPH's side files (profile_info.csv, results.npz), and
gives back the errors put into the files (an exact field with known
perturbations, test_foreign's).  The figure's labels are in the case's
scale whatever the file's units.

The install takes pip and the Python package index (numpy, scipy, h5py,
matplotlib, pyFFTW: wheels); pip's cache (~/.cache/pip) keeps them, so CI
caches that directory between runs.  Offline, SPHPOST_WHEELS=DIR installs
from a directory of wheels (pip download -d DIR ./postproc) with --no-index.
Measured on two shared cores: about 50 s with the wheels in pip's cache,
3.5 minutes with an empty cache.
"""
import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest

from common import ROOT
from test_foreign import (BIAS, DP, SHIFT, TIMES, exact_frames, expected_means,
                          write_pysph, write_plain_csv)

# the elliptical drop of PySPH's examples (pysph.examples.elliptical_drop):
# R = 1 m, A0 = 100 /s, rho = 1000 kg/m^3, c0 = 1400 m/s = 14 A0 R
PYSPH_UNITS = {"length": 1.0, "rate": 100.0, "rho": 1000.0, "c0": 1400.0}


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A fresh virtual environment (no system site packages) with the
    package installed from ./postproc; returns its bin directory."""
    d = tmp_path_factory.mktemp("venv") / "v"
    t0 = time.time()
    subprocess.run([sys.executable, "-m", "venv", str(d)], check=True, timeout=120)
    # from a copy of the package's sources: setuptools builds in the source
    # tree, whose build/ may hold modules of an earlier layout
    src = d.parent / "postproc"
    shutil.copytree(ROOT / "postproc", src,
                    ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    cmd = [str(d / "bin" / "pip"), "install", "--no-compile", "--disable-pip-version-check",
           str(src)]
    if os.environ.get("SPHPOST_WHEELS"):
        cmd[3:3] = ["--no-index", "--find-links", os.environ["SPHPOST_WHEELS"]]
    p = subprocess.run(cmd, capture_output=True, encoding="utf-8", errors="replace", timeout=900)
    assert p.returncode == 0, f"pip install ./postproc failed:\n{p.stdout}\n{p.stderr}"
    print(f"fresh venv + pip install ./postproc: {time.time() - t0:.1f} s")
    return d / "bin"


def sphpost(venv, *args, cwd, check=True):
    p = subprocess.run([str(venv / "sphpost")] + [str(a) for a in args], cwd=cwd,
                       capture_output=True, encoding="utf-8", errors="replace", timeout=300,
                       env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    if check:
        assert p.returncode == 0, f"sphpost {args}: exit {p.returncode}\n{p.stdout}{p.stderr}"
    return p


def test_the_environment_is_its_own(venv, tmp_path):
    # no system packages, and sphpost comes from the environment, not the
    # source tree
    code = ("import sys, sphpost, numpy, pyfftw, h5py, scipy, matplotlib; "
            "print(sphpost.__file__); print(any('dist-packages' in p for p in sys.path))")
    p = subprocess.run([str(venv / "python"), "-c", code], cwd=tmp_path, capture_output=True,
                       encoding="utf-8", errors="replace", check=True)
    where, system = p.stdout.split()
    assert where.startswith(str(venv.parent)) and "site-packages" in where, where
    assert system == "False"
    # the VTK reader names its extra when VTK is missing
    (tmp_path / "vtk").mkdir()
    (tmp_path / "vtk" / "PartFluid_0000.vtk").write_text("# vtk DataFile Version 3.0\n")
    (tmp_path / "vtk" / "PartFluid_0001.vtk").write_text("# vtk DataFile Version 3.0\n")
    p = sphpost(venv, "errors", "--case", "circle2d", tmp_path / "vtk", cwd=tmp_path,
                check=False)
    assert p.returncode == 2 and "pip install 'sphpost[vtk]'" in p.stderr, p.stderr


def check_means(report, frames):
    """The report's time means against those the perturbations put in
    (test_foreign.expected_means, from the frames alone); the tolerances
    are test_foreign's: the exact solution's own integration."""
    mean, final = expected_means(frames, SHIFT, BIAS)
    for k in ("pos", "vel", "ke", "p_raw"):
        assert math.isclose(report["mean"][k], mean[k], rel_tol=1e-9, abs_tol=1e-11), \
            (k, report["mean"][k], mean[k])
        assert math.isclose(report["final"][k], final[k], rel_tol=1e-9, abs_tol=1e-11), k
    assert report["mean"]["axis_max"] < 1e-12
    assert abs(report["final"]["p_filt"] - DP) < 3e-5


def test_plain_csv_run_from_another_directory(venv, tmp_path):
    frames = exact_frames(TIMES, shift=SHIFT, bias=BIAS, dp=DP, n_side=20)
    d = write_plain_csv(tmp_path / "mycode" / "out", frames)
    # a side file beside the particle files: a probe's table
    (d / "centre.csv").write_text("t,p\n0,0.25\n1,0.07\n")
    p = sphpost(venv, "errors", "--case", "circle2d", "mycode/out", "--json", cwd=tmp_path)
    r = json.loads(p.stdout)
    assert r["n"] == len(frames[0]["id"]) == 316
    check_means(r, frames)
    # the mean velocity error is |bias| = 0.41 % of A0 R
    assert math.isclose(r["mean"]["vel"], math.hypot(*BIAS), rel_tol=1e-9)


def pysph_side_files(d):
    """The side files PySPH writes beside its dumps: profile_info.csv (every
    run) and the elliptical drop's results.npz (its post-processing)."""
    (d / "profile_info.csv").write_text(
        "rank,function,calls,time\n0,Integrator.step,380,12.5\n0,NNPS.update,380,3.1\n")
    np.savez(d / "results.npz", t=TIMES, major=np.ones(11), minor=np.ones(11))


def test_pysph_directory_with_side_files(venv, tmp_path):
    u = PYSPH_UNITS
    frames = exact_frames(TIMES, shift=SHIFT, bias=BIAS, dp=DP, n_side=20, R=u["length"],
                          A0=u["rate"], rho=u["rho"])
    d = write_pysph(tmp_path / "elliptical_drop_output", frames, "hdf5")
    pysph_side_files(d)
    opts = ["--length", u["length"], "--rate", u["rate"], "--rho", u["rho"], "--c0", u["c0"]]
    r = json.loads(sphpost(venv, "errors", "--case", "circle2d", d, *opts, "--json",
                           cwd=tmp_path).stdout)
    mean, _ = expected_means(frames, SHIFT, BIAS, R=u["length"], A0=u["rate"])
    for k in ("pos", "vel", "ke", "p_raw"):
        assert math.isclose(r["mean"][k], mean[k], rel_tol=1e-9, abs_tol=1e-11), k
    # the report's header: c0 in the file's units and the case's scale, and
    # the unit options
    out = sphpost(venv, "errors", "--case", "circle2d", d, *opts, cwd=tmp_path).stdout
    assert "c0 1400 (c0 = 14 A0 R)" in out, out
    assert "units: --length 1 --rate 100 --rho 1000 --c0 1400 (c0 = 14 A0 R)" in out, out
    # convergence and plots read the same directory without --pattern
    sphpost(venv, "convergence", d, d, "--case", "circle2d", *opts, "-o", tmp_path / "c.png",
            cwd=tmp_path)
    sphpost(venv, "plots", "circle", d, "--case", "circle2d", *opts, "-o", tmp_path / "f1.png",
            cwd=tmp_path)
    assert (tmp_path / "f1.png").stat().st_size > 10000
    # two series of particle files: the message names them with their real
    # extensions and a --pattern taken from them
    write_pysph(tmp_path / "two", frames[:5], "hdf5")
    write_pysph(tmp_path / "two", frames[:4], "npz")
    pysph_side_files(tmp_path / "two")
    p = sphpost(venv, "errors", "--case", "circle2d", tmp_path / "two", *opts, cwd=tmp_path,
                check=False)
    assert p.returncode == 2, p.stderr
    assert ("several series of particle files (drop_*.hdf5 (5 files), drop_*.npz (4 files)): "
            "choose one with --pattern, e.g. --pattern 'drop_*.hdf5'") in p.stderr, p.stderr
    ok = sphpost(venv, "errors", "--case", "circle2d", tmp_path / "two", *opts, "--pattern",
                 "drop_*.npz", "--json", cwd=tmp_path)
    assert json.loads(ok.stdout)["n"] == 316


def test_figure_labels_are_in_the_case_scale(tmp_path):
    # Figure 1 of a run in PySPH's units (c0 = 1400 m/s, A0 = 100 /s, R = 1 m)
    # says c0 = 14 A0 R, and its axes are in R
    import argparse
    import matplotlib.text
    sys.path.insert(0, str(ROOT / "postproc"))
    from sphpost import filtering, foreign, plots
    u = dict(PYSPH_UNITS, length=0.5)
    frames = exact_frames(TIMES, n_side=20, R=u["length"], A0=u["rate"], rho=u["rho"])
    d = write_pysph(tmp_path / "drop", frames, "hdf5")
    pysph_side_files(d)
    ap = argparse.ArgumentParser()
    ap.add_argument("run_dir")
    foreign.add_options(ap)
    filtering.add_filter_options(ap)
    args = ap.parse_args([str(d), "--case", "circle2d", "--length", "0.5", "--rate", "100",
                          "--rho", "1000", "--c0", "700"])
    fig = plots.fig_circle(args)
    text = "\n".join(t.get_text() for t in fig.findobj(matplotlib.text.Text))
    assert "c0 = 14 A0 R" in text and "c0 = 700" not in text, text
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x / R"
    assert np.allclose(ax.get_xlim(), (-1.15, 1.15))        # 1.15 R, R = 0.5 m


# A real PySPH 1.0b2 run: its elliptical drop (R = 1, A0 = 100, rho = 1,
# c0 = 1400 = 14 A0 R) at --nx 8 (204 particles), serial, with gid set to
# the particle's index, an output every 0.02/A0; four of its outputs
# (t A0 = 0, 0.26, 0.5, 0.76, the empty datasets of the properties it does
# not save left out) with its profile_info.csv and results.npz.
PYSPH_RUN = ROOT / "tests" / "integration" / "data" / "pysph_elliptical_drop"
PYSPH_OPTS = ["--length", 1, "--rate", 100, "--c0", 1400]


def pysph_measures_by_hand():
    """The RMS velocity and position errors of each output of PYSPH_RUN,
    computed here from the HDF5 datasets with h5py and the exact flow
    integrated by scipy's odeint (a_k' = alpha_k a_k, alpha_k' = 2P/a_k^2 -
    alpha_k^2, P = Sum alpha^2 / (2 Sum 1/a^2)), then their time means by
    the trapezoidal rule: (t, vel, pos, mean vel, mean pos)."""
    import glob
    import h5py
    from scipy.integrate import odeint

    def rhs(s, _):
        a, al = s[:2], s[2:]
        p = np.sum(al**2) / (2 * np.sum(1 / a**2))
        return np.concatenate([al * a, 2 * p / a**2 - al**2])

    out, x0 = [], None
    for path in sorted(glob.glob(str(PYSPH_RUN / "elliptical_drop_*.hdf5"))):
        with h5py.File(path, "r") as f:
            g = f["particles/fluid/arrays"]
            t = float(f["solver_data"].attrs["t"])
            ids = g["gid"][()]
            x = np.stack([g["x"][()], g["y"][()]], 1)[np.argsort(ids)]
            u = np.stack([g["u"][()], g["v"][()]], 1)[np.argsort(ids)]
        if x0 is None:
            x0 = x
        s = odeint(rhs, [1.0, 1.0, -100.0, 100.0], [0.0, t] if t > 0 else [0.0, 1e-12],
                   rtol=1e-12, atol=1e-12)[-1]
        a, al = s[:2], s[2:]
        vel = np.sqrt(np.mean(np.sum((u - al * x)**2, 1))) / 100.0
        pos = np.sqrt(np.mean(np.sum((x - a * x0)**2, 1)))
        out.append((t * 100, vel, pos))
    t, vel, pos = map(np.array, zip(*out))
    mean = lambda e: float(np.sum(np.diff(t) * (e[1:] + e[:-1]) / 2) / (t[-1] - t[0]))  # noqa: E731
    return t, vel, pos, mean(vel), mean(pos)


def test_a_real_pysph_run_by_the_readme_command(venv, tmp_path):
    t, vel, pos, mvel, mpos = pysph_measures_by_hand()
    assert np.allclose(t, [0, 0.26, 0.5, 0.76])
    # the README's command, with the run's units (PySPH's SI-like ones)
    r = json.loads(sphpost(venv, "errors", "--case", "circle2d", PYSPH_RUN, *PYSPH_OPTS,
                           "--json", cwd=tmp_path).stdout)
    assert r["n"] == 204
    assert math.isclose(r["mean"]["vel"], mvel, rel_tol=1e-7), (r["mean"]["vel"], mvel)
    assert math.isclose(r["mean"]["pos"], mpos, rel_tol=1e-7), (r["mean"]["pos"], mpos)
    assert math.isclose(r["final"]["vel"], vel[-1], rel_tol=1e-7)
    # measured: velocity 4.62 %, position 1.48 % of A0 R and R at 204
    # particles (the 1,015 particles: 2.9 % velocity)
    assert 0.040 < mvel < 0.052 and 0.012 < mpos < 0.018, (mvel, mpos)
    # without the units the run is refused with the option to give
    p = sphpost(venv, "errors", "--case", "circle2d", PYSPH_RUN, cwd=tmp_path, check=False)
    assert p.returncode == 2 and "--rate" in p.stderr, p.stderr
