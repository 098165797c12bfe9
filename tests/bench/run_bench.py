#!/usr/bin/python3
"""make bench: fixed-step benchmarks of the solver at 1 and 2 ranks.

For each case it runs a fixed number of steps (no snapshots) and reads the
solver's own end-of-run figures: seconds per step, right-hand sides, pairs
per particle, peak memory, imbalance and communication share.  It prints a
table and writes it to runs/bench/bench.md with the machine it ran on.
Timings are only meaningful on an otherwise idle machine.

With --baseline REV (make bench BASELINE=REV) it also builds that git
revision under build/baseline/REV (from `git archive`, never in the source
tree) and runs the two executables alternately on every case, --repeat
times each, printing the ratio baseline/current of the seconds per step
(the median of the repeats): the honest comparison on a noisy machine.
Both get the same explicit settings (CASES: operators, placement, h/dx,
c0, particle count), not their own input defaults.

usage: tests/bench/run_bench.py [--quick] [--cases circle2d,ellipsoid3d] [--ranks 1,2]
                                [--baseline REV] [--repeat 2]
"""
import argparse
import os
import pathlib
import platform
import re
import statistics
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")

# Settings every case states explicitly, so that a baseline revision with
# other input defaults runs the same problem (rings: no packing before the
# timed steps; every option here exists since 1c431d2, the baseline of the
# vectorised pair loop: hence L_i every stage, numerics.renormalise came
# later).
COMMON_3D = ["particles.placement=rings", "particles.h_over_dx=1.6", "physics.c0=10",
             "numerics.alpha=0.01", "numerics.delta=0.1", "numerics.cfl=2.0",
             "numerics.skin=0.2"]
STANDARD = ["numerics.divergence=standard", "numerics.pressure_gradient=standard"]
RENORMALISED = ["numerics.divergence=renormalised", "numerics.pressure_gradient=higher_order"]
# case: (input file, particles, steps, explicit settings)
CASES = {
    "circle2d": ("input/circle2d.nml", 80000, 40,
                 ["particles.placement=rings", "particles.h_over_dx=2.0", "physics.c0=12.5",
                  "numerics.alpha=0.008", "numerics.delta=0.2"] + RENORMALISED),
    "ellipsoid3d": ("input/ellipsoid3d.nml", 1000000, 6, COMMON_3D + STANDARD),
    "ellipsoid3d_200k": ("input/ellipsoid3d.nml", 200000, 10, COMMON_3D + STANDARD),
    # the renormalised operators: a first pass and L_i g per pair side
    "ellipsoid3d_renormalised": ("input/ellipsoid3d.nml", 1000000, 6, COMMON_3D + RENORMALISED),
    # the convergence recipe (H2, R1, Antuono's diffusion, all computed from
    # n by the input file): options a baseline older than them lacks, where
    # its column reads n/a
    "circle2d_convergence": ("input/circle2d_convergence.nml", 80425, 20,
                             ["particles.placement=rings"]),
    # the squares' input: the general pair loop with binned sums, and shifting
    "square_rotation": ("input/square_rotation.nml", 90000, 20, []),
}
# the cases whose pair loops have no operation count below (no % of peak)
NO_FLOP_COUNT = {"circle2d_convergence", "square_rotation"}
# Floating-point operations of one pair, counted in src/sph/pair_terms.fypi and
# pair_loop.fypi (multiplications, additions, divisions and square roots as one
# each): per listed pair the distance test (8); per pair within the support
# the kernel (10) and the body: 54 with the standard operators, 140 with the
# renormalised divergence and the higher-order gradient; the first pass
# (M_i, lambda_i) 35.
FLOPS_LISTED = 8
FLOPS_IN_RANGE = {"standard": 64, "renormalised": 150, "first_pass": 45}
# double-precision operations per cycle and core: two 512-bit FMA units
PEAK_FLOPS_PER_CYCLE = 32

QUICK = {"circle2d": 20000, "ellipsoid3d": 100000, "ellipsoid3d_200k": 50000,
         "ellipsoid3d_renormalised": 100000, "circle2d_convergence": 20107}


def build_baseline(rev):
    """The executable of git revision rev, built under build/baseline/<rev>."""
    full = subprocess.run(["git", "rev-parse", "--short", rev], cwd=ROOT, capture_output=True,
                          text=True)
    if full.returncode != 0:
        sys.exit(f"bench: unknown revision {rev!r}: {full.stderr.strip()}")
    short = full.stdout.strip()
    d = ROOT / "build" / "baseline" / short
    exe = d / "sph"
    if not exe.exists():
        d.mkdir(parents=True, exist_ok=True)
        arch = subprocess.run(f"git archive {short} | tar -x -C {d}", shell=True, cwd=ROOT,
                              capture_output=True, text=True)
        if arch.returncode != 0:
            sys.exit(f"bench: git archive {short} failed: {arch.stderr}")
        print(f"building {short} in {d.relative_to(ROOT)} ...", flush=True)
        b = subprocess.run(["make", "-j2", "sph"], cwd=d, capture_output=True, text=True)
        if b.returncode != 0 or not exe.exists():
            sys.exit(f"bench: building {short} failed:\n{b.stdout[-3000:]}{b.stderr[-3000:]}")
    return short, d, exe


def run(case, n, steps, extra, ranks, exe=None, cwd=ROOT, tag="", may_fail=False):
    """One fixed-step run and its figures; None if it fails and may_fail
    (a baseline that lacks an option of the case)."""
    inp = CASES[case][0]
    out = ROOT / "runs" / "bench" / f"{case}_np{ranks}{tag}"
    cmd = ["mpirun", "-np", str(ranks), str(exe or ROOT / "sph"), inp, f"particles.n={n}",
           f"run.max_steps={steps}", "run.t_end=100", "output.snapshots=.false.",
           f"output.dir={out}", "run.progress_interval=1e9"] + extra
    t0 = time.time()
    p = subprocess.run(cmd, cwd=cwd, env=ENV, capture_output=True, text=True)
    wall = time.time() - t0
    if p.returncode != 0 and may_fail:
        return None
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
    tm = re.search(r"time \(largest rank\): pair passes\s+([\d.]+) %, list rebuilds\s+([\d.]+) %, "
                   r"validity test\s+([\d.]+) %, communication\s+([\d.]+) %, integration\s+"
                   r"([\d.]+) %;\s+([\d.E+-]+) listed pairs", txt)
    if tm:
        r["t_pairs"], r["t_build"], r["t_check"], r["t_comm"], r["t_integ"] = \
            (float(tm.group(k)) for k in range(1, 6))
        r["pair_rate"] = float(tm.group(6))
    r["rhs_s"] = r["rhs"] / r["loop"]
    r["updates"] = r["n"] * r["rhs"] / r["loop"]
    return r


def clock_ghz():
    """The cores' clock from /proc/cpuinfo (mean of the cpu MHz lines)."""
    try:
        mhz = [float(l.split(":")[1]) for l in open("/proc/cpuinfo") if l.startswith("cpu MHz")]
        return sum(mhz) / len(mhz) / 1e3
    except (OSError, ValueError, ZeroDivisionError):
        return float("nan")


def time_line(case, r, ghz):
    """Where the time goes, pairs per second, cycles per pair and the
    fraction of the peak floating-point rate in the pair passes."""
    if "pair_rate" not in r or case in NO_FLOP_COUNT:
        return None
    extra = CASES[case][3]
    renorm = "numerics.divergence=renormalised" in extra
    in_range = r["pairs"] / r["listed"]
    if renorm:   # the first pass and the main pass each visit the list
        flops = FLOPS_LISTED + in_range * (FLOPS_IN_RANGE["renormalised"]
                                           + FLOPS_IN_RANGE["first_pass"]) / 2
    else:
        flops = FLOPS_LISTED + in_range * FLOPS_IN_RANGE["standard"]
    cycles = ghz * 1e9 / r["pair_rate"]
    peak = r["pair_rate"] * flops / (ghz * 1e9 * PEAK_FLOPS_PER_CYCLE)
    return (f"| {case} | {r['n']} | {r['ranks']} | {r['t_pairs']:.1f} | {r['t_build']:.1f} | "
            f"{r['t_check']:.1f} | {r['t_comm']:.1f} | {r['t_integ']:.1f} | "
            f"{r['pair_rate']:.3g} | {cycles:.1f} | {flops:.0f} | {100 * peak:.1f} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="smaller cases (a smoke test)")
    ap.add_argument("--cases", default="circle2d,ellipsoid3d,ellipsoid3d_renormalised,"
                                       "circle2d_convergence,square_rotation")
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--baseline", default="", help="git revision to compare with")
    ap.add_argument("--repeat", type=int, default=2, help="runs of each with --baseline")
    a = ap.parse_args()
    ranks = [int(r) for r in a.ranks.split(",")]
    baseline = build_baseline(a.baseline) if a.baseline else None
    head = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT,
                          capture_output=True, text=True).stdout.strip()
    lines = [f"# sph benchmark, {time.strftime('%Y-%m-%d %H:%M')}, {head}",
             f"machine: {platform.node()}, {os.cpu_count()} cores, "
             f"{platform.processor() or platform.machine()}", ""]
    if baseline:
        lines += [f"baseline {baseline[0]} against {head}: seconds per step, the median of "
                  f"{a.repeat} alternate runs each, same explicit settings", "",
                  "| case | N | ranks | baseline s/step | current s/step | speed-up | "
                  "baseline MB/rank | current MB/rank |", "|---|---|---|---|---|---|---|---|"]
    else:
        lines += ["| case | N | ranks | s/step | RHS/s | particle-updates/s | neighbours "
                  "(support / list) | peak MB/rank | MB total | imbalance | comm % | efficiency |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    time_lines = []
    for case in a.cases.split(","):
        inp, n, steps, extra = CASES[case]
        if a.quick:
            n, steps = QUICK[case], max(3, steps // 4)
        base = None
        for p in ranks:
            if baseline:
                old, new = [], []
                for _ in range(a.repeat):
                    old.append(run(case, n, steps, extra, p, baseline[2], baseline[1], "_base",
                                   may_fail=case in NO_FLOP_COUNT))
                    new.append(run(case, n, steps, extra, p))
                sn = statistics.median(r["s_step"] for r in new)
                mn = max(r["mem"] for r in new)
                if None in old:
                    line = (f"| {case} | {new[0]['n']} | {p} | n/a | {sn:.4g} | n/a | n/a | "
                            f"{mn:.0f} |")
                else:
                    so = statistics.median(r["s_step"] for r in old)
                    line = (f"| {case} | {new[0]['n']} | {p} | {so:.4g} | {sn:.4g} | "
                            f"{so / sn:.2f} | {max(r['mem'] for r in old):.0f} | {mn:.0f} |")
            else:
                r = run(case, n, steps, extra, p)
                r["ranks"] = p
                tl = time_line(case, r, clock_ghz())
                if tl:
                    time_lines.append(tl)
                if base is None:
                    base = r["s_step"] * p
                eff = base / (r["s_step"] * p)
                line = (f"| {case} | {r['n']} | {p} | {r['s_step']:.4g} | {r['rhs_s']:.3g} |"
                        f" {r['updates']:.3g} | {r['pairs']:.1f} / {r['listed']:.1f} |"
                        f" {r['mem']:.0f} | {r['mem_all']:.0f} | {r['imb']:.3f} |"
                        f" {r['comm']:.1f} | {eff:.2f} |")
            lines.append(line)
            print(line, flush=True)
    if time_lines:
        head2 = ["", f"Where the time goes (% of the loop's wall time, largest rank) and the pair "
                 f"passes' rate: listed pairs per second per rank (one rank per core), cycles per "
                 f"listed pair at {clock_ghz():.2f} GHz, floating-point operations per listed "
                 f"pair (counted), fraction of the peak ({PEAK_FLOPS_PER_CYCLE} per cycle and "
                 f"core)", "",
                 "| case | N | ranks | pair passes | list rebuilds | validity test | "
                 "communication | integration | pairs/s per core | cycles/pair | flops/pair | "
                 "% of peak |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        lines += head2 + time_lines
        print("\n".join(head2 + time_lines))
    out = ROOT / "runs" / "bench" / ("bench_baseline.md" if baseline else "bench.md")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"\nwritten to {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
