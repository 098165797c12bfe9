"""The case registry (src/cases/case_factory.f90): every case the program
offers for run.case has its input file, input/<case>.nml, and that file
runs (a few steps at a small particle count, two ranks)."""
import math
import re

from common import ROOT, run_sph, read_timeseries


def registered_cases():
    """The cases of the factory, as --help lists the allowed run.case."""
    p = run_sph(["--help"])
    assert p.returncode == 0, p.out
    line = next(l for l in p.stdout.splitlines() if l.strip().startswith("run.case ="))
    return re.findall(r"'([a-z0-9_]+)'", line.split("one of", 1)[1])


def test_every_registered_case_has_an_input_file_that_runs(scratch):
    cases = registered_cases()
    assert len(cases) >= 4, cases
    for case in cases:
        nml = ROOT / "input" / f"{case}.nml"
        assert nml.exists(), f"case {case} has no input file {nml}"
        d = scratch(case) / "run"
        p = run_sph([nml, "particles.n=1200", "particles.pack_iterations=20", "run.max_steps=3",
                     f"output.dir={d}"], np=2)
        assert p.returncode == 0, (case, p.out[-2000:])
        ts = read_timeseries(d / "timeseries.csv")
        assert ts["step"][-1] == 3, case
        assert all(math.isfinite(v) for v in ts["kinetic_energy"]), case
