#!/usr/bin/python3
"""The scaling model of doc/developer/parallel.md: memory per rank, halo copies,
messages, bytes and time per step of the million-particle sphere's settings
scaled to 10^7..10^9 particles on 10..10,000 ranks, from the counts that
tests/bench/decomp_study.py measured (runs/decomp/decomp.json) and the
constants below (each measured on the development machine, or a stated
network).  Prints the markdown table of doc/developer/parallel.md.

usage: tests/bench/scaling_model.py [runs/decomp/decomp.json]
"""
import json
import math
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]

# measured (input/ellipsoid3d.nml, 2-core development machine)
US_PER_PARTICLE_STEP = 6.44   # 3.22 s/step x 2 cores / 999,648 particles, h/dx 1.65
KB_PER_PARTICLE = 1.33        # peak per particle held (owned + halo), 16 ranks x 1M
FIXED_MB = 26.0               # a rank's footprint with a few particles
H_OVER_DX_1M = 1.65           # the input's rule: h/dx = 1.65 (N/1e6)^(0.1/3)
LIST_RADIUS_H = 2.2           # kernel support 2h + skin 0.2h
PARTNERS_MAX = 26             # measured 17 mean, 27 max at P = 64 (sfc)
REDUCTIONS_PER_STEP = 20      # time step, validity test, samples of the time series
REBUILD_EVERY = 7.3           # steps per list rebuild (257 steps, 35 rebuilds)
# a stated network: latency per message and bandwidth per rank (a node of
# 64 ranks sharing 25 GB/s of injection bandwidth, all sending at once)
ALPHA_S = 2e-6
BETA_BYTES_S = 25e9 / 64


def shape_factor(rows):
    """a in h = (1 + a t n^(-1/3))^3 - 1 from the finest sfc pieces measured,
    the bytes per halo copy and messages per partner per step, and the
    pairs evaluated twice (across the cuts) per halo copy."""
    r = max((r for r in rows if r["case"] == "ellipsoid3d" and r["method"] == "sfc"),
            key=lambda r: r["ranks"])
    n = r["n"] / r["ranks"]
    t = LIST_RADIUS_H * H_OVER_DX_1M * (r["n"] / 1e6) ** (0.1 / 3)
    a = ((1 + r["halo_per_particle"]) ** (1 / 3) - 1) * n ** (1 / 3) / t
    return (a, r["bytes_per_step"] / (r["halo_per_particle"] * n),
            r["messages_per_step"] / r["partners_mean"],
            (r["pair_ratio"] - 1) / r["halo_per_particle"])


def model(n_total, p, a, bytes_per_copy, msgs_per_partner, dup):
    n = n_total / p
    hdx = H_OVER_DX_1M * (n_total / 1e6) ** (0.1 / 3)
    t = LIST_RADIUS_H * hdx
    halo = (1 + a * t / n ** (1 / 3)) ** 3 - 1 if p > 1 else 0.0
    work = US_PER_PARTICLE_STEP * 1e-6 * (hdx / H_OVER_DX_1M) ** 3   # neighbours ~ (h/dx)^3
    t_ideal = work * n
    t_comp = work * n * (1 + dup * halo)    # pairs across a cut are computed on both sides
    partners = min(PARTNERS_MAX, p - 1)
    msgs = partners * msgs_per_partner
    bytes_ = bytes_per_copy * halo * n
    t_p2p = msgs * ALPHA_S + bytes_ / BETA_BYTES_S
    t_coll = REDUCTIONS_PER_STEP * 2 * ALPHA_S * math.log2(max(p, 2))
    t_a2a = 2 * p * ALPHA_S / REBUILD_EVERY  # MPI_Alltoall of counts at each rebuild
    total = t_comp + t_p2p + t_coll + t_a2a
    mem = FIXED_MB + KB_PER_PARTICLE * n * (1 + halo) / 1e3
    return dict(n=n, halo=halo, mem=mem, msgs=msgs, kb=bytes_ / 1e3, t=total,
                eff=t_ideal / total, comm=(t_p2p + t_coll + t_a2a) / total)


def main():
    path = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "runs/decomp/decomp.json"
    rows = json.loads(path.read_text())
    a, bpc, mpp, dup = shape_factor(rows)
    print(f"shape factor a = {a:.2f}, {bpc:.0f} bytes per halo copy per step, "
          f"{mpp:.1f} messages per partner per step, {dup:.3f} more pairs per halo copy "
          f"(from {path.name})\n")
    print("| N | ranks | particles per rank | halo copies per particle | memory per rank (MB) "
          "| messages per step | kB sent per step | s per step | communication share "
          "| efficiency |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for n_total in (1e7, 1e8, 1e9):
        for p in (10, 100, 1000, 10000):
            m = model(n_total, p, a, bpc, mpp, dup)
            print(f"| 10^{int(math.log10(n_total))} | {p:,} | {m['n']:,.0f} | {m['halo']:.2f} | "
                  f"{m['mem']:,.0f} | {m['msgs']:.0f} | {m['kb']:,.0f} | {m['t']:.3g} | "
                  f"{100 * m['comm']:.1f} % | {m['eff']:.2f} |")


if __name__ == "__main__":
    main()
