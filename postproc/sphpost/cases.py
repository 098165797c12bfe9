"""sphpost.cases: the solver's cases, under their names (&run case), with
their scales, the lowest acoustic frequency (doc/theory/ X6) and, for those
that have one, how to get their exact solution (sphpost.exact).

CASES is the registry of the cases with an exact solution: for each its
dimension, the names of its rate and length, the shipped input's speed of
sound (in the case's scale), the probe point, its family ("stretching": the
errors against X1, "square": the initial pressure and kinetic energy of X3,
X4) and two functions: `scales`, from its input group, and `exact`, its
exact initial probe pressure and kinetic energy (squares).  A solver case
not in it needs no entry: case_info gives it unit scales, and the tools
report what a run of any case has (probe pressure, kinetic energy, free
surface).  case_info turns a parsed input.nml (or a foreign run's options)
into a CaseInfo.
"""
import collections
import math

from . import exact as _exact
from .exceptions import PostprocError

Case = collections.namedtuple("Case", "name dim rate length speed c0 probe time_label family "
                                      "scales exact")
Case.__doc__ = """A case of the registry: name (the solver's, &run case), dim, the
names of its flow rate, its length and its speed scale (rate x length), the
shipped input's c0 in that speed scale, the probe (in units of the length),
how times are written, its family ('stretching' or 'square'), scales(group,
rho0, c0, notes) -> dict of CaseInfo's length, rate, p_unit, p_unit_label,
f_acoustic, rates and volume from its input group, and exact(info, x, y) -> (the
exact initial pressure at (x, y), the exact kinetic energy), or None."""


def _number(group, names, default, notes, what):
    """The first of names set in the input group, else default (noted)."""
    for n in names:
        if n in group:
            return float(group[n])
    notes.append(f"{what} not found in input.nml; assumed {default}")
    return default


def _circle2d(g, rho0, c0, notes):
    r, a0 = float(g.get("radius", 1.0)), float(g.get("a0", 1.0))
    return dict(length=r, rate=a0, p_unit=rho0 * a0**2 * r**2, p_unit_label="rho A0^2 R^2",
                f_acoustic=J0_ZERO * c0 / (2 * math.pi * r), rates=(-a0, a0),
                volume=math.pi * r**2)


def _ellipsoid3d(g, rho0, c0, notes):
    r, a0 = float(g.get("radius", 1.0)), float(g.get("a0", 1.0))
    rates = g.get("rates", [-1.0, -1.0, 2.0])
    rates = tuple(a0 * float(x) for x in (rates if isinstance(rates, (list, tuple)) else [rates]))
    return dict(length=r, rate=a0, p_unit=rho0 * a0**2 * r**2, p_unit_label="rho A0^2 R^2",
                f_acoustic=c0 / (2 * r), rates=rates, volume=4 / 3 * math.pi * r**3)


def _square_rotation(g, rho0, c0, notes):
    side = _number(g, ("side", "l", "length"), 1.0, notes, "square_rotation side")
    omega = _number(g, ("omega",), 1.0, notes, "square_rotation omega")
    return dict(length=side, rate=omega, p_unit=rho0 * omega**2 * side**2,
                p_unit_label="rho omega^2 L^2", f_acoustic=c0 / (math.sqrt(2) * side),
                volume=side**2)


def _square_vortical(g, rho0, c0, notes):
    side = _number(g, ("side", "l", "length"), 1.0, notes, "square_vortical side")
    v0 = _number(g, ("v0",), 1.0, notes, "square_vortical v0")
    return dict(length=side, rate=v0 / side, p_unit=rho0 * v0**2, p_unit_label="rho V0^2",
                f_acoustic=c0 / (math.sqrt(2) * side), volume=side**2)


def _rotation_exact(c, x, y):
    return (float(_exact.square_rotation_pressure(x, y, c.length, c.rate, c.rho0)[0]),
            _exact.square_rotation_kinetic_energy(c.length, c.rate, c.rho0))


def _vortical_exact(c, x, y):
    v0 = c.rate * c.length
    return (float(_exact.square_vortical_pressure(x, y, c.length, v0, c.rho0)[0]),
            _exact.square_vortical_kinetic_energy(c.length, v0, c.rho0))


CASES = {c.name: c for c in (
    Case("circle2d", 2, "A0", "R", "A0 R", 10.0, (0.0, 0.0), "t A0", "stretching",
         _circle2d, None),
    Case("ellipsoid3d", 3, "A0", "R", "A0 R", 10.0, (0.0, 0.0, 0.0), "t A0", "stretching",
         _ellipsoid3d, None),
    Case("square_rotation", 2, "omega", "L", "omega L", 7.0, (0.0, 0.0), "t omega", "square",
         _square_rotation, _rotation_exact),
    Case("square_vortical", 2, "V0/L", "L", "V0", 14.0, (0.25, 0.25), "t V0/L", "square",
         _square_vortical, _vortical_exact))}

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
    family        'stretching', 'square', or None for a case not in CASES
    volume        the initial patch's area (volume), None when not known:
                  patch_volume
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
        self.family = CASES[name].family if name in CASES else None
        self.volume = None

    @property
    def stretching(self):
        return self.family == "stretching"

    @property
    def square(self):
        return self.family == "square"

    @property
    def rate_label(self):
        """The rate's name, the unit of frequencies: 'A0' of 't A0'; a case
        without scales has none."""
        return self.time_label[2:] if self.time_label.startswith("t ") else "per unit time"

    @property
    def c0_scaled(self):
        """c0 in the case's speed scale: c0 / (A0 R), c0 / (omega L), c0 / V0,
        whatever units the run's files use."""
        return self.c0 / (self.rate * self.length)

    @property
    def c0_label(self):
        """'c0 = 14 A0 R': c0 in the case's scale, as figures and reports
        write it."""
        if self.name not in CASES:
            return f"c0 = {self.c0:g}"
        return f"c0 = {self.c0_scaled:g} {CASES[self.name].speed}"


def patch_volume(case):
    """The initial patch's area pi R^2 (circle2d), volume 4/3 pi R^3
    (ellipsoid3d) or area L^2 (squares); the flows keep it.  A case not in
    CASES: its volume when the run has told it (Run: the first snapshot's
    Sum m/rho), else None."""
    return case.volume


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
    the case name must be given, e.g. from a snapshot's attributes).  A case
    not in CASES gets unit length and time scales and p_unit rho0 c0^2; its
    dimension is dim (from a snapshot's attributes), 2 if not given."""
    notes = []
    run = nml.get("run", {})
    name = (case or run.get("case") or "").lower()
    if not name:
        raise PostprocError("no case: give --case (the solver's run.case)")
    entry = CASES.get(name)
    d = entry.dim if entry else int(dim or 2)
    phys = nml.get("physics", {})
    rho0 = float(phys.get("rho0", 1.0))
    c0 = scaled_input(nml, d, "physics", "c0", "c0_exponent", 10.0)
    if not nml:
        notes.append("no input.nml: assumed rho0 = 1, c0 = 10 and unit scales")
    if entry is None:
        notes.append(f"case '{name}' has no exact solution in sphpost.cases: unit scales; "
                     "the acoustic frequency is that of a patch of size 1, c0/2")
        return CaseInfo(name, d, rho0, c0, 1.0, 1.0, "t", rho0 * c0**2, "rho0 c0^2",
                        c0 / 2, notes)
    sc = entry.scales(nml.get(name, {}), rho0, c0, notes)
    c = CaseInfo(name, d, rho0, c0, sc["length"], sc["rate"], entry.time_label,
                 sc["p_unit"], sc["p_unit_label"], sc["f_acoustic"], notes,
                 rates=sc.get("rates"))
    c.volume = sc["volume"]
    return c
