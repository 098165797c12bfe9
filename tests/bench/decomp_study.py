#!/usr/bin/python3
"""make decomp-study: what each decomposition costs in copies and messages.

Runs a few steps of a 2D and a 3D case with the slab, METIS and
space-filling-curve decompositions at P = 2, 4, ..., 64 ranks (oversubscribed
on a small machine: the counts are what is measured, not the times) and
reads the solver's end-of-run lines: halo copies per particle, partner ranks
per rank (mean and largest), bytes and messages sent per rank and step, and
the imbalance of the particle counts.  Prints a markdown table and writes it
with the raw figures to runs/decomp/ (doc/developer/parallel.md quotes it).

usage: tests/bench/decomp_study.py [--ranks 2,4,8,16,32,64] [--cases circle2d,ellipsoid3d]
"""
import argparse
import json
import os
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
# SPH_BINARY runs another build than ./sph (e.g. a copy while ./sph is rebuilt)
SPH = pathlib.Path(os.environ.get("SPH_BINARY", ROOT / "sph")).resolve()
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", OMPI_MCA_mpi_yield_when_idle="1")
# case: (input file, particles, steps, settings); a clipped lattice (no
# packing: the counts hardly depend on it), each input's own operators
CASES = {
    "circle2d": ("input/circle2d.nml", 80000, 10, ["particles.placement=lattice"]),
    "ellipsoid3d": ("input/ellipsoid3d.nml", 200000, 6, ["particles.placement=lattice"]),
}
METHODS = ("slab", "metis", "sfc")
NUM = r"([-+0-9.Ee]+)"


def run(case, p, method, out):
    nml, n, steps, extra = CASES[case]
    cmd = ["mpirun", "-np", str(p), str(SPH), nml, f"particles.n={n}",
           f"run.max_steps={steps}", "output.snapshots=.false.",
           f"parallel.decomposition={method}", f"output.dir={out}"] + extra
    r = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{r.stdout[-2000:]}{r.stderr[-2000:]}")
    imb = re.search(r"imbalance \(max/mean particles\) mean +" + NUM + r", max +" + NUM, r.stdout)
    halo = re.search(r"halo: +" + NUM + r" copies per particle, +" + NUM +
                     r" partner ranks per rank \(max (\d+)\); sent per rank and step +" + NUM +
                     r" bytes \(max +" + NUM + r"\), +" + NUM + " messages", r.stdout)
    parts = re.search(r"particles (\d+)", r.stdout)
    pairs = re.search(r"pairs evaluated +" + NUM + " times", r.stdout)
    return {"case": case, "ranks": p, "method": method, "n": int(parts.group(1)),
            "imbalance": float(imb.group(2)), "halo_per_particle": float(halo.group(1)),
            "partners_mean": float(halo.group(2)), "partners_max": int(halo.group(3)),
            "bytes_per_step": float(halo.group(4)), "bytes_per_step_max": float(halo.group(5)),
            "messages_per_step": float(halo.group(6)), "pair_ratio": float(pairs.group(1))}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--ranks", default="2,4,8,16,32,64")
    ap.add_argument("--cases", default=",".join(CASES))
    args = ap.parse_args()
    outdir = ROOT / "runs" / "decomp"
    outdir.mkdir(parents=True, exist_ok=True)
    rows = []
    for case in args.cases.split(","):
        for p in [int(x) for x in args.ranks.split(",")]:
            for method in METHODS:
                r = run(case, p, method, outdir / f"{case}_{method}_{p}")
                rows.append(r)
                print(json.dumps(r), flush=True)
    (outdir / "decomp.json").write_text(json.dumps(rows, indent=1))
    lines = ["| case | N | P | method | halo copies / owned | partner ranks mean (max) "
             "| kB sent / rank / step (max) | messages / rank / step | imbalance "
             "| pairs / one-rank pairs |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['n']:,} | {r['ranks']} | {r['method']} | "
                     f"{r['halo_per_particle']:.3f} | "
                     f"{r['partners_mean']:.1f} ({r['partners_max']}) | "
                     f"{r['bytes_per_step'] / 1e3:.0f} ({r['bytes_per_step_max'] / 1e3:.0f}) | "
                     f"{r['messages_per_step']:.0f} | {r['imbalance']:.3f} | "
                     f"{r['pair_ratio']:.3f} |")
    table = "\n".join(lines)
    (outdir / "decomp.md").write_text(table + "\n")
    print(table)


if __name__ == "__main__":
    main()
