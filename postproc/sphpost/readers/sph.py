"""sphpost.readers.sph: an sph run directory (doc/reference/output.md): its input,
time series (timeseries.csv) and HDF5 snapshots, a run with mirror planes
unfolded into the whole body (doc/studies/symmetry.md, M3 and M5), and the
solver's closing summary."""
import csv
import glob
import os
import re

import numpy as np

from ..cases import CASES, case_info, patch_volume
from ..exceptions import PostprocError
from .namelist import read_namelist


def read_timeseries(path):
    """timeseries.csv as {column: float64 array} in file order."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise PostprocError(f"{path} is empty")
    header, data = rows[0], rows[1:]
    if not data:
        raise PostprocError(f"{path} has a header but no rows")
    arr = np.array([[float(v) for v in r] for r in data], dtype=float)
    return {name: arr[:, k] for k, name in enumerate(header)}


IMAGE_ID_STRIDE = 2 ** 32


def mirror_copies(mask):
    return 2 ** bin(mask).count("1")


def mirror_attrs(attrs):
    """A snapshot's mirror planes (doc/reference/output.md): their mask (0: none) and
    the copies of the part the file holds (1: the part)."""
    return (int(round(float(attrs.get("symmetry_mask", 0)))),
            int(round(float(attrs.get("mirror_copies", 1)))))


def plane_sets(x, mask):
    """(M5) For each particle (rows of x, (N, dim)) the mask of the planes
    of `mask` it lies on (its coordinate exactly 0, of either sign)."""
    on = np.zeros(len(x), dtype=np.int64)
    for k in range(min(3, x.shape[1])):
        if mask >> k & 1:
            on |= np.where(x[:, k] == 0, 1 << k, 0)
    return on


def set_weights(on):
    """(M5) The weights of particles on the plane sets `on` (plane_sets):
    2^-k on k planes."""
    return 0.5 ** sum((on >> k) & 1 for k in range(3))


def plane_weights(x, mask):
    """(M5) Each particle's weight: 2^-k on k of the planes of `mask`."""
    return set_weights(plane_sets(x, mask))


def unfold_mirrors(fields, mask):
    """The whole body from the part of a run with mirror planes (M3): the
    part, then its reflection by each nonzero submask (code) of mask in
    ascending order, as the solver's output.mirror writes it: vectors
    (N, dim) flip the code's columns, ids become id + code 2^32, the 2D
    vorticity (a pseudo-scalar) takes the sign s_x s_y, scalars are copied.
    (M5) A particle on planes P (its position's coordinate 0) is one
    particle with its images across them: it appears once per code that
    flips none of P, with the mass 2^|P| m."""
    codes = [0] + [c for c in range(1, 8) if c & mask == c]
    pos = fields.get("position", fields.get("position_initial"))
    on = w = None
    if pos is not None:
        on = plane_sets(np.asarray(pos), mask)
        w = set_weights(on)
    out = {}
    for name, a in fields.items():
        blocks = []
        for c in codes:
            b = np.array(a, copy=True)
            if name == "id":
                b = b + np.int64(c) * IMAGE_ID_STRIDE
            elif b.ndim == 2:
                for k in range(b.shape[1]):
                    if c >> k & 1:
                        b[:, k] = -b[:, k]
            elif name == "vorticity" and bin(c & 3).count("1") == 1:
                b = -b
            if on is not None:
                if name == "mass":
                    b = b / w
                b = b[(on & c) == 0]
            blocks.append(b)
        out[name] = np.concatenate(blocks)
    return out


class Run:
    """An sph run directory: its input, time series and snapshots.

    Raises PostprocError with a clear message when the directory is not one.
    """

    def __init__(self, path):
        self.path = os.path.abspath(str(path))
        if not os.path.exists(self.path):
            raise PostprocError(f"run directory '{path}' does not exist")
        if not os.path.isdir(self.path):
            raise PostprocError(f"'{path}' is not a directory (give the run directory, "
                                "output.dir of the run)")
        ts = os.path.join(self.path, "timeseries.csv")
        self.snapshots = sorted(glob.glob(os.path.join(self.path, "snap_*.h5")))
        if not os.path.exists(ts):
            raise PostprocError(f"'{path}' has no timeseries.csv: is it the output.dir of an "
                                "sph run? (a run writes it at its first snapshot)")
        self.ts = read_timeseries(ts)
        nml_path = os.path.join(self.path, "input.nml")
        self.nml = read_namelist(nml_path) if os.path.exists(nml_path) else {}
        case = self.nml.get("run", {}).get("case")
        dim = None
        if not case and not self.snapshots:
            raise PostprocError(f"'{path}' has neither input.nml nor snapshots: "
                                "cannot tell the case")
        if self.snapshots and (not case or str(case).lower() not in CASES):
            attrs = self.snapshot_attrs(self.snapshots[0])
            case, dim = case or attrs["case"], attrs["dim"]
        self.case = case_info(self.nml, case, dim)
        if patch_volume(self.case) is None and self.snapshots:
            # a case without an entry in sphpost.cases: the run tells its volume
            s = self.snapshot(0)
            self.case.volume = float(np.sum(s["mass"] / s["density"]))
        self.time = self.ts["time"]
        self._n = None

    # -- snapshots ---------------------------------------------------------
    @staticmethod
    def snapshot_attrs(path):
        import h5py
        with h5py.File(path, "r") as f:
            a = dict(f.attrs)
        c = a.get("case", b"")
        a["case"] = (c.decode() if isinstance(c, bytes) else str(c)).strip()
        a["time"] = float(a["time"])
        a["dim"] = int(a["dim"])
        return a

    def snapshot_times(self):
        return np.array([self.snapshot_attrs(p)["time"] for p in self.snapshots])

    def snapshot(self, index):
        """Snapshot `index` (negative counts from the end) as a dict of arrays
        sorted by particle id, plus 'attrs'.  A run with mirror planes
        (particles.symmetry) is given as the whole body: a snapshot of the
        part is unfolded by its reflections (doc/studies/symmetry.md, M3)."""
        import h5py
        path = self.snapshots[index]
        with h5py.File(path, "r") as f:
            out = {k: f[k][:] for k in f if k != "connectivity"}
        attrs = self.snapshot_attrs(path)
        mask, held = mirror_attrs(attrs)
        if mask and held == 1:
            out = unfold_mirrors(out, mask)
        order = np.argsort(out["id"])
        out = {k: v[order] for k, v in out.items()}
        out["attrs"] = attrs
        return out

    def window(self, until):
        """Cuts the time series at t rate = until (in the case's flow time,
        e.g. t A0), so that runs of different lengths, such as a level stopped
        at a checkpoint, are compared over the same interval [0, until]: the
        rows before it, and a last row at exactly `until` interpolated
        linearly between the two rows around it.  Raises PostprocError when
        the run ends before `until`."""
        c = self.case
        t_cut = until / c.rate
        t = self.time
        # a run asked to end at `until` ends there up to the rounding of t
        if t[-1] < t_cut * (1 - 1e-9):
            raise PostprocError(f"'{self.path}' ends at {c.time_label} = {t[-1] * c.rate:g}, "
                                f"before --until {until:g}")
        k = int(np.searchsorted(t, t_cut, side="right"))     # rows t[:k] <= t_cut
        if k < 2:
            raise PostprocError(f"'{self.path}' has fewer than two rows with {c.time_label} "
                                f"<= {until:g}")
        cut = {name: v[:k] for name, v in self.ts.items()}
        if k < len(t) and t[k - 1] < t_cut:
            w = (t_cut - t[k - 1]) / (t[k] - t[k - 1])
            cut = {name: np.append(v, (1 - w) * self.ts[name][k - 1] + w * self.ts[name][k])
                   for name, v in cut.items()}
            cut["time"][-1] = t_cut
        self.ts = cut
        self.time = cut["time"]
        return self

    @property
    def n_particles(self):
        if self._n is None:
            if self.snapshots:
                # the whole body's count: a run with mirror planes writes
                # the part (mirror_copies 1) or the whole body
                import h5py
                mask, held = mirror_attrs(self.snapshot_attrs(self.snapshots[0]))
                with h5py.File(self.snapshots[0], "r") as f:
                    x = f["position"][...]
                if held > 1 or mask == 0:
                    self._n = len(x)
                else:
                    # (M5) a particle on k planes stands for 2^-k of the copies
                    self._n = int(round(float(np.sum(plane_weights(x, mask)))
                                        * mirror_copies(mask)))
            else:
                self._n = int(self.nml.get("particles", {}).get("n", 0))
        return self._n

    @property
    def dx(self):
        """Equivalent particle spacing (volume per particle)^(1/dim): the
        initial patch's area pi R^2 / volume 4/3 pi R^3 / square L^2."""
        return (patch_volume(self.case) / self.n_particles) ** (1 / self.case.dim)

    def column(self, name):
        if name not in self.ts:
            raise PostprocError(f"{self.path}/timeseries.csv has no column '{name}' "
                                f"(case {self.case.name})")
        return self.ts[name]

    def centre_probe(self):
        """Column name of the probe at the centre (all coordinates 0), or None."""
        return self.probe_at((0.0,) * self.case.dim, 1e-12)

    def probe_at(self, point, tol):
        """Column name of the first probe within tol of point in each of the
        point's coordinates (output.probes of input.nml; a probe not set is
        at the origin), or None."""
        out = self.nml.get("output", {})
        n = int(out.get("n_probes", 1)) if self.nml else 1
        for k in range(1, n + 1):
            key = f"p_probe_{k}"
            if key not in self.ts:
                continue
            pos = [0.0, 0.0, 0.0]
            for i in range(3):
                v = out.get(f"probes({i + 1},{k})")
                if v is not None:
                    pos[i] = float(v)
            sec = out.get(f"probes(1:3,{k})")
            if isinstance(sec, list):
                pos = [float(v) for v in sec[:3]]
            if all(abs(p - q) < tol for p, q in zip(pos, point)):
                return key
        return None

    def probe_samples(self, name):
        """The samples (t, p) of the probe column `name`: the time series' rows."""
        return self.time, self.ts[name]

    def probe_signal(self, name):
        """The samples (t, p, P(t)) of the centre probe `name` with the exact
        centre pressure at the same times."""
        t, p = self.probe_samples(name)
        return t, p, self.column("p_centre_exact")


def solver_summary(text):
    """The solver's closing summary (its stdout) as a dict of numbers in %:
    'mean_axis', 'mean_pos', 'mean_vel', 'mean_p_raw', 'n_samples'."""
    pats = {"mean_axis": r"max semi-axis error\s+(\S+) %",
            "mean_pos": r"Time-averaged.*?RMS position error\s+(\S+) %",
            "mean_vel": r"Time-averaged.*?RMS velocity error\s+(\S+) %",
            "mean_p_raw": r"centre pressure \(raw\)\s+(\S+) % of P\(0\)",
            "n_samples": r"Time-averaged over (\d+) samples"}
    out = {}
    for k, p in pats.items():
        m = re.search(p, text, re.S)
        if m:
            out[k] = float(m.group(1))
    return out
