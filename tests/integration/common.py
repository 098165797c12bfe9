"""Shared helpers for the integration tests: run ./sph (under mpirun), read
the outputs.  Run directories come from the `scratch` fixture (conftest.py)."""
import csv
import os
import pathlib
import subprocess

ROOT = pathlib.Path(__file__).resolve().parents[2]
# SPH_BINARY runs the tests against another build (e.g. build/x/sph) than ./sph.
SPH = pathlib.Path(os.environ.get("SPH_BINARY", ROOT / "sph")).resolve()

ENV = dict(os.environ)
ENV.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")


def run_sph(args, np=1, cwd=None, timeout=600):
    """Runs `mpirun -np np ./sph args...`; returns the CompletedProcess
    (stdout and stderr as text, merged into .out as well)."""
    cmd = ["mpirun", "-np", str(np), str(SPH)] + [str(a) for a in args]
    p = subprocess.run(cmd, cwd=cwd or ROOT, env=ENV, capture_output=True, text=True,
                       timeout=timeout)
    p.out = p.stdout + p.stderr
    return p


def read_timeseries(path):
    """timeseries.csv as a dict of column name -> list of floats."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, data = rows[0], rows[1:]
    return {name: [float(r[k]) for r in data] for k, name in enumerate(header)}
