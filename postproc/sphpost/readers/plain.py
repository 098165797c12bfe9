"""sphpost.readers.plain: the plain format, CSV or .npz with the columns
id, x, y[, z], u, v[, w], p[, rho, m] (doc/reference/other-codes.md)."""
import re

import numpy as np

from ..exceptions import PostprocError

TIME_LINE = re.compile(r"#\s*(?:time|t)\s*[=:]\s*(\S+)", re.I)


def read_plain_csv(path):
    """The plain format's CSV: '#' lines (one may be '# time = T'), a header
    of column names, then one row per particle."""
    with open(path, newline="") as f:
        lines = f.readlines()
    time, head = None, None
    for k, line in enumerate(lines):
        s = line.strip()
        if s.startswith("#"):
            m = TIME_LINE.match(s)
            if m and not _is_float(m.group(1)):
                raise PostprocError(f"{path} line {k + 1}: time '{m.group(1)}' is not a number")
            time = float(m.group(1)) if m else time
        elif s:
            head = k
            break
    if head is None:
        raise PostprocError(f"{path}: no particles (expected a header line id,x,y,... "
                            "and one row per particle)")
    header = [h.strip() for h in lines[head].split(",")]
    try:                            # numpy's parser: fast
        arr = np.loadtxt(lines[head + 1:], delimiter=",", comments="#", ndmin=2)
    except ValueError:
        arr = None
    if arr is None or arr.shape[1] != len(header):
        # what numpy refused, line by line, for a message naming the line
        # and the column
        for lineno, line in enumerate(lines[head + 1:], head + 2):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            vals = s.split(",")
            if len(vals) != len(header):
                raise PostprocError(f"{path} line {lineno}: {len(vals)} values, expected "
                                    f"{len(header)} (the columns {','.join(header)})")
            for h, v in zip(header, vals):
                if not _is_float(v):
                    raise PostprocError(f"{path} line {lineno}, column '{h}': '{v.strip()}' "
                                        "is not a number")
    if arr is None or len(arr) == 0:
        raise PostprocError(f"{path}: no particles (expected one row per particle after the "
                            "header)")
    return {h: arr[:, k] for k, h in enumerate(header)}, time, None


def _is_float(v):
    try:
        float(v)
        return True
    except ValueError:
        return False


def read_plain_npz(path):
    """The plain format's .npz: one 1-D array per column, 'time' a scalar."""
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except Exception as e:      # noqa: BLE001
        raise PostprocError(f"{path}: not a readable .npz file of plain arrays ({e})")
    time = data.pop("time", None)
    return data, (None if time is None else float(np.asarray(time).ravel()[0])), None
