"""bem: the rotating square by a boundary-integral method, the reference the
paper compares with (its Figures 3 and 4), in the square's own units
(L = omega = rho = 1; doc/theory/solutions.md X7, doc/validation/reference.md).

The flow keeps its vorticity uniform (zeta = -2 omega: 2D, inviscid), so
that u = u_R + grad phi with u_R = (omega y, -omega x) and phi harmonic in
the fluid (X7).  On the free surface p = 0, so that by Euler (X7)

    D phi/Dt = u . grad phi - |u|^2/2 + 2 omega psi,   psi = omega |z|^2/2 + chi,

chi the harmonic conjugate of phi (w = phi + i chi analytic).  w is the
Cauchy integral of a real density mu over the surface (X7): its real part's
boundary values give a second-kind equation for mu, solved directly and
spectrally accurate by the trapezoid rule on the smooth closed curve; chi on
the surface and w at A follow from the same integral, so that the stream
function's gauge is the same everywhere.  The pressure at A comes from a
second Dirichlet problem with the same matrix (X7): phi_t is harmonic and
equals -|u|^2/2 + 2 omega psi on the surface (up to the constant of phi's
gauge, which cancels), so p_A = -(G(A) + |u_A|^2/2 - 2 omega psi(A)).

The surface is a closed curve of N Lagrangian nodes, 4-fold symmetric (the
solve runs on a quarter: N/4 unknowns), advanced by RK4.  Regularisation,
stated in every output's header: the corners rounded to the superellipse
|x|^n + |y|^n = (L/2)^n; a Fourier filter exp(-36 (k/k_max)^order) and
Krasny's threshold on the nodes and phi after each step; the nodes
redistributed every few steps by a density that follows the curvature and
the arms' width (doc/validation/reference.md).
"""
import functools
import math
import os

import numpy as np
import scipy.linalg as sla
from scipy.interpolate import CubicSpline

SYM = 4                 # the flow's 4-fold symmetry: a quarter holds the unknowns
ROT = np.exp(0.5j * math.pi * np.arange(SYM))     # the quarters' rotations


class Params:
    """The numerical settings of a boundary-integral run (doc/validation/reference.md)."""

    def __init__(self, nodes=1024, dt=0.0025, t_end=4.0, n_corner=24, filter_order=12,
                 filter_strength=36.0, krasny=1e-14, remap_every=5, kappa0=6.0,
                 gap_length=0.1, arc_factor=2.5, grading=0.1, out_dt=0.01,
                 surface_times=(0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0),
                 energy_tol=1e-6, ds_ref=4e-4):
        self.nodes, self.dt, self.t_end, self.n_corner = nodes, dt, t_end, n_corner
        self.filter_order, self.filter_strength, self.krasny = (filter_order, filter_strength,
                                                                krasny)
        self.remap_every, self.kappa0, self.gap_length = remap_every, kappa0, gap_length
        self.arc_factor, self.out_dt, self.surface_times = arc_factor, out_dt, surface_times
        self.grading = grading
        self.energy_tol = energy_tol
        self.ds_ref = ds_ref
        checks = (("nodes", nodes >= 64 and nodes % (2 * SYM) == 0,
                   f"a multiple of {2 * SYM}, at least 64"),
                  ("dt", 0 < dt <= out_dt and abs(out_dt / dt - round(out_dt / dt)) < 1e-9,
                   f"0 < dt <= {out_dt:g}, dividing {out_dt:g}"),
                  ("n_corner", n_corner >= 4 and n_corner % 2 == 0, "an even number >= 4"),
                  ("filter_order", filter_order >= 2, ">= 2"),
                  ("remap_every", remap_every >= 1, ">= 1"))
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"bem {name} = {getattr(self, name)!r}: allowed {allowed}")

    def as_dict(self):
        d = dict(vars(self))
        d["surface_times"] = list(self.surface_times)
        return d

    def header(self):
        """The regularisation in words, for the outputs' headers."""
        return (f"boundary-integral method, {self.nodes} nodes (4-fold symmetry), RK4 dt = "
                f"{self.dt:g}/omega times min(1, sqrt(ds_min/{self.ds_ref:g} L)); corners rounded: |x|^{self.n_corner} + |y|^"
                f"{self.n_corner} = (L/2)^{self.n_corner}; filter exp(-{self.filter_strength:g}"
                f" (k/k_max)^{self.filter_order}) and Krasny threshold {self.krasny:g} each "
                f"step; nodes redistributed every {self.remap_every} steps by the density "
                f"max(1 + |kappa|/{self.kappa0:g}, {self.gap_length:g} L/gap), the spacing "
                f"graded by {self.grading:g} per unit length; quadrature on a grid "
                f"{UPSAMPLE} times finer")


# ---------------------------------------------------------------------------
# The curve: a quarter of nodes, the whole by symmetry, spectral derivatives
# ---------------------------------------------------------------------------

def whole(q):
    """The whole closed curve's complex positions from a quarter's."""
    return (ROT[:, None] * q[None, :]).ravel()


def whole_scalar(q):
    """A scalar field on the whole curve from a quarter's (invariant)."""
    return np.tile(q, SYM)


def wavenumbers(n):
    return np.fft.fftfreq(n, 1.0 / n)


def d_alpha(f, order=1):
    """Spectral derivative of a periodic array in the parameter alpha in [0, 2 pi)."""
    k = wavenumbers(len(f))
    fk = np.fft.fft(f) * (1j * k) ** order
    if order % 2 == 1 and len(f) % 2 == 0:
        fk[len(f) // 2] = 0.0
    out = np.fft.ifft(fk)
    return out if np.iscomplexobj(f) else out.real


def spectral_filter(f, p):
    """The Fourier filter exp(-s (k/k_max)^order) and Krasny's threshold
    (coefficients below it, relative to the largest, set to zero)."""
    n = len(f)
    fk = np.fft.fft(f)
    k = np.abs(wavenumbers(n)) / (n // 2)
    fk *= np.exp(-p.filter_strength * k ** p.filter_order)
    fk[np.abs(fk) < p.krasny * np.abs(fk).max()] = 0.0
    out = np.fft.ifft(fk)
    return out if np.iscomplexobj(f) else out.real


def fourier_basis(n, alpha):
    """The matrix that evaluates the trigonometric interpolant of n periodic
    samples' coefficients (fourier_coefficients) at the parameters alpha."""
    k = wavenumbers(n)
    if n % 2 == 0:                  # the Nyquist mode split symmetrically
        k = np.append(k, n // 2)
        k[n // 2] = -n // 2
    return np.exp(1j * np.outer(np.asarray(alpha, dtype=float), k))


def fourier_coefficients(f):
    n = len(f)
    fk = np.fft.fft(f) / n
    if n % 2 == 0:
        fk = np.append(fk, 0.5 * fk[n // 2])
        fk[n // 2] *= 0.5
    return fk


def fourier_eval(f, alpha, basis=None):
    """The trigonometric interpolant of the periodic samples f at the
    parameters alpha (basis: fourier_basis(len(f), alpha), if at hand)."""
    if basis is None:
        basis = fourier_basis(len(f), alpha)
    out = basis @ fourier_coefficients(f)
    return out if np.iscomplexobj(f) else out.real


def upsample(f, factor):
    """The trigonometric interpolant of periodic samples on a grid `factor`
    times finer (zero padding)."""
    n = len(f)
    fk = np.fft.fft(f)
    big = np.zeros(factor * n, dtype=complex)
    h = n // 2
    big[:h] = fk[:h]
    big[-h + 1:] = fk[-h + 1:]
    big[h] = 0.5 * fk[h]
    big[-h] = 0.5 * fk[h]
    out = np.fft.ifft(big) * factor
    return out if np.iscomplexobj(f) else out.real


# ---------------------------------------------------------------------------
# The boundary integrals (X7)
# ---------------------------------------------------------------------------

UPSAMPLE = 2     # the quadrature's grid, finer than the nodes' (X7): 2 and 8 give chi
                # within 5e-12 on 1024 nodes at t omega = 1.6 (arms 4 spacings wide)


@functools.lru_cache(maxsize=1)
def upsampling_matrix(n, up, m):
    """The trigonometric interpolation from a quarter's m nodes (the whole
    curve's n = 4 m samples, invariant under the symmetry) to the up * n
    points of the finer grid: the Dirichlet kernel, summed over the
    quarters.  Depends on (n, up) only: the last one is kept."""
    x = 2 * math.pi * np.arange(up * n) / (up * n)
    y = x[:, None] - 2 * math.pi * np.arange(n)[None, :] / n
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.sin(0.5 * n * y) / (n * np.tan(0.5 * y))
    d[np.abs(np.sin(0.5 * y)) < 1e-14] = 1.0
    return d.reshape(up * n, SYM, m).sum(axis=1)


class Geometry:
    """The whole curve Z (N nodes, counter-clockwise), its interpolant on a
    grid UPSAMPLE times finer (the quadrature's: the trapezoid rule across
    an arm thinner than a few node spacings keeps its accuracy), and the
    Cauchy kernel between the quarter's nodes (rows) and the fine points."""

    def __init__(self, zq, up=UPSAMPLE):
        self.zq = zq
        self.m = len(zq)
        self.Z = whole(zq)
        self.n = len(self.Z)
        self.Za = d_alpha(self.Z)
        self.up = up
        Zf = upsample(self.Z, up)
        self.nf = len(Zf)
        self.Zf, self.Zaf = Zf, d_alpha(Zf)
        Zaa = d_alpha(Zf, 2)
        self.U = upsampling_matrix(self.n, up, self.m)
        D = Zf[None, :] - zq[:, None]
        idx = np.arange(self.m)
        D[idx, up * idx] = 1.0
        self.K = self.Zaf[None, :] / D
        # the limit zeta_alpha / (zeta - z0) - 1/(alpha - alpha0): its
        # imaginary part is the kernel's smooth diagonal
        self.K[idx, up * idx] = Zaa[up * idx] / (2 * self.Zaf[up * idx])
        # the double-layer equation on the quarter: phi = mu/2 + (1/Nf) Sum Im K mu_f
        A = (np.ascontiguousarray(self.K.imag) @ self.U) / self.nf
        A[idx, idx] += 0.5
        self.lu = sla.lu_factor(A)

    def density(self, phi_q):
        """The real density mu on the quarter whose Cauchy integral has the
        real part phi on the curve (X7)."""
        return sla.lu_solve(self.lu, phi_q)

    def conjugate(self, mu_q):
        """chi = Im w on the curve from the interior: -(1/Nf) Sum (mu_k - mu_j)
        Re K_jk over the fine points, the diagonal's limit mu_alpha (X7)."""
        muf = self.U @ mu_q
        idx = np.arange(self.m)
        S = (muf[None, :] - mu_q[:, None]) * self.K.real
        S[idx, self.up * idx] = d_alpha(muf)[self.up * idx]
        return -S.sum(axis=1) / self.nf

    def interior(self, mu_q, z):
        """w and w' at an interior point z from the density (X7)."""
        MU = whole_scalar(mu_q)
        d = self.Z - z
        w = np.sum(MU * self.Za / d) / (1j * self.n)
        dw = np.sum(MU * self.Za / d**2) / (1j * self.n)
        return w, dw

    def harmonic_at(self, g_q, z):
        """The harmonic function with the boundary values g, at the interior
        point z."""
        nu = self.density(g_q)
        return float(np.real(self.interior(nu, z)[0]))


def surface_state(zq, phiq, omega=1.0):
    """Everything one state of the surface gives: the velocity U = u + i v
    at the nodes, D phi/Dt, chi, and the geometry (X7)."""
    g = Geometry(zq)
    mu = g.density(phiq)
    chi = g.conjugate(mu)
    W = whole_scalar(phiq + 1j * chi)
    dw = (d_alpha(W) / g.Za)[:g.m]                  # w' = w_alpha / z_alpha
    U = np.conj(dw) - 1j * omega * zq               # grad phi + u_R
    psi = 0.5 * omega * np.abs(zq) ** 2 + chi
    dphi = np.real(U * dw) - 0.5 * np.abs(U) ** 2 + 2 * omega * psi
    return g, mu, chi, U, dphi


def pressure_at(g, mu, chi, U, zq, a=0.0j, omega=1.0):
    """The pressure at the interior point a, in rho omega^2 L^2 (X7)."""
    w, dw = g.interior(mu, a)
    ua = np.conj(dw) - 1j * omega * a
    psi_a = 0.5 * omega * abs(a) ** 2 + w.imag
    gb = -0.5 * np.abs(U) ** 2 + 2 * omega * (0.5 * omega * np.abs(zq) ** 2 + chi)
    G = g.harmonic_at(gb, a)
    return -(G + 0.5 * abs(ua) ** 2 - 2 * omega * psi_a)


def integrals(g, phiq, chi, omega=1.0):
    """The area and the kinetic energy (rho = 1) by boundary integrals:
    KE = (omega^2 int r^2 + 2 omega oint phi d(r^2/2) + oint phi d chi)/2."""
    Z, Za = g.Z, g.Za
    h = 2 * math.pi / g.n
    xn = np.imag(np.conj(Z) * Za)                   # x dy - y dx per d alpha
    area = 0.5 * h * xn.sum()
    r2 = np.abs(Z) ** 2
    P = whole_scalar(phiq)
    X = whole_scalar(chi)
    ir2 = 0.25 * h * np.sum(r2 * xn)
    cross = h * np.sum(P * 0.5 * d_alpha(r2))
    grad2 = h * np.sum(P * d_alpha(X))
    return area, 0.5 * (omega**2 * ir2 + 2 * omega * cross + grad2)


# ---------------------------------------------------------------------------
# The nodes: the initial curve and the redistribution (doc/validation/reference.md)
# ---------------------------------------------------------------------------

def curvature(Z):
    za, zaa = d_alpha(Z), d_alpha(Z, 2)
    return np.imag(np.conj(za) * zaa) / np.abs(za) ** 3


def arc_length(Z):
    """The cumulative arc length at the nodes (spectral), and the perimeter."""
    s_a = np.abs(d_alpha(Z))
    return cumulative(s_a), s_a.mean() * 2 * math.pi


def cumulative(f_a):
    """int_0^alpha f d alpha at the nodes alpha_j = 2 pi j/N (spectral)."""
    n = len(f_a)
    k = wavenumbers(n)
    fk = np.fft.fft(f_a)
    mean = fk[0].real / n
    fk[0] = 0.0
    kk = np.where(k == 0, 1.0, k)
    gk = fk / (1j * kk)
    gk[0] = 0.0
    if n % 2 == 0:
        gk[n // 2] = 0.0
    g = np.fft.ifft(gk).real
    alpha = 2 * math.pi * np.arange(n) / n
    return mean * alpha + g - g[0]


def arm_gap(Z, s, perimeter, arc_factor, m, chunk=512):
    """For the first m nodes, the distance to the nearest node across the
    fluid: among the nodes farther along the curve than arc_factor times
    their distance (the arm's other side), the nearest; inf without one."""
    out = np.empty(m)
    for a in range(0, m, chunk):
        b = min(m, a + chunk)
        d = np.abs(Z[None, :] - Z[a:b, None])
        ds = np.abs(s[None, :] - s[a:b, None])
        ds = np.minimum(ds, perimeter - ds)
        out[a:b] = np.where(ds > arc_factor * d, d, np.inf).min(axis=1)
    return out


def graded(h, s, perimeter, slope):
    """min_i (h_i + slope |s - s_i|) on the closed curve (arc length s):
    two sweeps each way, twice around."""
    n = len(h)
    h = h.copy()
    ds = np.diff(np.append(s, s[0] + perimeter))
    for _ in range(2):
        for j in range(1, 2 * n):
            a, b = (j - 1) % n, j % n
            h[b] = min(h[b], h[a] + slope * ds[a])
        for j in range(2 * n - 2, -1, -1):
            a, b = (j + 1) % n, j % n
            h[b] = min(h[b], h[a] + slope * ds[b])
    return h


def node_density(Z, p):
    """The node density along the whole curve (doc/validation/reference.md): max(1 + |kappa|/kappa0,
    gap_length/gap), smoothed (a redistribution's parameter must stay a
    smooth function of the node index)."""
    n = len(Z)
    s, per = arc_length(Z)
    kap = np.abs(curvature(Z))
    gap = whole_scalar(arm_gap(Z, s, per, p.arc_factor, n // SYM))
    f = np.maximum(1 + kap / p.kappa0, p.gap_length / gap)
    # graded: the spacing h = 1/f grows at most by p.grading per unit of arc
    # length away from a fine spot (a needle tip's density would otherwise
    # jump by two orders within a few nodes)
    c = np.sum(f * np.abs(np.diff(np.append(Z, Z[0])))) / n    # arc length per unit of 1/f
    h = graded(1.0 / f, s, per, p.grading / c)
    f = 1.0 / h
    # a low-pass of the density: keep the modes below N/16
    fk = np.fft.fft(f)
    k = np.abs(wavenumbers(n)) / (n / 16)
    fk *= np.exp(-k**4)
    return np.maximum(np.fft.ifft(fk).real, 0.5)


def redistribute(zq, phiq, p, m_new):
    """New nodes (m_new per quarter) equally spaced in the node density's
    measure, z and phi by their trigonometric interpolants."""
    Z = whole(zq)
    n = len(Z)
    g = node_density(Z, p) * np.abs(d_alpha(Z))     # the measure per d alpha
    # its integral F(alpha) on a grid 8 times finer (the interpolant of g,
    # kept positive, by the trapezoid rule), inverted by a cubic spline
    fine = np.maximum(upsample(g, 8), 1e-3 * g.mean())
    af = 2 * math.pi * np.arange(8 * n + 1) / (8 * n)
    Ff = np.concatenate(([0.0], np.cumsum(0.5 * (fine + np.roll(fine, -1)))))
    Ff *= af[1]
    total = Ff[-1]
    target = total * np.arange(m_new) / (SYM * m_new)
    anew = CubicSpline(Ff, af)(target)
    # one Newton step on the spectral F: the spline's error (about 1e-13)
    # would seed the unstable surface with noise far above the round-off
    alpha = 2 * math.pi * np.arange(n) / n
    mean = g.mean()
    E = fourier_basis(n, anew)
    F = mean * anew + fourier_eval(cumulative(g) - mean * alpha, anew, E)
    anew = anew - (F - target) / fourier_eval(g, anew, E)
    E = fourier_basis(n, anew)
    znew = fourier_eval(Z, anew, E)
    pnew = fourier_eval(whole_scalar(phiq), anew, E)
    return znew, pnew


def initial_curve(p, oversample=8):
    """The rounded square |x|^n + |y|^n = (1/2)^n (side 1, centred at A,
    counter-clockwise), phi = 0 (rigid rotation), on the node density."""
    m_fine = oversample * p.nodes // SYM
    th = 0.5 * math.pi * np.arange(m_fine) / m_fine
    n = p.n_corner
    r = 0.5 / (np.cos(th) ** n + np.sin(th) ** n) ** (1.0 / n)
    zq = r * np.exp(1j * th)
    phq = np.zeros(m_fine)
    return redistribute(zq, phq, p, p.nodes // SYM)


# ---------------------------------------------------------------------------
# The run: RK4 in time, the series and surfaces recorded
# ---------------------------------------------------------------------------

def tip(zq):
    """The arm tip (the node farthest from A, refined by the interpolant):
    its radius and the curvature there."""
    Z = whole(zq)
    k = int(np.argmax(np.abs(Z)))
    n = len(Z)
    a0 = 2 * math.pi * k / n
    a = a0 + (2 * math.pi / n) * np.linspace(-1, 1, 41)
    r = np.abs(fourier_eval(Z, a))
    j = int(np.argmax(r))
    kap = fourier_eval(curvature(Z), a[j:j + 1])[0]
    return float(r[j]), float(kap)


def step(zq, phq, dt, omega=1.0):
    """One RK4 step of the nodes and phi (X7)."""
    def f(z, ph):
        _, _, _, U, dphi = surface_state(z, ph, omega)
        return U, dphi
    k1 = f(zq, phq)
    k2 = f(zq + 0.5 * dt * k1[0], phq + 0.5 * dt * k1[1])
    k3 = f(zq + 0.5 * dt * k2[0], phq + 0.5 * dt * k2[1])
    k4 = f(zq + dt * k3[0], phq + dt * k3[1])
    z = zq + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
    ph = phq + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return z, ph


def smooth(zq, phq, p):
    """The filter on the whole curve, back to the quarter."""
    m = len(zq)
    return (spectral_filter(whole(zq), p)[:m], spectral_filter(whole_scalar(phq), p)[:m])


class Record:
    """What a run leaves: the series every out_dt and the surfaces."""

    def __init__(self):
        self.t, self.p, self.area, self.ke, self.tip_r, self.tip_k = ([] for _ in range(6))
        self.surfaces = {}
        self.clean_until = 0.0
        self.stop_reason = None
        self.steps = 0
        self.dt_min = math.inf


def run(p, echo=print, progress=30.0):
    """The rotating square (L = omega = rho = 1) from t = 0 to p.t_end, or
    until the area or the kinetic energy drifts by more than p.energy_tol
    (relative): the run is then no longer clean (the surface's
    Rayleigh-Taylor instability has amplified the round-off) and stops."""
    import time
    zq, phq = initial_curve(p)
    rec = Record()
    nsub0 = int(round(p.out_dt / p.dt))
    n_out = int(round(p.t_end / p.out_dt))
    surf = {int(round(ts / p.out_dt)): ts for ts in p.surface_times}
    a0 = ke0 = None
    t_wall = time.time()
    last = t_wall
    for k in range(n_out + 1):
        if k > 0:
            # the step: p.dt, times sqrt(ds_min/ds_ref) once the nodes come
            # closer than ds_ref (the shortest surface waves' frequency
            # sqrt(g k) grows as the tips sharpen and the nodes crowd there:
            # RK4 must stay within its stability limit); it divides out_dt
            Z = whole(zq)
            ds_min = float(np.min(np.abs(np.diff(np.append(Z, Z[0])))))
            dt = p.dt * min(1.0, math.sqrt(ds_min / p.ds_ref))
            nsub = max(nsub0, math.ceil(p.out_dt / dt - 1e-9))
            rec.dt_min = min(rec.dt_min, p.out_dt / nsub)
            for _ in range(nsub):
                zq, phq = step(zq, phq, p.out_dt / nsub)
                zq, phq = smooth(zq, phq, p)
                rec.steps += 1
                if rec.steps % p.remap_every == 0:
                    zq, phq = redistribute(zq, phq, p, len(zq))
        t = k * p.out_dt
        g, mu, chi, U, _ = surface_state(zq, phq)
        pa = pressure_at(g, mu, chi, U, zq)
        area, ke = integrals(g, phq, chi)
        if a0 is None:
            a0, ke0 = area, ke
        drift = max(abs(area / a0 - 1), abs(ke / ke0 - 1))
        if not np.isfinite(pa) or not drift <= p.energy_tol:
            rec.stop_reason = (f"at t omega = {t:.2f} the area or the kinetic energy drifted by "
                               f"{drift:.2e} (more than {p.energy_tol:g})")
            break
        r, kap = tip(zq)
        for lst, v in ((rec.t, t), (rec.p, pa), (rec.area, area), (rec.ke, ke),
                       (rec.tip_r, r), (rec.tip_k, kap)):
            lst.append(v)
        rec.clean_until = t
        if k in surf:
            rec.surfaces[surf[k]] = whole(zq)
        now = time.time()
        if echo and (now - last > progress or k == n_out):
            last = now
            el = now - t_wall
            eta = el / max(k, 1) * (n_out - k)
            echo(f"  t omega = {t:.2f}  p_A = {pa:.7f}  drift {drift:.1e}  "
                 f"{el:.0f} s, about {eta:.0f} s left")
    rec.wall = time.time() - t_wall
    if rec.stop_reason is None:
        rec.stop_reason = f"reached t omega = {rec.clean_until:g}"
    return rec


# ---------------------------------------------------------------------------
# A reference run directory, in postproc/reference's layout
# ---------------------------------------------------------------------------

class BemSetup:
    """A boundary-integral reference's flow and settings: the attributes the
    comparisons read from a reference (postproc/reference's Setup)."""

    method = "bem"

    def __init__(self, case, side, rate, rho0, t_end, params):
        if case != "square_rotation":
            raise ValueError(f"case '{case}': the boundary-integral method applies to "
                             "square_rotation only (uniform vorticity)")
        self.case, self.side, self.rate, self.rho0, self.t_end = case, side, rate, rho0, t_end
        self.params = params if isinstance(params, Params) else Params(**params)

    @property
    def resolution(self):
        return self.params.nodes

    @property
    def dx(self):
        """The nodes' mean initial spacing, in L (a length scale for the
        surfaces' resampling)."""
        return 4.0 / self.params.nodes

    @property
    def label(self):
        return f"boundary integrals, {self.params.nodes} nodes"

    @property
    def probe(self):
        return (0.0, 0.0)

    @property
    def p_unit(self):
        return self.rho0 * (self.rate * self.side) ** 2

    @property
    def time_unit(self):
        return 1.0 / self.rate

    def as_dict(self):
        return {"method": self.method, "case": self.case, "side": self.side, "rate": self.rate,
                "rho0": self.rho0, "t_end": self.t_end, "params": self.params.as_dict()}


def write_run(rec, setup, out_dir, p0_series):
    """The run's files (doc/validation/reference.md, "What a reference run writes"):
    pressure.csv, integrals.csv, tips.csv, interface_T.csv, setup.json and
    summary.json, each written completely or not at all; a '#' line first
    in each CSV states the method and its regularisation."""
    import json
    import os
    from .reference import write_csv
    os.makedirs(out_dir, exist_ok=True)
    head = "# " + setup.params.header() + "; units L, 1/omega, rho omega^2 L^2"
    t = np.asarray(rec.t)
    # 12 digits: the invariants' drift (1e-11 while a run is clean) shows
    write_csv(os.path.join(out_dir, "pressure.csv"), ("t", "p"), zip(t, rec.p),
              comment=head, digits=12)
    write_csv(os.path.join(out_dir, "integrals.csv"), ("t", "area", "kinetic_energy"),
              zip(t, rec.area, rec.ke), comment=head, digits=12)
    write_csv(os.path.join(out_dir, "tips.csv"), ("t", "radius", "curvature"),
              zip(t, rec.tip_r, rec.tip_k), comment=head, digits=12)
    for ts, Z in rec.surfaces.items():
        # the nodes and the midpoints of their interpolant: a polyline within
        # a sixteenth of the nodes' chord error of the curve
        Zc = upsample(Z, SURFACE_UPSAMPLE)
        Zc = np.append(Zc, Zc[:1])                  # closed
        write_csv(os.path.join(out_dir, f"interface_{ts:g}.csv"), ("piece", "x", "y"),
                  ((0, float(z.real), float(z.imag)) for z in Zc), comment=head,
                  digits=10)
    area = np.asarray(rec.area)
    ke = np.asarray(rec.ke)
    summary = {"method": "bem", "header": setup.params.header(),
               "p_probe_initial": float(rec.p[0]),
               "p_probe_initial_error": float(rec.p[0] / p0_series - 1),
               "area_drift_max": float(np.max(np.abs(area / area[0] - 1))),
               "kinetic_energy_drift_max": float(np.max(np.abs(ke / ke[0] - 1))),
               "kinetic_energy_change_end": float(ke[-1] / ke[0] - 1),
               "clean_until": float(rec.clean_until), "stop_reason": rec.stop_reason,
               "surface_times": sorted(float(s) for s in rec.surfaces),
               "steps": rec.steps, "dt_min": float(rec.dt_min),
               "wall_time_s": float(rec.wall)}
    if rec.clean_until < setup.t_end - 1e-9:
        summary["partial_until"] = float(rec.clean_until)
    for name, obj in (("setup.json", setup.as_dict()), ("summary.json", summary)):
        tmp = os.path.join(out_dir, name + ".tmp")
        with open(tmp, "w") as f:
            json.dump(obj, f, indent=1)
        os.replace(tmp, os.path.join(out_dir, name))
    return summary


def pair_gap(a, b, tol=1e-4):
    """Two boundary-integral references (sphpost.reference.Reference)
    against each other: the largest |p_A difference| in |p_A(0)| over their
    common interval and the time up to which it stays within tol; the
    surfaces' largest distance (in L) and the tips' radius difference at
    their common surface times."""
    from .reference import curve_distance, tip_radius
    end = min(a.pressure["t"][-1], b.pressure["t"][-1])
    t, d = _p_gap(a, b, end)
    bad = np.nonzero(d > tol)[0]
    within = float(end) if not len(bad) else float(t[max(bad[0] - 1, 0)])
    surf = {}
    for t in sorted(set(a.interface_times()) & set(b.interface_times())):
        ca, cb = a.interface(t), b.interface(t)
        # resampled at 2e-5 L: the point-to-point distance's own floor is half of it
        mean, largest = curve_distance(ca, cb, ds=2e-5)
        surf[t] = (largest, tip_radius(ca) - tip_radius(cb), mean)
    return {"end": float(end), "p_max": float(d.max()), "within": within, "surfaces": surf}


def study(dirs, echo=print, tol=1e-4):
    """The boundary-integral reference's resolution study (markdown): each
    run; the runs with the finest run's step and regularisation against it
    (the nodes' convergence, and the interval where the two finest agree);
    each run that differs in its step, corners or filter against the run of
    the same nodes without that difference (the regularisation's effect)."""
    from .reference import Reference
    refs = [Reference(d) for d in dirs]
    for r in refs:
        if r.setup.method != "bem":
            raise ValueError(f"'{r.path}' is not a boundary-integral reference")
    reg = ("dt", "n_corner", "filter_order")
    key = lambda r: (r.setup.params.nodes, -r.setup.params.dt)     # noqa: E731
    bp = max(refs, key=key).setup.params           # the regularisation compared against
    name = lambda r: os.path.basename(r.path.rstrip("/"))           # noqa: E731
    echo("| run | nodes | dt omega | corners n | filter order | p_A(0) against the series | "
         "largest area drift | largest KE drift | clean until t omega | steps | wall time |")
    echo("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(refs, key=key):
        p, sm = r.setup.params, r.summary
        echo(f"| {name(r)} | {p.nodes} | {p.dt:g} | {p.n_corner} | {p.filter_order} | "
             f"{100 * sm['p_probe_initial_error']:+.4f} % | {sm['area_drift_max']:.1e} | "
             f"{sm['kinetic_energy_drift_max']:.1e} | {sm['clean_until']:.2f} | {sm['steps']} | "
             f"{sm['wall_time_s']:.0f} s |")
    standard = lambda r: all(getattr(r.setup.params, k) == getattr(bp, k)   # noqa: E731
                             for k in reg)
    std = sorted((r for r in refs if standard(r)), key=key)
    pairs = list(zip(std[:-1], std[1:]))          # each node count against the next
    for r in sorted(refs, key=key):
        if not standard(r):
            same = [q for q in refs if standard(q) and q.setup.params.nodes == r.setup.params.nodes]
            if same:
                pairs.append((r, same[0]))
    times = sorted({t for r in refs for t in r.interface_times()})
    echo(f"\nEach run against another: the largest |p_A difference| over their common interval "
         f"in % of |p_A(0)|, the time up to which it stays within {100 * tol:g} %, and at each "
         "surface time the surfaces' largest / mean distance in L (the tips' radius "
         "difference):\n")
    echo("| run | against | differs in | common end | p_A largest | within tolerance to | "
         + " | ".join(f"surface {t:g}" for t in times) + " |")
    echo("|---|---|---|---|---|---|" + "---|" * len(times))
    out = []
    for r, o in pairs:
        p, op = r.setup.params, o.setup.params
        what = [f"{k} {getattr(p, k):g} / {getattr(op, k):g}" for k in ("nodes",) + reg
                if getattr(p, k) != getattr(op, k)]
        g = pair_gap(r, o, tol)
        cells = ["{:.1e} / {:.1e} ({:+.1e})".format(*(g["surfaces"][t][k] for k in (0, 2, 1)))
                 if t in g["surfaces"] else "" for t in times]
        echo(f"| {name(r)} | {name(o)} | {', '.join(what)} | {g['end']:.2f} | "
             f"{100 * g['p_max']:.1e} % | {g['within']:.2f} | " + " | ".join(cells) + " |")
        out.append({"run": r.path, "against": o.path, "differs": what,
                    **{k: v for k, v in g.items() if k != "surfaces"},
                    "surfaces": {f"{t:g}": v for t, v in g["surfaces"].items()}})
    res = {"pairs": out}
    # the interval of convergence: where two successive node counts agree;
    # the reference is the finer run of the pair that agrees longest (a
    # finer run can end sooner: the instability grows its round-off faster)
    best = None
    for o in out[:len(std) - 1]:
        bad = [float(t) for t, (d, _, _) in o["surfaces"].items() if d > SURFACE_TOL]
        until = min([o["within"]] + [t - 0.5 for t in bad])     # the surface before
        if best is None or until >= best[0]:
            best = (until, o)
    if best is not None:
        until, g = best
        coarse, base = Reference(g["run"]), Reference(g["against"])
        surf = [d for t, (d, _, _) in g["surfaces"].items() if float(t) <= until + 1e-9]
        res.update({"base": base.path, "converged_until": float(until),
                    "nodes": [coarse.setup.params.nodes, base.setup.params.nodes],
                    "p_max": float(_p_gap(coarse, base, until)[1].max()),
                    "surface_max": float(max(surf)) if surf else float("nan")})
        nxt, bp = coarse, base.setup.params
        echo(f"\nConverged (p_A within {100 * tol:g} % of |p_A(0)| and the surfaces within "
             f"{SURFACE_TOL:g} L between {nxt.setup.params.nodes} and {bp.nodes} nodes) over "
             f"t omega in [0, {until:g}]: there p_A differs by at most "
             f"{100 * res['p_max']:.1e} % and the surfaces by {res['surface_max']:.1e} L.")
    return res


SHIPPED_README = """# The rotating square by boundary integrals

The incompressible, inviscid rotating square of Le Touze & Colagrossi's prototype problem 2
(side L, omega, rho; L = omega = rho = 1 here), computed by `postproc/reference bem`
(sphpost.bem; the equations: doc/theory/solutions.md X7, the method and its study:
doc/validation/reference.md):

    {header}

Converged over t omega in [0, {until:g}]: the runs with {nodes[0]} and {nodes[1]} nodes
differ there by at most {p_max:.1e} % of |p_A(0)| in p_A and {s_max:.1e} L in the free
surface (study.md, study.json). The files hold this interval only: `pressure.csv` (p_A every
0.01), `integrals.csv` (area, kinetic energy), `tips.csv` (the arm tips' radius and
curvature), `interface_T.csv` (the free surface, a closed polyline), `setup.json`,
`summary.json`; units L, 1/omega, rho omega^2 L^2.

Regenerate it: `make reference-bem` (the study's runs into runs/reference/square_rotation/,
then `postproc/reference bem-study ... --ship postproc/sphpost/data/square_rotation_bem`).
Compare a run with it: `postproc/errors --case square_rotation RUN --reference bem`.
"""

SURFACE_TOL = 1e-4      # the surfaces' bar for convergence, in L
SURFACE_UPSAMPLE = 2    # points written per node on the surfaces


def _p_gap(a, b, until):
    """|p_A of a - p_A of b| in |p_A(0)| at a's times up to `until`: (t, d)."""
    t = a.pressure["t"]
    sel = t <= until + 1e-9
    d = np.abs(a.pressure["p"][sel] - np.interp(t[sel], b.pressure["t"], b.pressure["p"]))
    return t[sel], d / abs(a.pressure["p"][0])


def ship(ref_dir, out_dir, res, study_text):
    """The reference as shipped with the package: the run's files cut at
    the interval of convergence, and the study (study.json, study.md)."""
    import json
    import shutil
    from .reference import read_csv, write_csv
    until = res["converged_until"]
    tmp = out_dir.rstrip("/") + ".tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(tmp)
    for name in sorted(os.listdir(ref_dir)):
        src = os.path.join(ref_dir, name)
        m = name.startswith("interface_") and float(name[10:-4]) > until + 1e-9
        if m or not (name.endswith(".csv") or name.endswith(".json")):
            continue
        if name in ("pressure.csv", "integrals.csv", "tips.csv"):
            with open(src) as f:
                comment = f.readline().rstrip("\n")
            d = read_csv(src)
            keep = d["t"] <= until + 1e-9
            cols = list(d)
            write_csv(os.path.join(tmp, name), cols, zip(*(d[c][keep] for c in cols)),
                      comment=comment, digits=12)
        else:
            shutil.copy(src, tmp)
    with open(os.path.join(tmp, "summary.json")) as f:
        sm = json.load(f)
    sm["converged_until"] = until
    for name, obj in (("summary.json", sm), ("study.json", res)):
        with open(os.path.join(tmp, name), "w") as f:
            json.dump(obj, f, indent=1)
    with open(os.path.join(tmp, "study.md"), "w") as f:
        f.write(study_text)
    with open(os.path.join(tmp, "README.md"), "w") as f:
        f.write(SHIPPED_README.format(header=sm["header"], until=until, nodes=res["nodes"],
                                      p_max=100 * res["p_max"], s_max=res["surface_max"]))
    shutil.rmtree(out_dir, ignore_errors=True)
    os.replace(tmp, out_dir)
