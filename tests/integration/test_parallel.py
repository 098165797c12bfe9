"""Parallel runs give the same particles as one rank.  The neighbour sums are
taken in a canonical order (doc/studies/numerics.md), so the agreement is bitwise,
not just to round-off: the tests ask for exact equality, matched by id."""
import re

import h5py
import numpy as np

from common import run_sph, read_timeseries

FIELDS = ("position", "velocity", "density", "pressure", "free_surface_lambda")


def final_state(d):
    f = sorted(d.glob("snap_*.h5"))[-1]
    with h5py.File(f, "r") as h:
        order = np.argsort(h["id"][:])
        return {k: h[k][:][order] for k in FIELDS}, float(h.attrs["time"]), int(h.attrs["step"])


def run(scratch, np_, extra, tag):
    d = scratch(f"par{np_}_{tag}") / "run"
    p = run_sph(["input/circle2d.nml", "particles.n=5000", "run.max_steps=100",
                 f"output.dir={d}", "output.dt=10"] + extra, np=np_)
    assert p.returncode == 0, p.out
    return final_state(d), p.out


def check_agreement(scratch, extra, tag, ranks):
    (ref, t_ref, step_ref), _ = run(scratch, 1, extra, tag)
    assert step_ref == 100
    for np_ in ranks:
        (got, t, step), out = run(scratch, np_, extra, tag)
        assert step == 100 and t == t_ref, (np_, step, t, t_ref)
        for k in FIELDS:
            same = np.array_equal(ref[k].view(np.int64), got[k].view(np.int64))
            assert same, (tag, np_, k, float(np.max(np.abs(ref[k] - got[k]))))
        assert "imbalance" in out


def test_slab_bitwise_at_2_3_4_ranks(scratch):
    # 100 steps of circle2d with about 5,000 particles, slab decomposition;
    # re-balancing and migration happen on the way (the patch stretches)
    check_agreement(scratch, [], "slab", [2, 3, 4])


def test_slab_bitwise_with_density_gradient_exchange(scratch):
    # the Antuono diffusion needs a second halo exchange (of the
    # renormalised density gradient) inside every right-hand side
    check_agreement(scratch, ["numerics.diffusion=antuono", "physics.eos=tait"], "antuono", [3])


def test_corrected_operators_and_shifting_bitwise(scratch):
    # the higher-order pressure gradient needs the free-surface indicator of
    # halo copies (an exchange), the renormalised divergence the matrix L of
    # the first pass, and shifting a halo refresh after each step: all in
    # canonical order
    check_agreement(scratch, ["numerics.pressure_gradient=higher_order",
                              "numerics.divergence=renormalised", "numerics.shifting=.true.",
                              "numerics.diffusion=antuono"], "corrected", [2, 3])


def test_quadratic_probe_bitwise(scratch):
    # the quadratic probe (D5) sums its normal equations exactly: the centre
    # pressure column is the same on 1 and 3 ranks to all 16 digits of the file
    cols = []
    for np_ in (1, 3):
        d = scratch(f"probe{np_}") / "run"
        p = run_sph(["input/circle2d.nml", "particles.n=3000", "run.max_steps=20",
                     "output.probe_quadratic=.true.", "output.snapshots=.false.",
                     f"output.dir={d}"], np=np_)
        assert p.returncode == 0, p.out
        cols.append(np.array(read_timeseries(d / "timeseries.csv")["p_probe_1"]))
    assert len(cols[0]) == 21 and np.all(np.isfinite(cols[0]))
    assert np.array_equal(cols[0].view(np.int64), cols[1].view(np.int64)), cols


def test_reconstructed_viscosity_bitwise(scratch):
    # the reconstructed viscosity (R1) needs the strain rate of halo copies
    # (an exchange) at every stage, from its own pass in canonical order
    check_agreement(scratch, ["numerics.visc_reconstruction=.true.",
                              "numerics.renormalise=step"], "recon", [3])


def test_adjoint_pressure_gradient_bitwise(scratch):
    # (H2) reads L_j and lambda_j of halo partners (two exchanges a stage);
    # with renormalise=step they are the step's first ones
    for when in ("stage", "step"):
        check_agreement(scratch, ["numerics.pressure_gradient=renormalised",
                                  "numerics.divergence=renormalised",
                                  f"numerics.renormalise={when}"], "adjoint_" + when, [3])


def test_metis_bitwise_at_2_and_3_ranks(scratch):
    check_agreement(scratch, ["parallel.decomposition=metis"], "metis", [2, 3])


def test_sfc_bitwise_at_2_3_4_ranks(scratch):
    # the Hilbert-curve pieces, re-balanced as the patch stretches
    check_agreement(scratch, ["parallel.decomposition=sfc"], "sfc", [2, 3, 4])


def test_pairs_balance_bitwise(scratch):
    check_agreement(scratch, ["parallel.balance=pairs", "parallel.imbalance_threshold=0.02"],
                    "pairs", [2])


def _restart_pair(scratch, np_a, np_b, extra_b=()):
    """Run A: 200 steps with snapshots every 0.5 (the one at t = 0.5 comes
    at step 75).  Run B: a copy of A's directory cut after that snapshot,
    restarted from it to step 200.  Returns both final states and dirs."""
    import shutil
    base = scratch("restart")
    a = base / "a"
    p = run_sph(["input/circle2d.nml", "particles.n=5000", "run.max_steps=200",
                 "output.dt=0.5", f"output.dir={a}"], np=np_a)
    assert p.returncode == 0, p.out
    b = base / "b"
    shutil.copytree(a, b)
    for f in b.glob("snap_*.h5"):
        if int(f.stem[5:]) > 1:
            f.unlink()
    p = run_sph(["input/circle2d.nml", "particles.n=5000", "run.max_steps=200",
                 "output.dt=0.5", f"output.dir={b}", f"run.restart={b / 'snap_00001.h5'}"]
                + list(extra_b), np=np_b)
    assert p.returncode == 0, p.out
    assert "restarted from" in p.stdout
    return a, b


def test_restart_bitwise_same_ranks(scratch):
    a, b = _restart_pair(scratch, 2, 2)
    (sa, ta, na), (sb, tb, nb) = final_state(a), final_state(b)
    assert na == nb == 200 and ta == tb
    for k in FIELDS:
        assert np.array_equal(sa[k].view(np.int64), sb[k].view(np.int64)), k
    # the time series was continued, not restarted: same rows, same times
    ra = np.genfromtxt(a / "timeseries.csv", delimiter=",", names=True)
    rb = np.genfromtxt(b / "timeseries.csv", delimiter=",", names=True)
    assert len(ra) == len(rb) and np.array_equal(ra["time"], rb["time"])
    assert np.allclose(ra["kinetic_energy"], rb["kinetic_energy"], rtol=1e-13, atol=0)
    # and the index lists every snapshot, the earlier ones included
    assert (b / "snapshots.xdmf").read_text().count("<Grid Name") == \
        (a / "snapshots.xdmf").read_text().count("<Grid Name")


def test_restart_bitwise_other_ranks_and_decomposition(scratch):
    a, b = _restart_pair(scratch, 2, 3, ["parallel.decomposition=metis"])
    (sa, _, _), (sb, _, _) = final_state(a), final_state(b)
    for k in FIELDS:
        assert np.array_equal(sa[k].view(np.int64), sb[k].view(np.int64)), k


def test_bad_restart_writes_nothing(scratch):
    d = scratch("badrestart") / "never"
    p = run_sph(["input/circle2d.nml", f"output.dir={d}", "run.restart=/nonexistent/snap_00001.h5"])
    assert p.returncode != 0 and "&run restart" in p.stderr and "does not exist" in p.stderr
    assert not d.exists()
    # a snapshot of another case
    sq = scratch("sq") / "run"
    p = run_sph(["input/square_rotation.nml", "particles.n=400", "run.t_end=0.01",
                 f"output.dir={sq}"])
    assert p.returncode == 0, p.out
    p = run_sph(["input/circle2d.nml", f"output.dir={d}", f"run.restart={sq / 'snap_00000.h5'}"])
    assert p.returncode != 0 and "square_rotation" in p.stderr, p.stderr
    assert not d.exists()
    # a snapshot at or after t_end: nothing to do, said in one line (it was a
    # Fortran runtime error, writing the message into a string too short)
    last = sorted(sq.glob("snap_*.h5"))[-1]
    p = run_sph(["input/square_rotation.nml", "particles.n=400", f"output.dir={d}",
                 "run.t_end=0.01", f"run.restart={last}"], np=2)
    assert p.returncode == 2 and "nothing to do (raise run.t_end)" in p.stderr, p.out
    assert "runtime error" not in p.out
    assert not d.exists()


def test_square_vortical_parallel(scratch):
    # the square cases too, bitwise: the dynamics, and the vorticity and
    # free-surface indicator of the snapshots (computed on the solver's list
    # in its canonical order, from halo copies brought up to date)
    def go(np_):
        d = scratch(f"sqv{np_}") / "run"
        p = run_sph(["input/square_vortical.nml", "particles.n=2500", "run.max_steps=60",
                     f"output.dir={d}", "output.dt=10"], np=np_)
        assert p.returncode == 0, p.out
        f = sorted(d.glob("snap_*.h5"))[-1]
        with h5py.File(f, "r") as h:
            o = np.argsort(h["id"][:])
            return {k: h[k][:][o] for k in FIELDS + ("vorticity",)}
    a, b = go(1), go(3)
    for k in FIELDS + ("vorticity",):
        assert np.array_equal(a[k].view(np.int64), b[k].view(np.int64)), k


def test_ellipsoid3d_one_and_two_ranks(scratch):
    # 3D with the input file's settings (packed particles, h/dx from its
    # resolution rule: 1.41 at this count, renormalised divergence,
    # higher-order gradient, L_i once a step, prepared start, c0 = 11): about
    # 4,000 particles to t A0 = 1, the paper's end time, on 1 and 2 ranks:
    # the same particles bit for bit (packing included), and errors against
    # the exact solution (X1, X2) within 1.5x of those measured: largest
    # semi-axis 0.151 %, RMS position 0.976 %, RMS velocity 2.13 %, KE
    # change -0.382 %, start-up dip of the centre pressure (largest fall of
    # the probe below P(t) for t A0 < 0.05) 3.20 % of P(0)
    from common import read_timeseries
    AX3, POS3, VEL3, KE3, DIP3 = 0.0023, 0.0146, 0.032, 0.0057, 0.048
    states = []
    for np_ in (1, 2):
        d = scratch(f"ell{np_}") / "run"
        p = run_sph(["input/ellipsoid3d.nml", "particles.n=4000", "output.dt=1",
                     f"output.dir={d}"], np=np_)
        assert p.returncode == 0, p.out
        states.append(final_state(d))
        ts = read_timeseries(d / "timeseries.csv")
        assert abs(ts["time"][-1] - 1.0) < 1e-12
        axes = max(abs(v[-1]) for k, v in ts.items()
                   if k.startswith("semi_axis_") and k.endswith("_error"))
        vel, pos = ts["rms_velocity_error"][-1], ts["rms_position_error"][-1]
        dke = ts["kinetic_energy"][-1] / ts["kinetic_energy"][0] - 1
        early = [i for i, t in enumerate(ts["time"]) if t < 0.05]
        p0 = ts["p_centre_exact"][0]
        dip = max(0.0, max((ts["p_centre_exact"][i] - ts["p_probe_1"][i]) / p0 for i in early))
        print(f"    {np_} rank(s): axis {100 * axes:.3f} %  pos {100 * pos:.3f} %  "
              f"vel {100 * vel:.3f} %  KE {100 * dke:.3f} %  dip {100 * dip:.3f} %")
        assert axes < AX3 and pos < POS3 and vel < VEL3 and abs(dke) < KE3 and dip < DIP3, \
            (axes, pos, vel, dke, dip)
    (a, ta, na), (b, tb, nb) = states
    assert na == nb and ta == tb
    for k in FIELDS:
        assert np.array_equal(a[k].view(np.int64), b[k].view(np.int64)), k


def test_packed_particles_from_snapshot(scratch):
    # particles.from: a run that reads the packed positions of another run's
    # first snapshot (on 2 ranks, the packing run on 1) ends bitwise where
    # the packing run ends, and packs nothing itself
    d1 = scratch("packfrom1") / "run"
    d2 = scratch("packfrom2") / "run"
    common = ["input/circle2d.nml", "particles.n=1250", "run.t_end=0.25", "output.dt=0.25"]
    p = run_sph(common + [f"output.dir={d1}"], np=1)
    assert p.returncode == 0, p.out
    assert "packed in" in p.stdout
    p = run_sph(common + [f"output.dir={d2}", f"particles.from={d1 / 'snap_00000.h5'}"], np=2)
    assert p.returncode == 0, p.out
    assert "packed in" not in p.stdout and "packed particles from" in p.stdout
    (a, ta, na), (b, tb, nb) = final_state(d1), final_state(d2)
    assert na == nb and ta == tb
    for k in FIELDS:
        assert np.array_equal(a[k].view(np.int64), b[k].view(np.int64)), k


def test_bad_snapshot_files_said_once_and_by_variable(scratch):
    # a file that is not HDF5, one cut short, and (with the resolution
    # scaling) a packed file of another particle count: one line each on two
    # ranks, naming the variable that gave the file, HDF5's own error stack
    # not printed, nothing written
    d = scratch("badfiles") / "never"
    junk = scratch("badfiles_in") / "junk.h5"
    junk.write_text("not a snapshot\n" * 100)
    packed = scratch("badfiles_packed") / "run"
    recipe = ["input/circle2d_convergence.nml", "particles.n=314", "run.max_steps=1"]
    p = run_sph(recipe + [f"output.dir={packed}"], np=1)
    assert p.returncode == 0, p.out
    cut = junk.parent / "cut.h5"
    cut.write_bytes((packed / "snap_00000.h5").read_bytes()[:3000])
    bare = junk.parent / "bare.h5"                # HDF5, but not a snapshot
    with h5py.File(bare, "w") as h:
        h["x"] = np.zeros(3)
    cases = [(["input/circle2d.nml", f"run.restart={junk}"], "&run restart", "not an HDF5 file"),
             (["input/circle2d.nml", f"run.restart={bare}"], "&run restart", "missing attribute"),
             (["input/circle2d.nml", f"run.restart={junk.parent}"], "&run restart",
              "is a directory"),
             (recipe + [f"particles.from={junk}"], "&particles from", "not an HDF5 file"),
             (recipe + [f"particles.from={cut}"], "&particles from", "damaged"),
             (["input/circle2d_convergence.nml", "particles.n=1257",
               f"particles.from={packed / 'snap_00000.h5'}"], "&particles from",
              "set n to the file's count")]
    for args, variable, why in cases:
        p = run_sph(args + [f"output.dir={d}"], np=2)
        errors = [line for line in p.stderr.splitlines() if line.startswith("sph: error:")]
        assert p.returncode != 0 and len(errors) == 1, p.out
        assert variable in errors[0] and why in errors[0], errors
        assert "HDF5-DIAG" not in p.out and "mca_fbtl" not in p.out, p.out
        assert not d.exists()
    # the same file with its own count starts
    p = run_sph(["input/circle2d_convergence.nml", "particles.n=314", "run.max_steps=1",
                 f"particles.from={packed / 'snap_00000.h5'}", f"output.dir={d}"], np=2)
    assert p.returncode == 0, p.out


def _peak_mb(args, np_):
    p = run_sph(["input/ellipsoid3d.nml", "run.max_steps=2", "output.snapshots=.false.",
                 "particles.pack_iterations=20"] + args, np=np_)
    assert p.returncode == 0, p.out
    m = re.search(r"peak memory +([0-9.]+) MB per rank \(max\)", p.stdout)
    return float(m.group(1))


def test_distributed_setup_memory(scratch):
    # each rank generates only its share of the particles: the largest
    # rank's peak on P ranks is about twice its share of the one-rank peak
    # plus the fixed footprint of a rank (a run of 2,000 particles), the
    # bound of doc/developer/parallel.md.  Measured at 300,000 particles on 8 ranks
    # (the curve decomposition): 96.7 MB against a bound of 100.1 (one rank
    # 312.8, fixed 21.9); when every rank built all of them and kept a share,
    # 142.4.  The assertion allows 15 % for another machine's allocator.
    d = scratch("mem")
    fixed = _peak_mb(["particles.n=2000", f"output.dir={d / 'tiny'}"], 1)
    one = _peak_mb(["particles.n=300000", f"output.dir={d / 'one'}"], 1)
    eight = _peak_mb(["particles.n=300000", f"output.dir={d / 'eight'}"], 8)
    assert eight <= 1.15 * (2 * one / 8 + fixed), (eight, one, fixed)
