"""sphpost.particles: estimates from a set of particles: the pressure at a
point (D5), the fitted semi-axes (D2), the free surface's outline and its
measures."""
import math

import numpy as np


def wendland_weight(q):
    """The Wendland C2 kernel's shape (K1 up to its normalisation, which a
    weighted fit does not see): (1 - q/2)^4 (2q + 1) for q = r/h < 2."""
    q = np.asarray(q, float)
    return np.where(q < 2, (1 - q / 2)**4 * (2 * q + 1), 0.0)


def pressure_at(point, x, p, volume, h):
    """The pressure at `point` from the particles (x, p, volume V_j) by the
    quadratic least-squares fit of D5 (doc/theory/): q minimises
    Sum_j W(|x_j - point|/h) V_j (p_j - q(x_j))^2 over the particles within
    2h, evaluated at the point; exact for a quadratic pressure field such as
    the stretching patch's (X1).  With fewer than 3 (dim + 1) particles in
    the support, or a singular fit, the Shepard average D4; NaN with none."""
    d = x - np.asarray(point, float)
    r = np.sqrt(np.sum(d**2, axis=1))
    sel = r < 2 * h
    if not sel.any():
        return float("nan")
    w = wendland_weight(r[sel] / h) * volume[sel]
    dim = x.shape[1]
    xi = d[sel] / h
    cols = [np.ones(len(xi))] + [xi[:, k] for k in range(dim)] + \
        [xi[:, i] * xi[:, j] for i in range(dim) for j in range(i, dim)]
    basis = np.stack(cols, axis=1)
    if sel.sum() >= 3 * (dim + 1):
        a = basis.T @ (w[:, None] * basis)
        if np.linalg.cond(a) < 1e10:
            return float(np.linalg.solve(a, basis.T @ (w * p[sel]))[0])
    return float(np.sum(w * p[sel]) / np.sum(w))


def fitted_semi_axes(x, m):
    """(D2) Semi-axes from the mass-weighted second moments about the
    centre of mass: 2 sqrt(<(x_k - c_k)^2>) in 2D, sqrt(5 <...>) in 3D."""
    mt = np.sum(m)
    c = (m @ x) / mt
    var = np.maximum(0.0, (m @ x**2) / mt - c**2)
    return np.sqrt(var * (4.0 if x.shape[1] == 2 else 5.0))


def free_surface_outline(x, volume, dx, h=None, level=0.5):
    """The free surface of 2D particles as closed polylines: the `level`
    contour of the colour function C(x) = sum_j V_j W(|x - x_j|, h)
    (Wendland C2, support 2 h; default h = 2 dx), which is 1 inside a
    uniform arrangement and falls to 1/2 at its surface.  Sampled on a grid
    of dx / 2, traced by contourpy (matplotlib's contouring).  Returns the
    list of (k, 2) arrays, outer boundaries and holes alike."""
    h = 2.0 * dx if h is None else h
    x = np.asarray(x)[:, :2]
    g = dx / 2
    lo = x.min(axis=0) - 2.5 * h
    n = np.ceil((x.max(axis=0) + 2.5 * h - lo) / g).astype(int) + 1
    grid = np.zeros((n[1], n[0]))
    base = np.floor((x - lo) / g).astype(int)
    reach = int(math.ceil(2 * h / g)) + 1
    sigma = 7.0 / (4.0 * math.pi * h**2)
    for di in range(-reach, reach + 1):
        for dj in range(-reach, reach + 1):
            i, j = base[:, 0] + di, base[:, 1] + dj
            r = np.hypot(lo[0] + i * g - x[:, 0], lo[1] + j * g - x[:, 1]) / h
            w = np.where(r < 2, sigma * (1 - r / 2) ** 4 * (1 + 2 * r), 0.0)
            np.add.at(grid, (j, i), volume * w)
    return contour(lo[0], lo[1], g, grid, level)


def contour(x0, y0, dx, grid, level=0.5):
    """The `level` contour of a grid (grid[j, i] at x0 + i dx, y0 + j dx) as a
    list of (n, 2) polylines, traced by contourpy."""
    import contourpy
    ny, nx = grid.shape
    gen = contourpy.contour_generator(x0 + dx * np.arange(nx), y0 + dx * np.arange(ny), grid)
    return [np.asarray(c) for c in gen.lines(level) if len(c) > 1]


def outline_measures(lines):
    """Area enclosed (outer boundaries less holes, by the signed shoelace
    sums), perimeter and number of closed curves of an outline."""
    area = sum(0.5 * float(np.sum(ln[:-1, 0] * ln[1:, 1] - ln[1:, 0] * ln[:-1, 1]))
               for ln in lines)
    perim = sum(float(np.sum(np.hypot(*np.diff(ln, axis=0).T))) for ln in lines)
    return abs(area), perim, len(lines)
