"""The convergent recipe (input/circle2d_convergence.nml, doc/convergence.md
S1) converges when particles.n alone changes: three short levels, some
ten seconds in all."""
import math

from common import read_timeseries, run_sph

LEVELS = (314, 1257, 5027)


def time_mean(t, e):
    """Trapezoidal time average of |e| over the run."""
    area = sum(0.5 * (abs(e[k]) + abs(e[k + 1])) * (t[k + 1] - t[k]) for k in range(len(t) - 1))
    return area / (t[-1] - t[0])


def test_recipe_velocity_order(scratch):
    # circle2d_convergence to t A0 = 1 at 314, 1,257 and 5,027 particles
    # (h/dx 1.41, 2, 2.83; c0 8.8, 12.5, 17.7; alpha 0.008; the
    # reconstructed viscosity, Antuono's diffusion): time-mean RMS velocity
    # error measured 0.495, 0.161, 0.086 % of A0 R, orders 1.62 and 0.91
    # between the levels (the recipe before the reconstructed viscosity:
    # 0.475, 0.237, 0.134 % to t A0 = 0.5, orders 1.00 and 0.82).  The
    # issue's bar: at least 0.8, by least squares and at each step.
    dx, err = [], []
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
        err.append(time_mean(ts["time"], ts["rms_velocity_error"]))
    steps = [math.log(err[k] / err[k + 1]) / math.log(dx[k] / dx[k + 1]) for k in range(2)]
    lx = [math.log(v) for v in dx]
    ly = [math.log(v) for v in err]
    mx, my = sum(lx) / 3, sum(ly) / 3
    slope = sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)
    print(f"    velocity errors {[f'{100 * e:.3f} %' for e in err]}, orders "
          f"{[f'{s:.2f}' for s in steps]}, least squares {slope:.2f}")
    assert slope >= 0.8 and min(steps) >= 0.8, (err, steps, slope)
