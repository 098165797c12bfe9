"""sphpost.readers.pysph: PySPH's dumps (pysph.solver.utils.dump), .npz and
.hdf5, read without PySPH."""
import numpy as np

from ..exceptions import PostprocError


def read_pysph(path, array=None):
    """PySPH's dump (pysph.solver.utils.dump): .npz with 'version' (1 or 2),
    'solver_data' and 'particles' (version 2: {array: {'arrays': {prop:
    data}, ...}}) or 'arrays' (version 1), pickled dicts; or .hdf5 with
    particles/ARRAY/arrays/PROP datasets (attribute 'stored') and the
    attributes of solver_data (t, dt, count)."""
    if path.lower().endswith(".npz"):
        try:
            with np.load(path, allow_pickle=True, encoding="bytes") as z:
                files = z.files
                if "version" not in files or "solver_data" not in files:
                    raise PostprocError(f"{path}: not a PySPH .npz (no 'version' or "
                                        "'solver_data' entry)")
                version = int(z["version"])
                solver = _unbox(z["solver_data"])
                if version == 2 and "particles" in files:
                    arrays = {n: info["arrays"] for n, info in _unbox(z["particles"]).items()}
                elif version == 1 and "arrays" in files:
                    arrays = _unbox(z["arrays"])
                else:
                    raise PostprocError(f"{path}: PySPH .npz version {version} is not "
                                        "understood (expected 1 or 2)")
        except PostprocError:
            raise
        except Exception as e:      # noqa: BLE001
            raise PostprocError(f"{path}: not a readable PySPH .npz file ({e})")
    else:
        import h5py
        try:
            with h5py.File(path, "r") as f:
                if "particles" not in f or "solver_data" not in f:
                    raise PostprocError(f"{path}: not a PySPH .hdf5 file (expected the "
                                        "groups particles and solver_data)")
                solver = {k: f["solver_data"].attrs[k] for k in f["solver_data"].attrs}
                arrays = {}
                for name, grp in f["particles"].items():
                    arrays[name] = {p: d[()] for p, d in grp["arrays"].items()
                                    if d.attrs.get("stored", True) and d.shape != (0,)}
        except PostprocError:
            raise
        except Exception as e:      # noqa: BLE001
            raise PostprocError(f"{path}: not a readable PySPH .hdf5 file ({e})")
    arrays = {_str(k): {_str(p): np.asarray(v) for p, v in a.items()} for k, a in arrays.items()}
    if array is None:
        array = "fluid" if "fluid" in arrays or len(arrays) != 1 else next(iter(arrays))
    if array not in arrays:
        raise PostprocError(f"{path}: no particle array '{array}' (the file has "
                            f"{', '.join(sorted(arrays))}): give --pysph-array")
    solver = {_str(k): v for k, v in solver.items()}
    time = float(solver["t"]) if "t" in solver else None
    return arrays[array], time, None


def _unbox(obj):
    """A dict that numpy.savez stored as a 0-d object array."""
    return obj.item() if isinstance(obj, np.ndarray) and obj.shape == () else obj[()]


def _str(s):
    return s.decode() if isinstance(s, bytes) else str(s)
