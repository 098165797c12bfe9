"""The rotating square's boundary-integral reference (sphpost.bem, postproc/
reference bem; doc/theory/solutions.md X7): the Cauchy integrals against harmonic
fields known in closed form, the centre pressure against exact values, a
short run's conservation and its agreement with a finer one, and the
shipped reference against a regeneration at low resolution."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest

from common import ROOT

sys.path.insert(0, str(ROOT / "postproc"))
from sphpost import bem, exact  # noqa: E402
from sphpost import reference as ref  # noqa: E402

SHIPPED = ROOT / "postproc" / "sphpost" / "data" / "square_rotation_bem"


def flower(m, r0=0.5, eps=0.2):
    """A quarter of the 4-fold symmetric curve r = r0 (1 + eps cos 4 theta)."""
    th = 0.5 * math.pi * np.arange(m) / m
    return r0 * (1 + eps * np.cos(4 * th)) * np.exp(1j * th)


@pytest.mark.parametrize("m", [32, 64, 128])
def test_the_cauchy_integral_gives_a_harmonic_fields_conjugate_and_derivative(m):
    # w = z^4 (4-fold invariant): from phi = Re w on the curve the solver
    # finds chi = Im w on it, w' = 4 z^3 there and w inside; measured
    # 3e-14 / 2e-11 at m = 64 / 256 (spectral differentiation's round-off
    # grows with the nodes): asserted at 1e-12 and 1e-8
    zq = flower(m)
    g = bem.Geometry(zq)
    mu = g.density(np.real(zq**4))
    chi = g.conjugate(mu)
    assert np.max(np.abs(chi - np.imag(zq**4))) < 1e-12
    dw = (bem.d_alpha(bem.whole_scalar(np.real(zq**4) + 1j * chi)) / g.Za)[:m]
    assert np.max(np.abs(dw - 4 * zq**3)) < 1e-8          # the normal derivative too
    z = 0.12 + 0.05j
    w, dwi = g.interior(mu, z)
    assert abs(w - z**4) < 1e-12 and abs(dwi - 4 * z**3) < 1e-12


def test_the_centre_pressure_of_a_disc_with_a_potential_flow_is_exact():
    # a disc of radius R in rigid rotation plus grad phi, phi = Re(c z^4):
    # G(A) is the mean of its boundary values (mean-value property), so
    # p_A = -(omega^2 R^2/2 - 8 |c|^2 R^6) in closed form (X7); measured
    # 1e-15 relative at 16 nodes per quarter
    R, c = 0.5, 0.3 + 0.1j
    zq = R * np.exp(0.5j * math.pi * np.arange(16) / 16)
    g, mu, chi, U, _ = bem.surface_state(zq, np.real(c * zq**4))
    exact_pa = -(R**2 / 2 - 8 * abs(c) ** 2 * R**6)
    assert abs(bem.pressure_at(g, mu, chi, U, zq) / exact_pa - 1) < 1e-12


def test_the_rounded_squares_initial_pressure_against_the_series():
    # p_A(0) of the superellipse |x|^n + |y|^n = (L/2)^n converges with the
    # nodes (256 and 1024 agree to 1e-12, measured) to a value the corners'
    # rounding moves from the true square's series (X3): -8.72e-5 at n = 24,
    # -3.13e-5 at 32, -7.2e-6 at 48 (relative, measured at 512-2048 nodes)
    series = float(exact.square_rotation_pressure(0.0, 0.0)[0])
    found = {}
    for n_corner, nodes in ((24, 256), (24, 512), (48, 512)):
        p = bem.Params(nodes=nodes, n_corner=n_corner)
        zq, phq = bem.initial_curve(p)
        g, mu, chi, U, _ = bem.surface_state(zq, phq)
        found[(n_corner, nodes)] = bem.pressure_at(g, mu, chi, U, zq)
    assert abs(found[(24, 256)] / found[(24, 512)] - 1) < 1e-10
    assert found[(24, 512)] / series - 1 == pytest.approx(-8.717e-5, abs=1e-8)
    assert abs(found[(48, 512)] / series - 1) < 1e-5      # the rounding's effect falls with n


def test_a_short_run_conserves_area_and_energy_and_agrees_with_a_finer_one():
    # to t omega = 0.2: area and kinetic energy drift 1e-9 / 3e-9 at 256
    # nodes, 2e-10 / 6e-10 at 320; p_A differs by 4e-10 of |p_A(0)| to 0.5
    # (measured)
    recs = {}
    for nodes in (256, 320):
        recs[nodes] = bem.run(bem.Params(nodes=nodes, dt=0.005, t_end=0.2), echo=None)
    for r in recs.values():
        a, k = np.array(r.area), np.array(r.ke)
        assert np.max(np.abs(a / a[0] - 1)) < 1e-8 and np.max(np.abs(k / k[0] - 1)) < 1e-8
        assert r.clean_until == pytest.approx(0.2)
    assert abs(recs[256].p[-1] - recs[320].p[-1]) < 1e-8 * abs(recs[320].p[0])
    # the tips of the rounded corners move out (their ballistic law, for
    # the sharp square: r = sqrt((1 + t^2)/2), is approached from inside)
    r0, r1 = recs[320].tip_r[0], recs[320].tip_r[-1]
    assert r0 == pytest.approx(0.5 * math.sqrt(2) * 2 ** (-1 / 24), rel=1e-9)
    assert r0 < r1 < math.sqrt((1 + 0.2**2) / 2)


def test_the_command_writes_a_reference_the_comparisons_read(tmp_path):
    out = tmp_path / "bem"
    r = subprocess.run([sys.executable, str(ROOT / "postproc" / "reference"), "bem",
                        "--nodes", "256", "--dt", "0.01", "--t-end", "0.5", "--dir", str(out),
                        "--input", str(ROOT / "input" / "square_rotation.nml")],
                       capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    rf = ref.Reference(str(out))
    assert rf.setup.method == "bem" and rf.setup.params.nodes == 256
    assert len(rf.pressure["t"]) == 51 and rf.interface_times() == [0.5]
    assert rf.pressure["p"][0] == pytest.approx(-0.14732986, rel=1e-7)
    first = (out / "pressure.csv").read_text().splitlines()[0]
    assert first.startswith("# boundary-integral method, 256 nodes")
    surf = rf.interface(0.5)[0]
    assert np.allclose(surf[0], surf[-1])                   # a closed curve
    # the shipped reference (make reference-bem: its finest run, cut at its
    # interval of convergence) reads back and agrees with this regeneration
    # at 256 nodes: p_A within 2.4e-10 of |p_A(0)| and the surface at 0.5
    # within 2.3e-5 L of 1024 nodes' (measured): asserted at 1e-8 and 5e-5 L
    shipped = ref.Reference("bem")
    assert shipped.path == str(SHIPPED) and shipped.setup.method == "bem"
    study = json.loads((SHIPPED / "study.json").read_text())
    assert shipped.t_end == pytest.approx(study["converged_until"]) and shipped.t_end >= 1.0
    assert shipped.pressure["t"][-1] == pytest.approx(shipped.t_end)
    assert (SHIPPED / "pressure.csv").read_text().startswith("# boundary-integral method")
    p = np.interp(rf.pressure["t"], shipped.pressure["t"], shipped.pressure["p"])
    assert np.max(np.abs(rf.pressure["p"] - p)) < 1e-8 * abs(shipped.pressure["p"][0])
    assert ref.curve_distance(rf.interface(0.5), shipped.interface(0.5), ds=2e-5)[1] < 5e-5
    # bad settings are refused with the variable and what is allowed
    r = subprocess.run([sys.executable, str(ROOT / "postproc" / "reference"), "bem",
                        "--nodes", "100", "--dir", str(tmp_path / "x")],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2 and "nodes = 100" in r.stderr and "multiple of 8" in r.stderr
    assert not (tmp_path / "x").exists()
