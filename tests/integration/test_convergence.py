"""The convergent recipe (input/circle2d_convergence.nml, doc/studies/convergence.md
S1) converges when particles.n alone changes: three short levels, some
ten seconds in all."""
import math

from common import read_timeseries, run_sph

LEVELS = (314, 1257, 5027)


def time_mean(t, e):
    """Trapezoidal time average of |e| over the run."""
    area = sum(0.5 * (abs(e[k]) + abs(e[k + 1])) * (t[k + 1] - t[k]) for k in range(len(t) - 1))
    return area / (t[-1] - t[0])


def orders(dx, err):
    """Observed orders between successive levels, and by least squares."""
    steps = [math.log(err[k] / err[k + 1]) / math.log(dx[k] / dx[k + 1])
             for k in range(len(dx) - 1)]
    lx = [math.log(v) for v in dx]
    ly = [math.log(v) for v in err]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    slope = sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)
    return steps, slope


def test_recipe_velocity_and_energy_orders(scratch):
    # circle2d_convergence to t A0 = 1 at 314, 1,257 and 5,027 particles
    # (h/dx 1.41, 2, 2.83; c0 7.4, 12.5, 21.0; alpha 0.008; the adjoint
    # pressure gradient H2, the reconstructed viscosity, Antuono's
    # diffusion), on one rank: time-mean RMS velocity error measured 0.991,
    # 0.434, 0.136 % of A0 R (orders 1.19 and 1.68, least squares 1.44);
    # time-mean kinetic-energy error 0.149, 0.061, 0.022 % (orders 1.27
    # and 1.46, least squares 1.37).  The bar for the quick check is
    # 0.8; asserted here: at least 1, by least squares and at each step.
    dx, vel, ke = [], [], []
    for n in LEVELS:
        d = scratch(f"conv{n}") / "run"
        p = run_sph(["input/circle2d_convergence.nml", f"particles.n={n}", "run.t_end=1.0",
                     "output.snapshots=.false.", f"output.dir={d}"])
        assert p.returncode == 0, p.out
        assert "resolution scaling from n_ref" in p.stdout, p.stdout
        n_real = int(p.stdout.split("particles ")[1].split()[0])
        ts = read_timeseries(d / "timeseries.csv")
        assert abs(ts["time"][-1] - 1.0) < 1e-12
        dx.append(math.sqrt(math.pi / n_real))
        vel.append(time_mean(ts["time"], ts["rms_velocity_error"]))
        ke.append(time_mean(ts["time"], [a / b - 1 for a, b in zip(ts["kinetic_energy"],
                                                                 ts["kinetic_energy_exact"])]))
    for name, err in (("velocity", vel), ("kinetic energy", ke)):
        steps, slope = orders(dx, err)
        print(f"    {name} errors {[f'{100 * e:.3f} %' for e in err]}, orders "
              f"{[f'{s:.2f}' for s in steps]}, least squares {slope:.2f}")
        assert slope >= 1 and min(steps) >= 1, (name, err, steps, slope)
