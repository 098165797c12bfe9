"""sphpost.readers.namelist: the input file that sph writes into a run
directory (input.nml), as a dict."""


def _strip_comment(line):
    out, quote = [], None
    for ch in line:
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "!":
            break
        out.append(ch)
    return "".join(out)


def _split_values(text):
    vals, cur, quote = [], [], None
    for ch in text:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
            cur.append(ch)
        elif ch == ",":
            vals.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    if "".join(cur).strip():
        vals.append("".join(cur).strip())
    return vals


def _value(tok):
    if len(tok) >= 2 and tok[0] == tok[-1] and tok[0] in "'\"":
        return tok[1:-1].replace(tok[0] * 2, tok[0])
    low = tok.lower()
    if low in (".true.", "t", ".t."):
        return True
    if low in (".false.", "f", ".f."):
        return False
    try:
        return int(tok)
    except ValueError:
        pass
    try:
        return float(low.replace("d", "e"))
    except ValueError:
        return tok


def read_namelist(path):
    """The effective input that sph writes into a run directory, as
    {group: {variable: value}}; names in lower case; a list value for several
    comma-separated items.  Only the subset of namelist syntax that sph writes
    (one item per line) is understood."""
    groups, cur = {}, None
    with open(path) as f:
        for raw in f:
            line = _strip_comment(raw).strip()
            if not line:
                continue
            if line.startswith("&"):
                name = line[1:].split()[0].lower() if len(line) > 1 else ""
                cur = groups.setdefault(name, {})
                rest = line[1 + len(name):].strip()
                if rest == "/":
                    cur = None
                continue
            if line == "/":
                cur = None
                continue
            if cur is None or "=" not in line:
                continue
            key, val = line.split("=", 1)
            val = val.strip()
            if val.endswith("/"):
                val = val[:-1].strip()
            items = [_value(v) for v in _split_values(val)]
            cur[key.strip().lower()] = items[0] if len(items) == 1 else items
    return groups
