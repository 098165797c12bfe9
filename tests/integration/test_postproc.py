"""Post-processing (postproc/): the FFTW low-pass filter on synthetic signals,
and the scripts errors, filter, convergence, plots and validate on tiny runs
made here, their numbers checked against the solver's own time series; the
package sphpost behind them (python3 -m sphpost, the functions validate
calls, the library's names)."""
import json
import math
import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from common import ROOT, SPH, run_sph, read_timeseries

POSTPROC = ROOT / "postproc"
sys.path.insert(0, str(POSTPROC))
import sphpost as sp  # noqa: E402
from sphpost import exact  # noqa: E402
from sphpost.cases import J0_ZERO  # noqa: E402
from sphpost.filtering import raised_cosine  # noqa: E402
from sphpost.measures import slow_centre_pressure  # noqa: E402

PY = "/usr/bin/python3"
SCRIPTS = ["errors", "filter", "convergence", "plots", "validate", "reference"]


def script(name, *args, check=True):
    """Runs postproc/<name> as a user would (its shebang is /usr/bin/python3)."""
    p = subprocess.run([str(POSTPROC / name)] + [str(a) for a in args],
                       capture_output=True, text=True, timeout=300)
    if check:
        assert p.returncode == 0, \
            f"postproc/{name} {args}: exit {p.returncode}\n{p.stdout}{p.stderr}"
    return p


def module(*args, check=True):
    """Runs `python3 -m sphpost ARGS...` as doc/reference/postproc.md shows it: from the
    repository root with PYTHONPATH=postproc."""
    p = subprocess.run([PY, "-m", "sphpost"] + [str(a) for a in args], cwd=ROOT,
                       env=dict(os.environ, PYTHONPATH="postproc"),
                       capture_output=True, text=True, timeout=300)
    if check:
        assert p.returncode == 0, \
            f"python3 -m sphpost {args}: exit {p.returncode}\n{p.stdout}{p.stderr}"
    return p


def make_tiny_run(scratch, n=1250, t_end=0.5, case="circle2d"):
    """A run for the tests below: circle2d with n particles to t_end,
    snapshots every 0.25 (a few seconds at most), with the paper's standard
    operators, whose acoustic noise the filter tests need.  Returns (run
    directory, output)."""
    d = scratch(f"postproc_{case}_{n}") / "run"
    p = run_sph([f"input/{case}.nml", f"particles.n={n}", f"run.t_end={t_end}",
                 "output.dt=0.25", f"output.dir={d}", "numerics.divergence=standard",
                 "numerics.pressure_gradient=standard"])
    assert p.returncode == 0, p.out
    return d, p.out


# Each run once, shared by the tests that ask for it.
@pytest.fixture(scope="module")
def tiny_run(scratch):
    return make_tiny_run(scratch)


@pytest.fixture(scope="module")
def tiny_run_5000(scratch):
    return make_tiny_run(scratch, 5000)


@pytest.fixture(scope="module")
def tiny_run_ellipsoid3d(scratch):
    return make_tiny_run(scratch, 1000, 0.25, "ellipsoid3d")


# ---------------------------------------------------------------------------
# The filter
# ---------------------------------------------------------------------------

def test_exact_solution_matches_reference_values():
    # doc/theory/ X1 (2D, alpha = (-A0, A0)) and X2 (3D, rates (-1, -1, 2)):
    # the tables give 6 digits (X2: 5).
    a, _, p = exact.exact_ellipse([0.5, 1.0, 2.0])
    assert np.allclose(a[:, 0], [0.627053, 0.439461, 0.271814], atol=1e-6), a[:, 0]
    assert np.allclose(p, [0.231943, 0.069327, 0.010799], atol=1e-6), p
    a, _, p = exact.exact_ellipse([1.0], rates=(-1, -1, 2))
    assert np.allclose(a[0], [0.54708, 0.54708, 3.34112], atol=1e-5), a
    assert abs(p[0] - 0.05874) < 1e-5, p


def test_compressibility_floor_closed_form_at_t0():
    """I2 at t = 0 against P''(0) derived by hand from X1 (doc/theory/solutions.md):
    2D rates (-1, 1): P'' = -8 P(0) A0^2, coefficient 3/16 -> 1.5 % at c0 = 10;
    3D rates (-1, -1, 2): P'' = -10 P(0) A0^2, coefficient 7/60 -> 1.1667 %.
    sphpost computes P'' in closed form from the semi-axes and rates."""
    for name, dim, rates, expected in (("circle2d", 2, (-1.0, 1.0), 8 * 3 / 16 / 100),
                                       ("ellipsoid3d", 3, (-1.0, -1.0, 2.0), 10 * 7 / 60 / 100)):
        c = sp.case_info({"run": {"case": name}, "physics": {"c0": 10.0}})
        t = np.linspace(0.0, 0.2, 201)
        _, _, p = exact.exact_ellipse(t, rates=rates)
        slow = slow_centre_pressure(c, t)
        assert abs(slow[0] - expected) < 1e-12, (name, slow[0], expected)
        # the closed-form P'' against second differences of P(t) inside the
        # interval (step 1e-3: they differ by 2e-5 relative, 3e-7 absolute)
        p2 = np.gradient(np.gradient(p, t), t)
        coef = (dim + 4) / (4 * dim * (dim + 2) * 10.0**2) / p[0]
        assert np.allclose(slow[5:-5], -coef * p2[5:-5], rtol=1e-4, atol=1e-6)
        # 1/c0^2: twice c0, a quarter of the floor
        c2 = sp.case_info({"run": {"case": name}, "physics": {"c0": 20.0}})
        assert abs(slow_centre_pressure(c2, t)[0] - expected / 4) < 1e-12


def test_case_info_applies_the_resolution_scaling():
    # the run's c0 is physics.c0 (n/n_ref)^(c0_exponent/dim) (doc/studies/convergence.md
    # S1): the filter's cut-off and the I2 floor must use it, not input.nml's c0
    nml = {"run": {"case": "circle2d"}, "physics": {"c0": 12.5, "c0_exponent": 0.5},
           "particles": {"n": 20108, "n_ref": 1257}}
    assert abs(sp.case_info(nml).c0 - 12.5 * (20108 / 1257) ** 0.25) < 1e-12
    nml["particles"]["n_ref"] = 0
    assert sp.case_info(nml).c0 == 12.5
    nml = {"run": {"case": "ellipsoid3d"}, "physics": {"c0": 10, "c0_exponent": 1.0},
           "particles": {"n": 8000, "n_ref": 1000}}
    assert abs(sp.case_info(nml).c0 - 20.0) < 1e-12


def test_filter_transfer_function_on_the_dct_grid():
    # A cosine of the DCT grid, cos(pi k t/T) (frequency k/(2T)), is one
    # coefficient of the transform: the filter multiplies it by H(k/(2T))
    # exactly.  This pins the normalisation (1/(2(M-1))) and the frequency of
    # each coefficient: a cosine in the pass band comes back to round-off,
    # one in the stop band goes to round-off, one at the cut-off is halved.
    T, m = 2.0, 801
    t = np.linspace(0, T, m)
    fc, w = 2.0, 0.3
    for k, gain in ((0, 1.0), (3, 1.0), (5, 1.0), (8, 0.5), (11, 0.0), (40, 0.0)):
        f = k / (2 * T)
        assert math.isclose(raised_cosine(f, fc, w), gain, abs_tol=1e-15), (k, f)
        y = np.cos(math.pi * k * t / T)
        _, yu, yf = sp.lowpass(t, y, fc, w)
        assert np.max(np.abs(yu - y)) < 1e-14
        assert np.max(np.abs(yf - gain * y)) < 1e-12, (k, np.max(np.abs(yf - gain * y)))


def test_filter_recovers_smooth_curve_from_acoustic_noise():
    # Synthetic probe signal like circle2d's at c0 = 10 A0 R (doc/theory/,
    # Measurements the defaults rest on): the exact centre pressure P(t)
    # (P0 = 0.5) + an acoustic sine at the disc's lowest acoustic frequency
    # f_a = 2.405 c0/(2 pi R) = 3.83 A0 (X6),
    # amplitude A = 3 % of P0, + white noise sigma = 0.4 % of P0, sampled at
    # non-uniform steps (0.004 (1 +- 0.5) / A0, like a run's varying dt).
    # Default filter: f_cut = f_a/2, raised-cosine transition +-0.3.
    #
    # Error budget of the filtered signal y_f at a distance d >= 1.5/f_cut
    # from both ends, against P_f = P filtered by the same H (the filter's
    # distortion of the smooth curve, a property of P and H computed below
    # with scipy's DCT on a 5x finer grid, independent of pyFFTW):
    #  - noise: linear resampling at spacing <= dmax keeps white noise's
    #    one-sided low-frequency PSD at <= 2 sigma^2 dmax; the filter passes
    #    the bandwidth B = Int H^2 df = f_cut (1 - w/4): residual std
    #    s_r <= sigma sqrt(2 B dmax); 5 s_r bounds it (Gaussian, fixed seed);
    #  - acoustic sine: f_a lies in the stop band (>= 1.3 f_cut = 0.65 f_a), so
    #    only the even extension's mirror images at the ends leak; they differ
    #    from the continued sine by at most 2A, weighted by the impulse
    #    response g's tail: <= 2 A Int_d^inf |g(tau)| dtau, with
    #    g(tau) = 2 f_c sinc(2 f_c tau) cos(2 pi w f_c tau) / (1 - (4 w f_c tau)^2);
    #  - linear interpolation: <= dmax^2/8 max|y''| before filtering, times
    #    Int |g| after.
    # Over the whole record (ends included) the same with d = 0, plus the
    # largest distortion of P itself.
    import scipy.fft
    rng = np.random.default_rng(20240601)
    T, c0 = 2.0, 10.0
    fa = J0_ZERO * c0 / (2 * math.pi)
    fc, w = 0.5 * fa, 0.3
    t = [0.0]
    while t[-1] < T:
        t.append(t[-1] + 0.004 * (1 + 0.4 * math.sin(3 * t[-1]) + 0.1 * rng.uniform(-1, 1)))
    t = np.array(t)
    t[-1] = T
    dmax = float(np.max(np.diff(t)))
    _, _, p = exact.exact_ellipse(t)
    p0, amp, sigma = 0.5, 0.015, 0.002
    y = p + amp * np.sin(2 * math.pi * fa * t + 0.7) + sigma * rng.standard_normal(len(t))
    tu, yu, yf = sp.lowpass(t, y, fc, w)
    _, _, pu = exact.exact_ellipse(tu)

    # the smooth curve's distortion by H, independently
    tf = np.linspace(0, T, 5 * len(tu))
    _, _, pfine = exact.exact_ellipse(tf)
    hk = raised_cosine(np.arange(len(tf)) / (2 * T), fc, w)
    dist = scipy.fft.dct(hk * scipy.fft.dct(pfine, type=1), type=1) / (2 * (len(tf) - 1)) - pfine
    p_f = pu + np.interp(tu, tf, dist)

    tau = np.linspace(0, 200 / fc, 400001)
    x = 4 * w * fc * tau
    with np.errstate(all="ignore"):
        g = 2 * fc * np.sinc(2 * fc * tau) * np.cos(2 * math.pi * w * fc * tau) / (1 - x**2)
    g[np.abs(1 - x**2) < 1e-9] = 2 * fc * np.sinc(2 * fc / (4 * w * fc)) * math.pi / 4
    assert abs(2 * np.trapz(g, tau) - 1) < 1e-6          # unit gain at f = 0

    def tail(d):
        s = tau >= d
        return np.trapz(np.abs(g[s]), tau[s])

    s_r = sigma * math.sqrt(2 * fc * (1 - w / 4) * dmax)
    interp = dmax**2 / 8 * (amp * (2 * math.pi * fa)**2 + 5.0) * 2 * tail(0)  # |P''| <= 5
    d = 1.5 / fc
    inner = (tu >= d) & (tu <= T - d)
    tol_inner = 5 * s_r + 2 * amp * tail(d) + interp
    err_inner = np.max(np.abs(yf - p_f)[inner])
    assert err_inner < tol_inner, (err_inner / p0, tol_inner / p0)
    tol_all = 5 * s_r + 2 * amp * tail(0) + interp + np.max(np.abs(dist))
    err_all = np.max(np.abs(yf - pu))
    assert err_all < tol_all, (err_all / p0, tol_all / p0)
    # and the filter did its job: the raw signal is 10 times further off
    assert np.max(np.abs(yu - pu)[inner]) > 10 * np.max(np.abs(yf - pu)[inner])


# ---------------------------------------------------------------------------
# The scripts on a tiny run, against the solver's own numbers
# ---------------------------------------------------------------------------

def test_filtered_error_exact_at_the_ends_in_3d():
    # The stretching cases filter the error p - P(t) (sphpost.stretching_errors):
    # on a synthetic ellipsoid3d probe, the exact P(t) of rates (-1, -1, 2)
    # plus the sphere's lowest acoustic mode (f_a = c0/(2R) = 5 A0 at
    # c0 = 10) of 6 % of P(0) (the size I1 removes), the filtered error must
    # stay small up to t = 0 and t = 1.  Filtering p itself would round the
    # falling P(t) off at the ends: the filter applied to P alone is off by
    # 0.95 % of P(0) on average and 9.3 % at t = 0 on this grid, and the
    # filtered p by 4.1 % on average and 7.2 % at t = 0 (measured).
    # Bounds: the stop-band leak of the sine's mirror images at the ends, as
    # in the test above, <= 2 A Int_0^inf |g| = about 1.1 A = 0.066 at the
    # very ends (measured 0.021); the mean over the record measured 0.0058,
    # bound 0.0075; the old way is asserted to be worse by far.
    t = np.linspace(0.0, 1.0, 401)
    _, _, pex = exact.exact_ellipse(t, rates=(-1, -1, 2))
    amp, fa = 0.06, 5.0
    praw = pex + amp * np.sin(2 * math.pi * fa * t)
    fc = 0.5 * fa
    tu, _, ef = sp.lowpass(t, praw - pex, fc, 0.3)
    _, pu, pf = sp.lowpass(t, praw, fc, 0.3)
    mean_err = float(np.trapz(np.abs(ef), tu))
    mean_old = float(np.trapz(np.abs(pf - pu), tu))
    assert mean_err < 0.0075, mean_err
    assert np.max(np.abs(ef)) < 0.066, np.max(np.abs(ef))
    assert mean_old > 0.03 and abs(pf[0] - pu[0]) > 0.05, (mean_old, pf[0] - pu[0])


def test_errors_agree_with_the_solver(tiny_run):
    d, out = tiny_run
    ts = read_timeseries(d / "timeseries.csv")
    csv_path = d.parent / "errors.csv"
    p = script("errors", d, "--check-snapshots", "--csv", csv_path)
    # the table's rows are the time-series values at the snapshot times
    # (0, 0.25, 0.5), in %; written with 10 significant digits
    tab = np.genfromtxt(csv_path, delimiter=",", names=True)
    assert np.allclose(tab["time"], [0.0, 0.25, 0.5], atol=1e-12), tab["time"]
    t = np.array(ts["time"])
    for i, tt in enumerate(tab["time"]):
        row = int(np.argmin(np.abs(t - tt)))
        for mine, col in (("axis_1", "semi_axis_1_error"), ("axis_2", "semi_axis_2_error"),
                          ("pos", "rms_position_error"), ("vel", "rms_velocity_error")):
            assert math.isclose(tab[mine][i], 100 * ts[col][row], rel_tol=1e-8, abs_tol=1e-12), \
                (mine, tab[mine][i], 100 * ts[col][row])
        ke = 100 * (ts["kinetic_energy"][row] / ts["kinetic_energy_exact"][row] - 1)
        assert math.isclose(tab["KE"][i], ke, rel_tol=1e-8, abs_tol=1e-12)
        praw = 100 * (ts["p_probe_1"][row] - ts["p_centre_exact"][row]) / ts["p_centre_exact"][0]
        assert math.isclose(tab["p_raw"][i], praw, rel_tol=1e-8, abs_tol=1e-12)
    # the sample means are the solver's closing summary (printed with 3
    # decimals, in %)
    m = re.search(r"\n\s+samples\s+(.*)", p.stdout)
    vals = [float(v) for v in m.group(1).split()]
    summ = sp.solver_summary(out)
    # columns: axis 1, axis 2, max|axis|, pos, vel, KE, p raw, p filt
    assert abs(vals[2] - summ["mean_axis"]) < 6e-4, (vals[2], summ)
    assert abs(vals[3] - summ["mean_pos"]) < 6e-4, (vals[3], summ)
    assert abs(vals[4] - summ["mean_vel"]) < 6e-4, (vals[4], summ)
    assert abs(vals[6] - summ["mean_p_raw"]) < 6e-4, (vals[6], summ)
    # the snapshot datasets give the same errors as the time series
    m = re.search(r"pos (\S+), vel (\S+), KE (\S+)", p.stdout)
    assert max(float(v) for v in m.groups()) < 1e-12, m.group(0)
    # the time means (--json) are the trapezoidal means of the columns
    js = json.loads(script("errors", d, "--json").stdout)
    for key, col in (("pos", "rms_position_error"), ("vel", "rms_velocity_error")):
        ref = np.trapz(np.abs(ts[col]), t) / (t[-1] - t[0])
        assert math.isclose(js["mean"][key], ref, rel_tol=1e-12), (key, js["mean"][key], ref)
    assert js["n"] == len(h5_ids(d)) and js["case"] == "circle2d"


def test_errors_windows_split_the_time_means(tiny_run):
    # --windows: each window's mean is the trapezoidal rule on the piecewise-
    # linear interpolant of |error| over it (checked by brute force on a fine
    # grid of that interpolant), and the windows weighted by their lengths add
    # up to the whole run's mean (the same rule), for every error
    d, _ = tiny_run
    ts = read_timeseries(d / "timeseries.csv")
    t = np.array(ts["time"])
    js = json.loads(script("errors", d, "--json", "--windows", "0.13,0.3").stdout)
    win = js["windows"]
    assert [(w["from"], w["to"]) for w in win] == [(0.0, 0.13), (0.13, 0.3), (0.3, 0.5)], win
    for key in js["mean"]:
        if key in ("p_filt_bias", "slow"):
            continue
        whole = sum(w["mean"][key] * (w["to"] - w["from"]) for w in win) / 0.5
        assert math.isclose(whole, js["mean"][key], rel_tol=1e-12), (key, whole, js["mean"][key])
    fine = np.linspace(0.13, 0.3, 200001)
    ref = np.trapz(np.interp(fine, t, np.abs(ts["rms_velocity_error"])), fine) / 0.17
    # the fine grid's trapezoids are exact but in the cells holding a sample
    # (a kink of the interpolant): measured 1.8e-12 relative
    assert math.isclose(win[1]["mean"]["vel"], ref, rel_tol=1e-9), (win[1]["mean"]["vel"], ref)
    text = script("errors", d, "--windows", "0.25").stdout
    assert re.search(r"\[0, 0\.25\]\s+\d", text) and re.search(r"\[0\.25, 0\.5\]\s+\d", text), text
    bad = script("errors", d, "--windows", "0.3,0.2", check=False)
    assert bad.returncode == 2 and "--windows 0.3,0.2: the times must increase" in bad.stderr, \
        bad.stderr


def h5_ids(d):
    import h5py
    with h5py.File(d / "snap_00000.h5", "r") as f:
        return f["id"][:]


def test_filter_script_writes_filtered_probe(tiny_run):
    d, _ = tiny_run
    out = d.parent / "filtered.csv"
    p = script("filter", d, "-o", out)
    assert "spectral peak" in p.stdout and str(out) in p.stdout, p.stdout
    f = np.genfromtxt(out, delimiter=",", names=True)
    assert f.dtype.names == ("time", "p_probe_1", "p_probe_1_filtered", "p_centre_exact")
    ts = read_timeseries(d / "timeseries.csv")
    # uniform grid over the run, raw column = the probe interpolated onto it
    dt = np.diff(f["time"])
    assert np.max(np.abs(dt - dt[0])) < 1e-12 and f["time"][0] == 0.0
    assert abs(f["time"][-1] - 0.5) < 1e-12
    assert np.allclose(f["p_probe_1"], np.interp(f["time"], ts["time"], ts["p_probe_1"]),
                       rtol=0, atol=1e-14)
    # the filtered signal is smoother (second differences) than the raw one
    assert np.std(np.diff(f["p_probe_1_filtered"], 2)) < 0.2 * np.std(np.diff(f["p_probe_1"], 2))


def test_convergence_script_orders(tiny_run, tiny_run_5000):
    d1, _ = tiny_run
    d2, _ = tiny_run_5000
    png = d2.parent / "conv.png"
    js = d2.parent / "conv.json"
    p = script("convergence", d2, d1, "-o", png, "--json", js)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    res = json.load(open(js))
    rows = res["rows"]
    assert [r["n"] for r in rows][0] < rows[1]["n"]          # sorted by N
    for r, d in zip(rows, (d1, d2)):
        e = json.loads(script("errors", d, "--json").stdout)
        assert math.isclose(r["errors"]["vel"], e["mean"]["vel"], rel_tol=1e-12)
        assert math.isclose(r["dx"], math.sqrt(math.pi / e["n"]), rel_tol=1e-12)
    for k, o in res["orders"].items():
        e1, e2 = rows[0]["errors"][k], rows[1]["errors"][k]
        ref = math.log(e1 / e2) / math.log(rows[0]["dx"] / rows[1]["dx"])
        assert math.isclose(o["pairs"][0], ref, rel_tol=1e-12)
        assert math.isclose(o["lsq"], ref, rel_tol=1e-9)
    # printed: the velocity order between the two runs, 2 decimals
    line = [ln for ln in p.stdout.splitlines() if "->" in ln][0]
    assert f"{res['orders']['vel']['pairs'][0]:.2f}" in line


def test_convergence_until_compares_over_a_common_window(scratch, tiny_run, tiny_run_5000):
    # --until T cuts every run at T: the same errors as runs whose time series
    # stop there.  The reference: copies of the two runs with timeseries.csv
    # cut by hand at a row time (no interpolation), through postproc/errors.
    d1, _ = tiny_run
    d2, _ = tiny_run_5000
    tmp = scratch("postproc_until")
    script("convergence", d1, d2, "-o", tmp / "a.png", "--json", tmp / "a.json")
    full = json.loads((tmp / "a.json").read_text())
    same = script("convergence", d1, d2, "-o", tmp / "b.png", "--until", 0.5,
                  "--json", tmp / "b.json")
    assert "warning" not in same.stderr, same.stderr
    assert json.loads((tmp / "b.json").read_text())["rows"] == full["rows"]   # T = the end

    cut_rows = []
    for d in (d1, d2):
        lines = (d / "timeseries.csv").read_text().splitlines()
        t = read_timeseries(d / "timeseries.csv")["time"]
        k = int(np.searchsorted(t, 0.3))          # first row at t >= 0.3
        c = tmp / d.parent.name
        c.mkdir()
        (c / "timeseries.csv").write_text("\n".join(lines[:k + 2]) + "\n")
        (c / "input.nml").write_text((d / "input.nml").read_text())
        (c / "snap_00000.h5").symlink_to(d / "snap_00000.h5")
        cut_rows.append((c, t[k]))
    # both cut at the larger of the two row times, the other run interpolated
    t_cut = max(tc for _, tc in cut_rows)
    c_exact = [c for c, tc in cut_rows if tc == t_cut][0]
    d_exact = d1 if c_exact.name == d1.parent.name else d2
    script("convergence", d1, d2, "-o", tmp / "c.png", "--until", repr(t_cut),
           "--json", tmp / "c.json")
    row = [r for r in json.loads((tmp / "c.json").read_text())["rows"]
           if r["run"] == str(d_exact)][0]
    ref = json.loads(script("errors", c_exact, "--json").stdout)
    assert math.isclose(row["t_end"], t_cut, rel_tol=1e-12)
    for name, key in (("vel", "vel"), ("pos", "pos"), ("ke_mean", "ke"), ("p_filt", "p_filt")):
        assert math.isclose(row["errors"][name], ref["mean"][key], rel_tol=1e-12), name
    assert row["errors"]["vel"] < 0.95 * full["rows"][0 if d_exact == d1 else 1]["errors"]["vel"]

    # between two rows the last row is interpolated linearly to t = T exactly
    run = sp.Run(d1)
    t, v = run.time, run.ts["rms_velocity_error"]
    k = int(np.searchsorted(t, 0.3))
    mid = 0.5 * (t[k - 1] + t[k])
    w = sp.Run(d1).window(mid)
    assert len(w.time) == k + 1 and w.time[-1] == mid
    assert math.isclose(w.ts["rms_velocity_error"][-1], 0.5 * (v[k - 1] + v[k]), rel_tol=1e-12)

    # a run that ends before T, and T <= 0, are refused
    for until, msg in ((0.7, "ends at t A0 = 0.5, before --until 0.7"),
                       (0, "--until 0: give a time above 0")):
        p = script("convergence", d1, d2, "--until", until, check=False)
        assert p.returncode == 2 and msg in p.stderr and p.stdout == "", p.stderr


def test_plots_circle_and_pressure(tiny_run):
    d, _ = tiny_run
    for what, args in (("circle", [d]), ("pressure", [d, d])):
        png = d.parent / f"{what}.png"
        script("plots", what, *args, "-o", png, "--dpi", "50")
        assert png.stat().st_size > 5000 and png.read_bytes()[:4] == b"\x89PNG", what


def test_ellipsoid3d_errors_and_figure(tiny_run_ellipsoid3d):
    d, out = tiny_run_ellipsoid3d
    ts = read_timeseries(d / "timeseries.csv")
    js = json.loads(script("errors", d, "--json").stdout)
    assert js["case"] == "ellipsoid3d"
    assert math.isclose(js["final"]["axis_3"], ts["semi_axis_3_error"][-1], rel_tol=1e-12)
    summ = sp.solver_summary(out)
    assert abs(100 * js["sample_mean"]["vel"] - summ["mean_vel"]) < 6e-4
    png = d.parent / "fig2.png"
    script("plots", "ellipsoid", d, "-o", png, "--dpi", "40")
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_velocity_split(tiny_run_ellipsoid3d):
    # At t = 0 the velocity error of the prepared start is the compressible
    # flow I1, u_c = -kappa x (1/3 - r^2/5): a cubic polynomial of the
    # positions, so the smooth part is all of it (the rest is round-off).
    # At every time the least-squares residual is orthogonal to the fit:
    # total^2 = smooth^2 + rest^2.
    d, _ = tiny_run_ellipsoid3d
    text = script("errors", d, "--velocity-split").stdout
    rows = [[float(v) for v in line.split()] for line in
            text[text.index("velocity error split"):].splitlines()[2:] if line.strip()]
    assert len(rows) >= 2
    t0, total0, smooth0, rest0 = rows[0]
    assert t0 == 0.0 and total0 > 0.1, rows[0]
    assert rest0 < 1e-6 * total0, rows[0]
    assert abs(smooth0 - total0) < 1e-6 * total0, rows[0]
    # (the table prints 4 decimals: each square is off by at most 1e-4 x value)
    for t, total, smooth, rest in rows:
        assert abs(total**2 - smooth**2 - rest**2) < 2e-4 * (total + smooth + rest), \
            (t, total, smooth, rest)


def test_validate_quick_writes_report(scratch):
    # the whole chain on the two smallest circle2d runs (a few seconds)
    tmp = scratch("validate")
    script("validate", "--quick", "--cases", "circle2d", "--runs", tmp / "runs",
           "--doc", tmp / "doc", "--sph", SPH)
    md = (tmp / "doc" / "patches.md").read_text()
    # the smallest packed disc: 1,256 particles for particles.n = 1250
    assert "| 1,256 |" in md and "least squares" in md and "Beside the paper's claims" in md
    for png in ("convergence", "fig1", "pressure_error", "spectrum"):
        assert (tmp / "doc" / f"validation_circle2d_{png}.png").exists(), png


def test_validate_in_pieces_continues_from_checkpoints(scratch):
    """--wall-limit stops the study's runs with checkpoints and writes no
    report (exit 75); the same command with --reuse continues them and
    reports; a continued run ends with the bits of an uninterrupted one."""
    tmp = scratch("validate_pieces")
    common = ["--quick", "--cases", "circle2d", "--runs", tmp / "runs", "--doc", tmp / "doc",
              "--sph", SPH, "--np", "2"]
    # 2 s: the quick study takes about 20 s on two cores, its longest run
    # (the recipe at 1,257 particles, started first) about 10 s
    p = script("validate", *common, "--wall-limit", "2", check=False)
    assert p.returncode == 75, p.stdout + p.stderr
    assert "report not written" in p.stdout and not (tmp / "doc" / "patches.md").exists()
    stopped = [log for log in (tmp / "runs").glob("*.log")
               if "sph: stopped by run.wall_limit" in log.read_text()]
    assert stopped, p.stdout
    p = script("validate", *common, "--reuse")
    assert (tmp / "doc" / "patches.md").exists()
    cont = re.findall(r"^  continue circle2d N = \d+: (.*)$", p.stdout, re.M)
    assert len(cont) == len(stopped), p.stdout
    # the first continued run again, uninterrupted, into a directory of its own
    args = cont[0].split()[1:]             # (the first: the solver)
    run_dir = next(a for a in args if a.startswith("output.dir="))[len("output.dir="):]
    args = [a for a in args if not a.startswith(("output.dir=", "run.restart=",
                                                 "run.wall_limit="))]
    whole = tmp / "whole"
    q = run_sph(args + [f"output.dir={whole}"], np=2)
    assert q.returncode == 0, q.out
    # every step once, at the same times; the particles at the end the same
    # bits (the time series' global sums run in storage order, which a
    # restart may change: compared to round-off)
    a = read_timeseries(os.path.join(run_dir, "timeseries.csv"))
    b = read_timeseries(whole / "timeseries.csv")
    assert len(a["time"]) == len(b["time"]) > 5
    for k in ("time", "step", "dt"):
        assert a[k] == b[k], k
    assert np.allclose(a["kinetic_energy"], b["kinetic_energy"], rtol=1e-12, atol=0)
    import h5py
    ends = []
    for d in (pathlib.Path(run_dir), whole):
        with h5py.File(sorted(d.glob("snap_*.h5"))[-1], "r") as h:
            order = np.argsort(h["id"][:])
            ends.append({k: h[k][:][order] for k in ("position", "velocity", "density")})
    for k in ends[0]:
        assert np.array_equal(ends[0][k].view(np.int64), ends[1][k].view(np.int64)), k


def test_validate_ctrl_c_stops_runs_with_checkpoints(scratch):
    """Ctrl-C (SIGINT to validate alone: the runs have sessions of their own)
    asks the running runs to stop with checkpoints, starts no more and
    writes no report (exit 75); --reuse then finishes the study."""
    tmp = scratch("validate_ctrl_c")
    common = [str(POSTPROC / "validate"), "--quick", "--cases", "circle2d", "--runs",
              str(tmp / "runs"), "--doc", str(tmp / "doc"), "--sph", str(SPH), "--np", "2"]
    p = subprocess.Popen(common, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    # the first run started (the recipe at 1,257 particles: 200 steps, 2.4 s
    # of time loop on an idle machine) is interrupted once its first snapshot
    # is on disk: its signal handlers are set and its time loop is ahead (its
    # log, buffered, can show nothing before it ends)
    log = tmp / "runs" / "circle2d_convergence_1257.log"
    snap0 = tmp / "runs" / "circle2d_convergence_1257" / "snap_00000.h5"
    t0 = time.monotonic()
    while not snap0.exists():
        assert time.monotonic() - t0 < 120 and p.poll() is None, "no snapshot written"
        time.sleep(0.02)
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=300)
    assert p.returncode == 75, out
    assert "interrupted" in out and "report not written" in out and "not started" in out, out
    assert "sph: stopped by SIGUSR1" in log.read_text()
    assert (tmp / "runs" / "circle2d_convergence_1257" / "checkpoint.h5").exists()
    assert not (tmp / "doc" / "patches.md").exists()
    q = subprocess.run(common + ["--reuse"], capture_output=True, text=True, timeout=300)
    assert q.returncode == 0, q.stdout + q.stderr
    assert "continue circle2d N = 1257" in q.stdout
    assert (tmp / "doc" / "patches.md").exists()


def test_scripts_help_and_bad_run_directory(scratch, tiny_run):
    empty = scratch("postproc_empty")
    afile = empty / "file.txt"
    afile.write_text("x")
    for name in SCRIPTS:
        p = script(name, "--help")
        assert "usage" in p.stdout, name
    cases = [("errors", [empty / "missing"], "does not exist"),
             ("errors", [empty], "has no timeseries.csv"),
             ("errors", [afile], "is not a directory"),
             ("filter", [empty / "missing"], "does not exist"),
             ("convergence", [empty, empty], "has no timeseries.csv"),
             ("plots", ["circle", empty / "missing"], "does not exist")]
    for name, args, msg in cases:
        p = script(name, *args, check=False)
        assert p.returncode == 2 and msg in p.stderr and p.stdout == "", (name, p.stdout, p.stderr)
        assert "Traceback" not in p.stderr
    # a run of the wrong case for a figure
    d, _ = tiny_run
    p = script("plots", "ellipsoid", d, check=False)
    assert p.returncode == 2 and "circle2d" in p.stderr, p.stderr


def test_errors_of_a_case_without_exact_solution(scratch):
    # a solver case the package has no entry for (here the rotating square
    # renamed in input.nml): unit scales, probe pressure, kinetic energy
    # and free surface, the case's name from the run
    d = scratch("postproc_new_case") / "run"
    p = run_sph(["input/square_rotation.nml", "particles.n=400", "run.max_steps=10",
                 "output.dt=0.01", f"output.dir={d}"])
    assert p.returncode == 0, p.out
    nml = d / "input.nml"
    nml.write_text(nml.read_text().replace("square_rotation", "new_case"))
    p = script("errors", d)
    assert "case 'new_case' has no exact solution" in p.stdout, p.stdout
    assert "probe 1: p(0)" in p.stdout and "kinetic energy:" in p.stdout, p.stdout
    assert "free surface at t = 0:" in p.stdout, p.stdout
    js = json.loads(script("errors", d, "--json").stdout)
    assert js["case"] == "new_case" and js["p0_exact"] is None and js["ke_change"] < 0.01


# ---------------------------------------------------------------------------
# The package: python3 -m sphpost, the functions validate calls, the names
# ---------------------------------------------------------------------------

def test_module_lists_the_tools():
    p = module("--help")
    for name in SCRIPTS:
        assert re.search(rf"^\s+{name}\b", p.stdout, re.M), (name, p.stdout)
    for args, msg in (([], "required: TOOL"), (["bogus"], "invalid choice: 'bogus'")):
        p = module(*args, check=False)
        assert p.returncode == 2 and msg in p.stderr and p.stdout == "", (args, p.stderr)
    # a tool's own --help, under the module's name
    p = module("errors", "--help")
    assert p.stdout.startswith("usage: python3 -m sphpost errors"), p.stdout


def test_module_and_script_give_the_same_output(tiny_run):
    d, _ = tiny_run
    for args, status in (([d], 0), ([d, "--json"], 0),
                         ([d, "--count", "3", "--check-snapshots"], 0), ([d / "missing"], 2),
                         ([d, "--cutoff-flow", "1", "--cutoff-acoustic", "1"], 2)):
        a = script("errors", *args, check=False)
        b = module("errors", *args, check=False)
        assert a.returncode == status, (args, a.stdout, a.stderr)
        assert (b.returncode, b.stdout, b.stderr) == (a.returncode, a.stdout, a.stderr), args


def test_functions_validate_calls_match_the_scripts(tiny_run, tiny_run_5000):
    # validate calls convergence.study, filter.filter_probes and plots.draw
    # in its own process instead of running the scripts: the same report,
    # JSON, CSV and figure, byte for byte
    import sphpost.convergence
    import sphpost.filter
    import sphpost.plots
    d1, _ = tiny_run
    d2, _ = tiny_run_5000
    tmp = d2.parent
    p = script("convergence", d1, d2, "-o", tmp / "conv_s.png", "--json", tmp / "conv_s.json")
    lines = []
    table = sphpost.convergence.study([sp.Run(d1), sp.Run(d2)], sp.filter_options(),
                                      tmp / "conv_f.png", echo=lines.append)
    assert "\n".join(lines) + "\n" == p.stdout.replace("conv_s.png", "conv_f.png")
    # (through JSON text: a NaN order would not compare equal to itself)
    assert json.dumps(table, indent=1) == (tmp / "conv_s.json").read_text()
    assert (tmp / "conv_s.png").read_bytes() == (tmp / "conv_f.png").read_bytes()
    p = script("filter", d1, "-o", tmp / "filt_s.csv")
    lines = []
    stats = sphpost.filter.filter_probes(sp.Run(d1), sp.filter_options(), tmp / "filt_f.csv",
                                         echo=lines.append)
    assert "\n".join(lines) + "\n" == p.stdout.replace("filt_s.csv", "filt_f.csv")
    assert (tmp / "filt_s.csv").read_bytes() == (tmp / "filt_f.csv").read_bytes()
    c = sp.Run(d1).case
    assert f"spectral peak {stats['p_probe_1']['f_peak'] / c.rate:.4g} A0" in p.stdout
    script("plots", "pressure", d1, d2, "--labels", "a", "b", "-o", tmp / "pr_s.png",
           "--dpi", "50")
    sphpost.plots.draw("pressure", [d1, d2], tmp / "pr_f.png", dpi=50, labels=["a", "b"],
                       echo=lambda line: None)
    assert (tmp / "pr_s.png").read_bytes() == (tmp / "pr_f.png").read_bytes()


def test_package_names_come_from_their_modules():
    # the package's public names are each defined in one module of the
    # package, imported explicitly: no module imports with *, and no module
    # is a catch-all (the former core.py is gone)
    import importlib
    import pkgutil
    mods = [m.name for m in pkgutil.walk_packages(sp.__path__, "sphpost.")]
    for n in sp.__all__:
        # the module the name comes from holds the same object
        homes = [m for m in mods if getattr(importlib.import_module(m), n, None) is getattr(sp, n)
                 or m == f"sphpost.{n}"]
        assert homes, n
    assert "sphpost.core" not in mods
    for m in ("readers.sph", "readers.plain", "readers.vtk", "readers.pysph",
              "readers.series", "cases", "exact", "filtering", "measures", "cli"):
        assert f"sphpost.{m}" in mods, m
    for path in pathlib.Path(sp.__file__).parent.rglob("*.py"):
        assert not re.search(r"^\s*from\s+\S+\s+import\s+\*", path.read_text(), re.M), path
    # the names the tools call moved with their definitions
    assert sp.Run is importlib.import_module("sphpost.readers.sph").Run
    assert sp.lowpass is importlib.import_module("sphpost.filtering").lowpass


def test_validate_counts_every_piece_of_a_continued_run():
    """A run stopped at checkpoints and continued logs each piece: validate's
    table counts all their steps and wall time, not the last piece's."""
    from sphpost.validate import Job
    log = "\n".join([
        "step       10  t    0.1  dt  1.0E-02  wall      20.0 s  ETA  80.0 s",
        "step       12  t    0.12  dt  1.0E-02  wall      24.5 s  ETA  80.0 s",
        "sph: stopped by run.wall_limit after step 12 (t =  1.2E-01); checkpoint written to x",
        "step       20  t    0.2  dt  1.0E-02  wall      15.0 s  ETA  60.0 s",
        "sph: stopped by SIGUSR1 after step 21 (t =  2.1E-01); checkpoint written to x",
        "done: 79 steps in     150.00 s,  1.9E+00 s/step,  5.0E+03 particle-steps/s on 2 rank(s)",
        ""])
    j = Job("c", 10, "x.nml", [], "/nonexistent", 1.0)
    assert j.parse(log)
    assert (j.steps, j.ranks) == (21 + 79, 2)
    assert j.wall == pytest.approx(24.5 + 15.0 + 150.0)
    # an uninterrupted run: the done line alone
    j = Job("c", 10, "x.nml", [], "/nonexistent", 1.0)
    assert j.parse(log.split("\n", 5)[5])
    assert (j.steps, j.wall) == (79, 150.0)


def test_validate_compares_the_squares_schemes_with_a_reference(scratch):
    # the rotating square's three schemes at the quick resolutions against a
    # made-up reference of two levels (p_A = its series value plus a slope,
    # circles for interfaces): the report's numbers are reference.compare's,
    # the reference's uncertainty the two levels' known difference
    sys.path.insert(0, str(ROOT / "tests" / "integration"))
    from test_reference import fake_reference
    from sphpost import reference as ref
    tmp = scratch("validate_squares")
    th = np.linspace(0, 2 * np.pi, 201)
    for level, off in ((8, 0.0), (9, 0.002)):
        s = ref.Setup("square_rotation", 1.0, 1.0, 1.0, 4.0, level=level)
        d = tmp / "ref" / "square_rotation" / f"level_{level}"
        d.parent.mkdir(parents=True, exist_ok=True)
        fake_reference(d, s, lambda t, o=off: -0.147343 + 0.03 * t + o * 0.147343,
                       lambda t: (1 / 12) * (1 - 0.01 * t))
        for tk in (1, 2, 3, 4):
            ref.write_csv(str(d / f"interface_{tk}.csv"), ("piece", "x", "y"),
                          zip(np.zeros(201, int), (0.5 + 0.1 * tk) * np.cos(th),
                              (0.5 + 0.1 * tk) * np.sin(th)))
    # (--bem '': Gerris's levels alone, as for the vortical square)
    script("validate", "--quick", "--cases", "square_rotation", "--runs", tmp / "runs",
           "--doc", tmp / "doc", "--sph", SPH, "--reference", tmp / "ref", "--bem", "")
    md = (tmp / "doc" / "patches.md").read_text()
    assert "Against the reference (Gerris, 64 cells per L" in md
    # the levels differ by 0.2 % of |p(0)| everywhere
    assert "its levels 8 and 9 against each other: probe pressure 0.2 %" in md
    assert "mean difference +0.200 %" in md
    # within the 0.3 % bar over the whole record: the claims judged on [0.1, 3.9]
    assert "has converged to the bar" in md and "over [0.1, 3.9]; the reference's own " \
        "uncertainty there 0.2 %" in md
    c = ref.compare(str(tmp / "runs" / "square_rotation_paper_2500"),
                    str(tmp / "ref" / "square_rotation" / "level_9"), echo=lambda m: None,
                    until=4.0)
    row = next(line for line in md.splitlines()
               if line.startswith("| paper's: standard gradient, tensile control | 2,500 |"))
    assert f"| {100 * c['p_trim_bias']:+.3f} |" in row, row
    assert c["p_until"] == (0.1, 3.9) and f"| {100 * c['p_until_bias']:+.3f} |" in row
    assert f"{c['interface']['1'][0]:.4f}" in row and f"{c['tip']['4']:+.4f}" in row
    assert md.count("| the standard SPH's p_A") == 1 and "shows to be much closer" in md
    assert (tmp / "doc" / "validation_square_rotation_reference.png").exists()
    # by default the rotating square is judged against the shipped
    # boundary-integral reference, Gerris's finest level its second
    script("validate", "--quick", "--cases", "square_rotation", "--runs", tmp / "runs",
           "--doc", tmp / "doc2", "--sph", SPH, "--reference", tmp / "ref", "--reuse")
    md = (tmp / "doc2" / "patches.md").read_text()
    assert "Against the reference (boundary integrals, 1536 nodes" in md
    assert "converged over t omega in [0, 2.84]" in md and "The targets" in md
    assert "Gerris's finest level (Gerris, 64 cells per L" in md
