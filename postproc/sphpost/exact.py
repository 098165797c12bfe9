"""sphpost.exact: the prototype problems' exact solutions, usable on their own.

Any particle code can check itself against these without running sph or
reading its files (doc/reference/postproc.md, "The exact solutions as a library"):

    from sphpost import exact
    s = exact.stretching([0.0, 1.0, 2.0])            # circle2d, R = A0 = rho = 1
    s.a[:, 0], s.P                                  # semi-axes, centre pressure
    exact.stretching(1.0, rates=(-1, -1, 2)).a      # the sphere (X2)
    exact.square_rotation_pressure(0.0, 0.0)        # p_A(0) = -0.147343 (X3)
    exact.square_vortical_pressure(0.25, 0.25)      # -0.229452 (X4)
    exact.compressibility_floor(t, c0=12.5)         # I2, the filtered error's floor

Lengths, rates and densities are whatever units the caller uses (R, A0,
rho; L, omega, V0): every formula is dimensionally consistent.  Each function
carries the label of its equation in doc/theory/ (X1-X4) or
doc/studies/numerics.md (I2).  exact_ellipse integrates the ODE of X1 and
centre_pressure_derivatives gives P', P''; the error measures use them
directly.
"""
import collections
import math

import numpy as np


__all__ = ["Stretching", "stretching", "stretching_velocity", "stretching_pressure",
           "lagrangian_map", "stretching_kinetic_energy", "compressibility_floor",
           "square_pressure_series", "square_rotation_pressure", "square_vortical_pressure",
           "square_rotation_kinetic_energy", "square_vortical_kinetic_energy",
           "square_vortical_velocity"]

def exact_ellipse(t, rates=(-1.0, 1.0), radius=1.0, rho=1.0):
    """Exact semi-axes a_k(t) (shape (len(t), dim)), rates alpha_k(t) and
    centre pressure P(t) of the stretching patch with alpha_k(0) = rates:
    a_k' = alpha_k a_k, alpha_k' = 2P/(rho a_k^2) - alpha_k^2,
    P/rho = Sum alpha_k^2 / (2 Sum 1/a_k^2).  Integrated by scipy's DOP853 to
    1e-12 relative."""
    from scipy.integrate import solve_ivp
    t = np.atleast_1d(np.asarray(t, dtype=float))
    rates = np.asarray(rates, dtype=float)
    d = len(rates)

    def rhs(_, s):
        a, al = s[:d], s[d:]
        p = np.sum(al**2) / (2 * np.sum(1 / a**2))
        return np.concatenate([al * a, 2 * p / a**2 - al**2])

    tt = np.unique(np.concatenate([[0.0], t]))
    if tt[-1] == 0:             # t = 0 alone: the initial state (no interval to integrate)
        tt = np.array([0.0, 1e-300])
    sol = solve_ivp(rhs, (0.0, tt[-1]), np.concatenate([np.full(d, radius), rates]),
                    t_eval=tt, rtol=1e-12, atol=1e-14, method="DOP853")
    idx = np.searchsorted(tt, t)
    a = sol.y[:d, idx].T
    al = sol.y[d:, idx].T
    p = rho * np.sum(al**2, axis=1) / (2 * np.sum(1 / a**2, axis=1))
    return a, al, p


def centre_pressure_derivatives(a, al, rho=1.0):
    """P(t), P'(t) and P''(t) of X1 from the semi-axes a and rates al
    (arrays (n, dim)): with P = rho N/D, N = Sum al^2, D = 2 Sum 1/a^2,
    a' = al a, al' = 2P/(rho a^2) - al^2 and
    al'' = 2P'/(rho a^2) - 4 P al/(rho a^2) - 2 al al',
    P' = rho (N' D - N D')/D^2,
    P'' = rho ((N'' D - N D'')/D^2 - 2 D' (N' D - N D')/D^3)."""
    a, al = np.atleast_2d(a), np.atleast_2d(al)
    n, d = np.sum(al**2, 1), 2 * np.sum(1 / a**2, 1)
    p = rho * n / d
    al1 = 2 * p[:, None] / (rho * a**2) - al**2
    n1, d1 = 2 * np.sum(al * al1, 1), -4 * np.sum(al / a**2, 1)
    p1 = rho * (n1 * d - n * d1) / d**2
    al2 = (2 * p1[:, None] - 4 * p[:, None] * al) / (rho * a**2) - 2 * al * al1
    n2 = 2 * np.sum(al1**2 + al * al2, 1)
    d2 = -4 * np.sum((al1 - 2 * al**2) / a**2, 1)
    p2 = rho * ((n2 * d - n * d2) / d**2 - 2 * d1 * (n1 * d - n * d1) / d**3)
    return p, p1, p2


def centre_pressure_accel(a, al, rho=1.0):
    """P''(t) of X1 from the semi-axes a and rates al (centre_pressure_derivatives)."""
    return centre_pressure_derivatives(a, al, rho)[2]


def compressibility_floor(t, rates=(-1.0, 1.0), radius=1.0, rho=1.0, c0=10.0):
    """(I2, doc/studies/numerics.md) The weakly compressible model's own departure
    of the centre pressure of the stretching patch (X1, initial rates
    `rates`) from the incompressible P(t), over P(0):
    delta p(0, t) = -P''(t) R^2 (dim + 4) / (4 dim (dim + 2) c0^2).  It
    falls as 1/c0^2 and is slow, so the low-pass filter keeps it: a floor
    of the filtered error at any resolution."""
    d = len(rates)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    a, al, _ = exact_ellipse(t, rates=rates, radius=radius, rho=rho)
    p0 = rho * np.sum(np.square(rates)) * radius**2 / (2 * d)
    p2 = centre_pressure_accel(a, al, rho)
    return -p2 * radius**2 * (d + 4) / (4 * d * (d + 2) * c0**2) / p0


Stretching = collections.namedtuple("Stretching", "t a alpha P dPdt d2Pdt2")
Stretching.__doc__ = """The stretching patch at the times t (X1): semi-axes a and
rates alpha (arrays (len(t), dim)), the centre pressure P(t) and its first two
time derivatives (arrays (len(t),))."""


def stretching(t, rates=(-1.0, 1.0), radius=1.0, rho=1.0):
    """(X1, X2) The stretching patch of initial radius R = radius and initial
    strain rates alpha_k(0) = rates (A0 included; they must sum to 0):
    a_k' = alpha_k a_k, alpha_k' = 2P/(rho a_k^2) - alpha_k^2,
    P/rho = Sum alpha_k^2 / (2 Sum 1/a_k^2), a_k(0) = R.  circle2d is
    rates (-A0, A0); ellipsoid3d A0 (-1, -1, 2).  Integrated by DOP853 to
    1e-12 relative (exact_ellipse); P' and P'' in closed form."""
    rates = tuple(float(r) for r in rates)
    if abs(sum(rates)) > 1e-12 * max(abs(r) for r in rates):
        raise ValueError(f"the rates {rates} must sum to 0 (an incompressible flow)")
    t = np.atleast_1d(np.asarray(t, dtype=float))
    a, al, p = exact_ellipse(t, rates=rates, radius=radius, rho=rho)
    _, p1, p2 = centre_pressure_derivatives(a, al, rho)
    return Stretching(t, a, al, p, p1, p2)


def stretching_velocity(x, alpha):
    """(X1) u_k = alpha_k(t) x_k at the points x (n, dim) about the centre,
    alpha the rates at one time (dim,)."""
    return np.asarray(x, float) * np.asarray(alpha, float)


def stretching_pressure(x, a, P):
    """(X1) p = P(t) (1 - Sum_k x_k^2/a_k^2) at the points x (n, dim), for
    the semi-axes a (dim,) and centre pressure P at one time; negative
    outside the ellipse (the exact field does not extend there)."""
    x = np.asarray(x, float)
    return P * (1 - np.sum(x**2 / np.asarray(a, float)**2, axis=1))


def lagrangian_map(x0, a, radius=1.0):
    """(X1) The exact path x_k(t) = x0_k a_k(t)/R of the particles that
    started at x0 (n, dim)."""
    return np.asarray(x0, float) * np.asarray(a, float) / radius


def stretching_kinetic_energy(alpha, a, radius=1.0, rho=1.0):
    """(X1) KE = rho V Sum_k alpha_k^2 a_k^2 / (2 (dim + 2)), V the patch's
    area pi R^2 or volume 4/3 pi R^3 (constant in time); alpha and a of one
    time (dim,) or of many ((n, dim) -> (n,))."""
    alpha, a = np.asarray(alpha, float), np.asarray(a, float)
    d = alpha.shape[-1]
    vol = math.pi * radius**2 if d == 2 else 4 / 3 * math.pi * radius**3
    return rho * vol * np.sum(alpha**2 * a**2, axis=-1) / (2 * (d + 2))


# ---------------------------------------------------------------------------
# The square patches: initial pressure by the double sine series (X3, X4, X5)
# ---------------------------------------------------------------------------

def _sine_coefficients(g, side, modes, nodes=None):
    """b_m = (2/L) Int_0^L g(x* - L/2) sin(m pi x*/L) dx*, m = 1..modes, by
    Gauss-Legendre quadrature (exact to round-off for the smooth g here)."""
    nodes = nodes or 4 * modes + 200
    z, w = np.polynomial.legendre.leggauss(nodes)
    xs = 0.5 * side * (z + 1)
    m = np.arange(1, modes + 1)
    return (2 / side) * 0.5 * side * (np.sin(np.outer(m, xs) * math.pi / side)
                                      @ (w * g(xs - side / 2)))


def square_pressure_series(x, y, g, amplitude, side=1.0, modes=400):
    """(X5) The solution of Laplacian p = amplitude g(x) g(y) on the square
    [-L/2, L/2]^2 with p = 0 on the edges, by the double sine series
    p = Sum_{m,n} amplitude b_m b_n / -(k_m^2 + k_n^2) sin(k_m x*) sin(k_n y*),
    k_m = m pi/L, x* = x + L/2, b_m the sine coefficients of g.  Both squares'
    right-hand sides are separable like this.  The terms fall as
    1/(m n (m^2 + n^2)) (the corners are singular), so `modes` = 400 gives
    about 6 digits."""
    x = np.atleast_1d(np.asarray(x, float))
    y = np.broadcast_to(np.asarray(y, float), x.shape)
    b = _sine_coefficients(g, side, modes)
    k = np.arange(1, modes + 1) * math.pi / side
    coef = amplitude * np.outer(b, b) / -(k[:, None]**2 + k[None, :]**2)
    out = np.empty(x.shape)
    flat_x, flat_y, flat_o = x.ravel(), y.ravel(), out.reshape(-1)
    for s in range(0, flat_x.size, 2000):             # bounded memory
        sx = np.sin(np.outer(flat_x[s:s + 2000] + side / 2, k))
        sy = np.sin(np.outer(flat_y[s:s + 2000] + side / 2, k))
        flat_o[s:s + 2000] = np.sum((sx @ coef) * sy, axis=1)
    return out


def square_rotation_pressure(x, y, side=1.0, omega=1.0, rho=1.0, modes=400):
    """(X3) The initial pressure of the rotating square (side L centred at
    the origin, u = omega y, v = -omega x): Laplacian p0 = 2 rho omega^2,
    p0 = 0 on the edges; p_A(0) = p0(0, 0) = -0.147343 rho omega^2 L^2."""
    return square_pressure_series(x, y, lambda s: np.ones_like(s), 2 * rho * omega**2, side,
                                  modes)


def square_vortical_pressure(x, y, side=1.0, v0=1.0, rho=1.0, modes=400):
    """(X4) The initial pressure of the vortical square: with
    f(s) = exp(-(4 s/L)^2), Laplacian p0 = 2 rho V0^2 f'(x) f'(y),
    p0 = 0 on the edges; p0(L/4, L/4) = -0.229452 rho V0^2."""
    def fprime(s):
        return -32 * s / side**2 * np.exp(-(4 * s / side)**2)
    return square_pressure_series(x, y, fprime, 2 * rho * v0**2, side, modes)


def square_vortical_velocity(x, y, side=1.0, v0=1.0):
    """(X4) The initial velocity u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4)."""
    def f(s):
        return np.exp(-(4 * np.asarray(s, float) / side)**2) - math.exp(-4)
    return v0 * f(y), -v0 * f(x)


def square_rotation_kinetic_energy(side=1.0, omega=1.0, rho=1.0):
    """(X3) KE0 = rho omega^2 L^4 / 12, kept by the exact flow."""
    return rho * omega**2 * side**4 / 12


def square_vortical_kinetic_energy(side=1.0, v0=1.0, rho=1.0):
    """(X4) KE0 = 1/2 rho Int (u^2 + v^2) = rho V0^2 L Int_{-L/2}^{L/2} (f - e^-4)^2 ds,
    kept by the exact (inviscid) flow."""
    z, w = np.polynomial.legendre.leggauss(200)
    s = 0.5 * side * z
    u, _ = square_vortical_velocity(0.0, s, side, v0)
    return rho * side * float(np.sum(w * u**2)) * 0.5 * side
