"""sphpost.cases: the four prototype problems, under the solver's case
names, with their scales and the lowest acoustic frequency (doc/theory/
X6); their exact solutions are sphpost.exact.

CASES is the registry: for each case its dimension, the input group that
holds its parameters, its flow rate and length, the default speed of sound
of the shipped input (in the case's scale) and the probe point.  case_info
turns a parsed input.nml (or a foreign run's options) into a CaseInfo.
"""
import collections
import math

from .exceptions import PostprocError

Case = collections.namedtuple("Case", "name dim rate length speed c0 probe time_label")
Case.__doc__ = """A case of the registry: name (the solver's, &run case), dim, the
names of its flow rate, its length and its speed scale (rate x length), the
shipped input's c0 in that speed scale, the probe (in units of the length)
and how times are written."""

CASES = {c.name: c for c in (
    Case("circle2d", 2, "A0", "R", "A0 R", 10.0, (0.0, 0.0), "t A0"),
    Case("ellipsoid3d", 3, "A0", "R", "A0 R", 10.0, (0.0, 0.0, 0.0), "t A0"),
    Case("square_rotation", 2, "omega", "L", "omega L", 7.0, (0.0, 0.0), "t omega"),
    Case("square_vortical", 2, "V0/L", "L", "V0", 14.0, (0.25, 0.25), "t V0/L"))}

# the probe of each case (the shipped inputs'): the centre, A for the
# rotating square, (L/4, L/4) for the vortical one, in units of R or L
PROBES = {name: c.probe for name, c in CASES.items()}


# First zero of the Bessel function J0: the lowest Dirichlet (p = 0 on the
# free surface) acoustic mode of a disc of radius R is f = J0_ZERO c0/(2 pi R).
J0_ZERO = 2.404825557695773


class CaseInfo:
    """What the post-processing needs to know about a run's case.

    name          case name (circle2d, ellipsoid3d, square_rotation, square_vortical)
    dim           2 or 3
    rho0, c0      reference density and speed of sound
    length        R (stretching cases) or L (squares)
    rate          the flow's rate: A0, omega, or V0/L; its time scale is 1/rate
    time_label    how times are written, e.g. 't A0'
    p_unit        the pressure unit of the paper's plots (rho A0^2 R^2, rho omega^2 L^2, rho V0^2)
    p_unit_label  its name
    f_acoustic    the lowest acoustic frequency of the patch at t = 0, in
                  cycles per unit time (doc/theory/ X6; sphere: c0/(2R), the
                  first zero of sin(kr)/r).  By the Faber-Krahn inequality the
                  disc (ball) has the lowest Dirichlet eigenvalue among all
                  shapes of equal area (volume), so the stretching patches
                  never go below their initial value; a deformed square could
                  fall to at most 4 % below its f0 (the disc of equal area).
    notes         warnings gathered while reading (e.g. defaults assumed)
    rates         the stretching cases' initial strain rates alpha_k(0) (A0 included)
    units         a foreign run's unit options as given or assumed
                  ('--length 1 --rate 100 ...'), empty for our runs
    """

    def __init__(self, name, dim, rho0, c0, length, rate, time_label, p_unit,
                 p_unit_label, f_acoustic, notes=(), rates=None):
        self.name, self.dim, self.rho0, self.c0 = name, dim, rho0, c0
        self.rates = rates
        self.length, self.rate = length, rate
        self.time_label, self.p_unit, self.p_unit_label = time_label, p_unit, p_unit_label
        self.f_acoustic = f_acoustic
        self.notes = list(notes)
        self.units = ""

    @property
    def stretching(self):
        return self.name in ("circle2d", "ellipsoid3d")

    @property
    def square(self):
        return self.name.startswith("square")

    @property
    def c0_scaled(self):
        """c0 in the case's speed scale: c0 / (A0 R), c0 / (omega L), c0 / V0,
        whatever units the run's files use."""
        return self.c0 / (self.rate * self.length)

    @property
    def c0_label(self):
        """'c0 = 14 A0 R': c0 in the case's scale, as figures and reports
        write it."""
        return f"c0 = {self.c0_scaled:g} {CASES[self.name].speed}"


def patch_volume(case):
    """The initial patch's area pi R^2 (circle2d), volume 4/3 pi R^3
    (ellipsoid3d) or area L^2 (squares); the flows keep it."""
    return {"circle2d": math.pi * case.length**2,
            "ellipsoid3d": 4 / 3 * math.pi * case.length**3}.get(case.name, case.length**2)


def _pick(group, names, default, notes, what):
    for n in names:
        if n in group:
            return float(group[n])
    notes.append(f"{what} not found in input.nml; assumed {default}")
    return default


def resolution_scale(nml, dim):
    """s = (n/n_ref)^(1/dim) of the input's resolution scaling (doc/studies/convergence.md
    S1), 1 without it: the run's c0 is physics.c0 s^c0_exponent, as the solver
    computes it (input.nml keeps the given values and the rule)."""
    part = nml.get("particles", {})
    n_ref = float(part.get("n_ref", 0.0))
    if not n_ref > 0:
        return 1.0
    return (float(part.get("n", n_ref)) / n_ref) ** (1.0 / dim)


def scaled_input(nml, dim, group, name, exponent, default):
    """The value the run used for &group name: the input's value times
    resolution_scale^exponent (the exponent read from the same group)."""
    g = nml.get(group, {})
    return float(g.get(name, default)) * resolution_scale(nml, dim) ** float(g.get(exponent, 0.0))


def case_info(nml, case=None, dim=None):
    """CaseInfo from the parsed input.nml (nml may be {} when absent, then
    the case name must be given, e.g. from a snapshot's attributes)."""
    notes = []
    run = nml.get("run", {})
    name = (case or run.get("case") or "").lower()
    phys = nml.get("physics", {})
    rho0 = float(phys.get("rho0", 1.0))
    c0 = scaled_input(nml, 3 if name == "ellipsoid3d" else 2, "physics", "c0", "c0_exponent",
                      10.0)
    if not nml:
        notes.append("no input.nml: assumed rho0 = 1, c0 = 10 and unit scales")
    if name == "circle2d":
        g = nml.get("circle2d", {})
        r = float(g.get("radius", 1.0))
        a0 = float(g.get("a0", 1.0))
        return CaseInfo(name, 2, rho0, c0, r, a0, "t A0", rho0 * a0**2 * r**2,
                        "rho A0^2 R^2", J0_ZERO * c0 / (2 * math.pi * r), notes,
                        rates=(-a0, a0))
    if name == "ellipsoid3d":
        g = nml.get("ellipsoid3d", {})
        r = float(g.get("radius", 1.0))
        a0 = float(g.get("a0", 1.0))
        rates = g.get("rates", [-1.0, -1.0, 2.0])
        rates = tuple(a0 * float(x) for x in (rates if isinstance(rates, (list, tuple)) else [rates]))
        return CaseInfo(name, 3, rho0, c0, r, a0, "t A0", rho0 * a0**2 * r**2,
                        "rho A0^2 R^2", c0 / (2 * r), notes, rates=rates)
    if name == "square_rotation":
        # Variable names of issue 5's input/square_rotation.nml; the first
        # one found is used.
        g = nml.get("square_rotation", {})
        side = _pick(g, ("side", "l", "length"), 1.0, notes, "square_rotation side")
        omega = _pick(g, ("omega",), 1.0, notes, "square_rotation omega")
        return CaseInfo(name, 2, rho0, c0, side, omega, "t omega",
                        rho0 * omega**2 * side**2, "rho omega^2 L^2",
                        c0 / (math.sqrt(2) * side), notes)
    if name == "square_vortical":
        g = nml.get("square_vortical", {})
        side = _pick(g, ("side", "l", "length"), 1.0, notes, "square_vortical side")
        v0 = _pick(g, ("v0",), 1.0, notes, "square_vortical v0")
        return CaseInfo(name, 2, rho0, c0, side, v0 / side, "t V0/L", rho0 * v0**2,
                        "rho V0^2", c0 / (math.sqrt(2) * side), notes)
    raise PostprocError(f"unknown case '{name}': the post-processing knows circle2d, "
                        "ellipsoid3d, square_rotation and square_vortical")
