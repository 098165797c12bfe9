"""Refactors change no bit: short runs of every input file and of every
scheme option end with the same bits as the runs recorded in
data/golden.json, written by an earlier build of the solver.

A digest is the SHA-256 of the last snapshot's datasets (sorted by particle
id) and attributes, and of timeseries.csv.  The bits depend on the compiler
and on the instruction set (-march=native: FMA contraction), so the test
compares only on a machine of the recorded kind (compiler, instruction set,
what -march=native resolves to) and says so otherwise.

Record anew (only when a change of the results is intended, and say why in
the commit):  /usr/bin/python3 tests/integration/test_golden.py --write
"""
import hashlib
import json
import pathlib
import subprocess
import sys
import tempfile

import h5py
import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from common import ROOT, run_sph  # noqa: E402

GOLDEN = pathlib.Path(__file__).resolve().parent / "data" / "golden.json"

C2 = ["input/circle2d.nml", "particles.n=1500", "run.max_steps=12"]
# the paper's standard operators (E1, E4): the base of the options' variants
STD = C2 + ["numerics.pressure_gradient=standard", "numerics.divergence=standard"]
# every input file, then each scheme option on the circle (each copy of the
# pair loop, the general one, the first passes, the integrators, kernels)
CONFIGS = {
    "circle2d": C2,
    "circle2d_convergence": ["input/circle2d_convergence.nml", "particles.n=1500",
                             "particles.pack_iterations=20", "run.max_steps=8"],
    "ellipsoid3d": ["input/ellipsoid3d.nml", "particles.n=3000", "particles.pack_iterations=10",
                    "run.max_steps=3"],
    "ellipsoid3d_octant": ["input/ellipsoid3d.nml", "particles.n=3000",
                           "particles.pack_iterations=10", "run.max_steps=3",
                           "particles.symmetry=xyz"],
    "ellipsoid3d_lattice": ["input/ellipsoid3d.nml", "particles.n=3000",
                            "particles.placement=lattice", "run.max_steps=3",
                            "numerics.renormalise=stage"],
    "square_rotation": ["input/square_rotation.nml", "particles.n=900", "run.max_steps=12"],
    "square_vortical": ["input/square_vortical.nml", "particles.n=900", "run.max_steps=12"],
    "pc2_cubic": C2 + ["numerics.integrator=pc2", "numerics.cfl=0.8",
                       "numerics.kernel=cubic_spline"],
    "gaussian_tait": C2 + ["numerics.kernel=gaussian", "physics.eos=tait"],
    "standard": STD,
    "standard_3d_lattice": ["input/ellipsoid3d.nml", "particles.n=2000", "run.max_steps=3",
                            "particles.placement=lattice", "numerics.pressure_gradient=standard",
                            "numerics.divergence=standard"],
    "higher_order_alone": STD + ["numerics.pressure_gradient=higher_order"],
    "renormalised_div": STD + ["numerics.divergence=renormalised", "numerics.renormalise=step"],
    "adjoint": STD + ["numerics.pressure_gradient=renormalised",
                      "numerics.divergence=renormalised"],
    "monaghan": STD + ["numerics.viscosity=monaghan", "numerics.alpha=0.05"],
    "reconstruction": STD + ["numerics.visc_reconstruction=.true."],
    "no_viscosity_no_diffusion": STD + ["numerics.viscosity=none", "numerics.diffusion=none"],
    "antuono": STD + ["numerics.diffusion=antuono"],
    "tensile": STD + ["numerics.tensile=.true.", "numerics.tensile_n=3"],
    "shifting": STD + ["numerics.shifting=.true."],
    "binned": STD + ["numerics.binned_sums=.true."],
    "binned_tensile_monaghan": STD + ["numerics.binned_sums=.true.", "numerics.tensile=.true.",
                                     "numerics.viscosity=monaghan"],
    "exponents": C2 + ["particles.n_ref=1000", "particles.h_exponent=0.5",
                       "physics.c0_exponent=0.5", "numerics.alpha_exponent=0.5",
                       "numerics.delta_exponent=-0.5"],
    "square_tensile_higher_order": ["input/square_rotation.nml", "particles.n=900",
                                    "run.max_steps=12", "numerics.binned_sums=.false.",
                                    "numerics.tensile=.true.", "numerics.shifting=.false.",
                                    "numerics.pressure_gradient=higher_order"],
}


def machine():
    """The compiler and the instruction-set class the bits depend on."""
    fc = subprocess.run(["gfortran", "--version"], capture_output=True, text=True).stdout
    flags = set()
    for line in open("/proc/cpuinfo"):
        if line.startswith("flags"):
            flags = set(line.split(":", 1)[1].split())
            break
    isa = "avx512f" if "avx512f" in flags else "avx2" if "avx2" in flags else "other"
    # what -march=native resolves to: the code the compiler generates
    q = subprocess.run(["gfortran", "-march=native", "-Q", "--help=target"], capture_output=True,
                       text=True).stdout
    march = next((l.split()[-1] for l in q.splitlines() if l.strip().startswith("-march=")), "")
    return {"compiler": fc.splitlines()[0], "isa": isa + ("+fma" if "fma" in flags else ""),
            "march": march}


def digest(run_dir):
    """SHA-256 of the last snapshot (datasets by id, attributes) and the time series."""
    h = hashlib.sha256()
    snap = sorted(run_dir.glob("snap_*.h5"))[-1]
    with h5py.File(snap, "r") as f:
        order = np.argsort(f["id"][:], kind="stable")
        for name in sorted(f.keys()):
            data = f[name][:]
            if data.ndim >= 1 and data.shape[0] == order.size:
                data = data[order]
            h.update(name.encode())
            h.update(np.ascontiguousarray(data).tobytes())
        for key in sorted(f.attrs.keys()):
            h.update(key.encode())
            h.update(repr(f.attrs[key]).encode())
    h.update((run_dir / "timeseries.csv").read_bytes())
    return h.hexdigest()


def run_config(name, where):
    d = pathlib.Path(where) / name
    p = run_sph(CONFIGS[name] + [f"output.dir={d}", "output.dt=100"])
    assert p.returncode == 0, (name, p.out)
    return digest(d)


def recorded():
    return json.loads(GOLDEN.read_text())


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_same_bits_as_recorded(scratch, name):
    rec = recorded()
    if rec["machine"] != machine():
        pytest.skip(f"digests recorded on {rec['machine']}, this is {machine()}")
    assert name in rec["digests"], f"{name}: not recorded (run this file with --write)"
    got = run_config(name, scratch("golden"))
    assert got == rec["digests"][name], f"{name}: the results changed bits"


if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    with tempfile.TemporaryDirectory() as tmp:
        digests = {name: run_config(name, tmp) for name in sorted(CONFIGS)}
    rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                         text=True).stdout.strip()
    GOLDEN.write_text(json.dumps({"written_by": rev, "machine": machine(), "digests": digests},
                                 indent=1) + "\n")
    print(f"{len(digests)} digests written to {GOLDEN}")
