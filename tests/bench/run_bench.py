#!/usr/bin/python3
"""make bench: fixed-step benchmarks of the solver at 1 and 2 ranks.

For each case it runs a fixed number of steps (no snapshots) and reads the
solver's own end-of-run figures: seconds per step, right-hand sides, pairs
per particle, peak memory, imbalance and communication share.  It prints a
table and writes it to runs/bench/bench.md with the machine it ran on.
Timings are only meaningful on an otherwise idle machine.

usage: tests/bench/run_bench.py [--quick] [--cases circle2d,ellipsoid3d] [--ranks 1,2]
"""
import argparse
import os
import pathlib
import platform
import re
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")

# case: (input file, particles, steps, extra overrides)
CASES = {
    "circle2d": ("input/circle2d.nml", 80000, 40, []),
    "ellipsoid3d": ("input/ellipsoid3d.nml", 1000000, 6, []),
    "ellipsoid3d_200k": ("input/ellipsoid3d.nml", 200000, 10, []),
    # the renormalised operators: a first pass and L_i g per pair side
    "ellipsoid3d_renormalised": ("input/ellipsoid3d.nml", 1000000, 6,
                                 ["numerics.divergence=renormalised",
                                  "numerics.pressure_gradient=higher_order"]),
}
QUICK = {"circle2d": 20000, "ellipsoid3d": 100000, "ellipsoid3d_200k": 50000,
         "ellipsoid3d_renormalised": 100000}


def run(case, n, steps, extra, ranks):
    inp = CASES[case][0]
    out = ROOT / "runs" / "bench" / f"{case}_np{ranks}"
    cmd = ["mpirun", "-np", str(ranks), str(ROOT / "sph"), inp, f"particles.n={n}",
           f"run.max_steps={steps}", "run.t_end=100", "output.snapshots=.false.",
           f"output.dir={out}", "run.progress_interval=1e9"] + extra
    t0 = time.time()
    p = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
    wall = time.time() - t0
    if p.returncode != 0:
        sys.exit(f"bench: {case} at {ranks} rank(s) failed:\n{p.stdout}\n{p.stderr}")
    txt = p.stdout
    m = re.search(r"done: (\d+) steps in\s+([\d.]+) s,\s+([\d.E+-]+) s/step,\s+([\d.E+-]+) "
                  r"particle-steps/s", txt)
    r = dict(steps=int(m.group(1)), loop=float(m.group(2)), s_step=float(m.group(3)),
             ps=float(m.group(4)), wall=wall)
    r["n"] = int(re.search(r"particles (\d+)", txt).group(1))
    r["rhs"] = int(re.search(r"right-hand sides (\d+)", txt).group(1))
    m = re.search(r"neighbours per particle:\s+([\d.]+) in the list,\s+([\d.]+) within", txt)
    r["listed"], r["pairs"] = float(m.group(1)), float(m.group(2))
    r["mem"] = float(re.search(r"peak memory\s+([\d.]+) MB per rank", txt).group(1))
    r["mem_all"] = float(re.search(r"MB per rank \(max\),\s+([\d.]+) MB in all", txt).group(1))
    im = re.search(r"imbalance \(max/mean particles\) mean\s+([\d.]+).*communication\s+([\d.]+) %",
                   txt)
    r["imb"], r["comm"] = (float(im.group(1)), float(im.group(2))) if im else (1.0, 0.0)
    r["rhs_s"] = r["rhs"] / r["loop"]
    r["updates"] = r["n"] * r["rhs"] / r["loop"]
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="smaller cases (a smoke test)")
    ap.add_argument("--cases", default="circle2d,ellipsoid3d,ellipsoid3d_renormalised")
    ap.add_argument("--ranks", default="1,2")
    a = ap.parse_args()
    ranks = [int(r) for r in a.ranks.split(",")]
    lines = [f"# sph benchmark, {time.strftime('%Y-%m-%d %H:%M')}",
             f"machine: {platform.node()}, {os.cpu_count()} cores, {platform.processor() or platform.machine()}",
             "", "| case | N | ranks | s/step | RHS/s | particle-updates/s | neighbours (support / list) |"
             " peak MB/rank | MB total | imbalance | comm % | efficiency |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    for case in a.cases.split(","):
        inp, n, steps, extra = CASES[case]
        if a.quick:
            n, steps = QUICK[case], max(3, steps // 4)
        base = None
        for p in ranks:
            r = run(case, n, steps, extra, p)
            if base is None:
                base = r["s_step"] * p
            eff = base / (r["s_step"] * p)
            line = (f"| {case} | {r['n']} | {p} | {r['s_step']:.4g} | {r['rhs_s']:.3g} |"
                    f" {r['updates']:.3g} | {r['pairs']:.1f} / {r['listed']:.1f} | {r['mem']:.0f} |"
                    f" {r['mem_all']:.0f} | {r['imb']:.3f} | {r['comm']:.1f} | {eff:.2f} |")
            lines.append(line)
            print(line, flush=True)
    out = ROOT / "runs" / "bench" / "bench.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"\nwritten to {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
