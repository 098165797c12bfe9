"""sphpost.readers.series: which files of another code's output are its
particle files, one per output time, and their format.

A code writes side files next to its particle files: PySPH its
profile_info.csv and, for some examples, results.npz; DualSPHysics'
PartVTK its CSV tables; ParaView collections (.pvd).  A directory is read
without --pattern when exactly one series of files holds particles; else
the message names the candidate series and a --pattern taken from them.
"""
import glob
import os
import re

import numpy as np

from ..exceptions import PostprocError

FORMATS = ("sph", "plain", "vtk", "pysph")
EXTENSIONS = {"plain": (".csv", ".npz"), "vtk": (".vtk", ".vtu", ".vtp"),
              "pysph": (".npz", ".hdf5", ".h5")}


def _natural_key(path):
    """Sort key: the file name with its numbers compared as numbers."""
    return [float(s) if re.fullmatch(r"\d+(\.\d+)?", s) else s
            for s in re.split(r"(\d+(?:\.\d+)?)", os.path.basename(path))]


def series_name(path):
    """The series a file belongs to, as (prefix, extension, numbered):
    NAME_0012.vtk -> ('NAME_', '.vtk', True); profile_info.csv ->
    ('profile_info', '.csv', False), a file of its own."""
    base = os.path.basename(path)
    stem, ext = os.path.splitext(base)
    m = re.match(r"^(.*?)[0-9.eE+-]*\d+$", stem)
    if m and re.search(r"\d$", stem):
        return m.group(1), ext, True
    return stem, ext, False


def series_glob(key):
    """The --pattern of a series (series_name): 'NAME_*.vtk', or the file's
    own name."""
    prefix, ext, numbered = key
    return f"{prefix}*{ext}" if numbered else prefix + ext


def holds_particles(path):
    """Whether a file looks like one output time of particles: a VTK file, a
    CSV whose header names x and y, a plain .npz with x and y, a PySPH dump
    (.npz with 'particles' or 'arrays', .hdf5 with the group particles).  Side
    files (PySPH's profile_info.csv and results.npz, DualSPHysics' Run.csv,
    a probe's t,p table) do not."""
    low = path.lower()
    try:
        if low.endswith((".vtk", ".vtu", ".vtp")):
            return True
        if low.endswith(".csv"):
            with open(path, newline="") as f:
                for line in f:
                    s = line.strip()
                    if s and not s.startswith("#"):
                        cols = {c.strip() for c in s.split(",")}
                        return {"x", "y"} <= cols
            return False
        if low.endswith(".npz"):
            with np.load(path, allow_pickle=False) as z:
                names = set(z.files)
            return bool({"particles", "arrays"} & names) or {"x", "y"} <= names
        if low.endswith((".hdf5", ".h5")):
            import h5py
            with h5py.File(path, "r") as f:
                return "particles" in f
    except Exception:           # noqa: BLE001 (unreadable: not ours to judge here)
        return True
    return False


def find_files(path, fmt=None, pattern=None):
    """The output files of a foreign run and its format: a directory, a glob
    pattern, or a single file.  In a directory (without pattern) the files
    of the format's extensions are grouped into series (series_name); a
    code's side files are left out: a file of its own (no output number)
    beside a numbered series, and a series whose files hold no particles
    (holds_particles).  One series must remain; else the message names the
    candidates and a --pattern taken from them."""
    if any(ch in path for ch in "*?["):
        files = glob.glob(path)
        where = path
    elif os.path.isdir(path):
        if pattern:
            files = glob.glob(os.path.join(path, pattern))
        else:
            exts = EXTENSIONS.get(fmt) or sum(EXTENSIONS.values(), ())
            files = [f for f in glob.glob(os.path.join(path, "*"))
                     if f.lower().endswith(exts) and os.path.isfile(f)]
        where = path
    elif os.path.isfile(path):
        files, where = [path], path
    else:
        raise PostprocError(f"run '{path}' does not exist")
    if not files:
        raise PostprocError(f"'{where}' has no output files" + (f" matching '{pattern}'"
                            if pattern else " (.csv, .npz, .vtk, .vtu, .vtp, .hdf5; "
                            "our runs have timeseries.csv)"))
    groups = {}
    for f in files:
        groups.setdefault(series_name(f), []).append(f)
    if len(groups) > 1:
        keep = groups
        if any(k[2] for k in keep):         # files of their own beside a numbered series
            keep = {k: v for k, v in keep.items() if k[2]}
        if len(keep) > 1:                   # series that hold particles
            keep = {k: v for k, v in keep.items() if holds_particles(sorted(v)[0])} or keep
        if len(keep) > 1:
            names = sorted(keep, key=lambda k: (-len(keep[k]), series_glob(k)))
            listed = ", ".join(f"{series_glob(k)} ({len(keep[k])} file"
                               f"{'s' if len(keep[k]) > 1 else ''})" for k in names[:6])
            raise PostprocError(f"'{where}' holds several series of particle files ({listed}): "
                                f"choose one with --pattern, e.g. --pattern "
                                f"'{series_glob(names[0])}'")
        groups = keep
    files = sorted(next(iter(groups.values())), key=_natural_key)
    if fmt is None:
        fmt = _detect_format(files[0])
    return files, fmt


def _detect_format(path):
    low = path.lower()
    if low.endswith((".vtk", ".vtu", ".vtp")):
        return "vtk"
    if low.endswith(".csv"):
        return "plain"
    if low.endswith(".npz"):
        try:
            with np.load(path, allow_pickle=False) as z:
                return "pysph" if "particles" in z.files or "arrays" in z.files else "plain"
        except Exception as e:      # noqa: BLE001 (any unreadable file)
            raise PostprocError(f"{path}: not a readable .npz file ({e})")
    if low.endswith((".hdf5", ".h5")):
        return "pysph"
    raise PostprocError(f"{path}: cannot tell the format from the name; give --format")
