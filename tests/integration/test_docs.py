"""The documentation set (doc/README.md) is checked like code:

(a) every relative link of README.md and doc/**/*.md resolves: the file
    exists inside the repository and, for a link to a markdown page with
    #anchor, the page has a heading with that GitHub anchor;
(b) every default a page states agrees with `./sph --defaults` or with the
    input file it names.  The convention, which pages follow:
      - inline, default `group.variable = value`, or `group.variable`
        (default value): the solver's default, as `./sph --defaults`
        prints it;
      - inline, `input/NAME.nml` sets `group.variable = value`: the value
        a run of that input file uses (the file's, else the default);
      - a table whose first header cell is "variable", its rows starting
        with `group.variable`, its other columns headed "default" or
        `input/NAME.nml` (a cell left empty or "-" states nothing).
    Any other `group.variable = value` describes a setting and states
    nothing; but every `group.variable` a page names must exist;
(c) no issue numbers ("issue 37", "#37"), session words ("this session",
    "last stop") or machine anecdotes ("this machine", "the development
    machine") in doc/;
(d) no page over 20 kB, except the generated references, the studies and
    the pages listed in OWNED_ELSEWHERE;
(e) every doc/ path the code, the tests and the input files cite exists,
    and every equation label they cite (E8, X3, M5, ...) is defined in
    doc/theory/.
"""
import re

import pytest

from common import ROOT, run_sph

DOC = ROOT / "doc"
PAGES = sorted(DOC.rglob("*.md"))
# Written by programs, not by hand: checked against their generators elsewhere
# (tests/integration/test_input_doc.py; `make validate*` writes the reports).
GENERATED = {DOC / "reference" / "input.md", DOC / "validation" / "patches.md",
             DOC / "validation" / "squares.md"}
# Maintained by the squares' reference work (Gerris and the boundary-integral
# reference), which rewrites it: only its links are checked here.
OWNED_ELSEWHERE = {DOC / "validation" / "reference.md"}
# (d): 20 kB for every page a user or developer reads top to bottom; the
# studies are reports of measurements and may be longer, up to 60 kB.
PAGE_LIMIT = 20 * 1024
# Pages allowed over the limit for now (none).
SIZE_PENDING = set()
STUDY_LIMIT = 60 * 1024


def rel(p):
    return p.relative_to(ROOT).as_posix()


def prose(text):
    """text without fenced code blocks (their lines kept empty, so that line
    numbers stay right)."""
    out, fence = [], False
    for line in text.split("\n"):
        if line.lstrip().startswith("```"):
            fence = not fence
            out.append("")
        else:
            out.append("" if fence else line)
    return "\n".join(out)


def slug(heading):
    """GitHub's anchor of a heading: lower case, markup and punctuation
    dropped (letters, digits, '-', '_' and spaces kept), spaces to '-'."""
    s = heading.strip().lower()
    s = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", s)      # a link: its text
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def anchors(page):
    seen, out = {}, set()
    for line in prose(page.read_text()).split("\n"):
        m = re.match(r"#{1,6} +(.*?) *#*$", line)
        if m:
            a = slug(m.group(1))
            n = seen.get(a, 0)
            out.add(a if n == 0 else f"{a}-{n}")
            seen[a] = n + 1
    return out


LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?: \"[^\"]*\")?\)")


def links(page):
    text = re.sub(r"`[^`\n]*`", "", prose(page.read_text()))
    for n, line in enumerate(text.split("\n"), 1):
        for m in LINK.finditer(line):
            yield n, m.group(1)


def test_links_resolve():
    bad, count = [], 0
    for page in [ROOT / "README.md"] + PAGES:
        for n, target in links(page):
            if re.match(r"[a-z][a-z0-9+.-]*:", target):      # http:, mailto:
                continue
            count += 1
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            where = f"{rel(page)}:{n}: {target}"
            if ROOT.resolve() not in dest.parents and dest != ROOT.resolve():
                bad.append(f"{where} (outside the repository)")
            elif not dest.exists():
                bad.append(f"{where} (no such file)")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                bad.append(f"{where} (no heading with this anchor)")
    assert count > 100, count        # the index alone links every page
    assert not bad, "broken links:\n" + "\n".join(bad)


def test_every_page_is_in_the_index():
    index = (DOC / "README.md").read_text()
    linked = {(DOC / t.partition("#")[0]).resolve() for _, t in links(DOC / "README.md")}
    missing = [rel(p) for p in PAGES if p.resolve() not in linked and p != DOC / "README.md"]
    assert index and not missing, f"doc/README.md does not link {missing}"


# ------------------------------------------------------------------ defaults
def uncomment(line):
    """line without its '!' comment (a '!' inside a quoted string stays)."""
    quote = None
    for k, c in enumerate(line):
        if quote:
            quote = None if c == quote else quote
        elif c in "'\"":
            quote = c
        elif c == "!":
            return line[:k]
    return line


def parse_namelist(text):
    """{'group.variable': [values]} of a Fortran namelist text as sph's input
    files and `--defaults` write it: one assignment a line, '!' comments."""
    out, group = {}, None
    for line in text.split("\n"):
        line = uncomment(line).strip()
        if line.startswith("&"):
            group = line[1:].strip().lower()
        elif line == "/":
            group = None
        elif group and "=" in line:
            name, value = line.split("=", 1)
            out[f"{group}.{name.strip().lower()}"] = values(value)
    return out


def values(text):
    """A namelist value (or list of values) in a comparable form."""
    out = []
    for tok in re.findall(r"'[^']*'|\"[^\"]*\"|[^,\s]+", text.strip()):
        if tok[0] in "'\"":
            out.append(tok[1:-1])
        elif tok.lower() in (".true.", ".t.", "t", "true"):
            out.append(True)
        elif tok.lower() in (".false.", ".f.", "f", "false"):
            out.append(False)
        else:
            try:
                out.append(float(tok.lower().replace("d", "e")))
            except ValueError:
                out.append(tok)
    return out


@pytest.fixture(scope="module")
def defaults():
    p = run_sph(["--defaults"])
    assert p.returncode == 0, p.out
    d = parse_namelist(p.stdout)
    assert len(d) > 50, d
    return d


def effective(defaults, nml):
    path = ROOT / nml
    assert path.is_file(), f"{nml}: no such input file"
    return {**defaults, **parse_namelist(path.read_text())}


VAR = r"([a-z_0-9]+\.[a-z_0-9]+(?:\([0-9:, ]*\))?)"
INLINE = [re.compile(r"[Dd]efault:? `" + VAR + r" = ([^`]+)`()"),
          re.compile(r"`" + VAR + r"` \([Dd]efault:? `?([^`),]+)`?\)()"),
          re.compile(r"`(input/[\w.]+\.nml)` sets `" + VAR + r" = ([^`]+)`")]


def stated_defaults():
    """(page:line, variable, value text, source) of every stated default."""
    for page in PAGES:
        if page in GENERATED | OWNED_ELSEWHERE:
            continue
        lines = prose(page.read_text()).split("\n")
        for n, line in enumerate(lines, 1):
            for k, pattern in enumerate(INLINE):
                for m in pattern.finditer(line):
                    if k < 2:
                        yield f"{rel(page)}:{n}", m.group(1), m.group(2), "default"
                    else:
                        yield f"{rel(page)}:{n}", m.group(2), m.group(3), m.group(1)
        n = 0
        while n < len(lines):
            head = [c.strip() for c in lines[n].strip().strip("|").split("|")]
            if lines[n].lstrip().startswith("|") and head[0].lower() == "variable":
                cols = [re.sub(r"[`*]", "", c) for c in head]
                n += 2                                        # header and rule
                while n < len(lines) and lines[n].lstrip().startswith("|"):
                    cells = [c.strip() for c in lines[n].strip().strip("|").split("|")]
                    var = re.fullmatch(r"`" + VAR + "`", cells[0])
                    assert var, f"{rel(page)}:{n + 1}: a row of a variable table " \
                                f"starts with `group.variable`: {cells[0]}"
                    for col, cell in zip(cols[1:], cells[1:]):
                        cell = cell.strip("`").strip()
                        if col in ("default",) or col.endswith(".nml"):
                            if cell not in ("", "-"):
                                yield f"{rel(page)}:{n + 1}", var.group(1), cell, col
                    n += 1
            n += 1


def test_stated_defaults_agree_with_the_inputs(defaults):
    bad, count = [], 0
    for where, var, value, source in stated_defaults():
        count += 1
        table = defaults if source == "default" else effective(defaults, source)
        key = var.lower()
        if key not in table:
            bad.append(f"{where}: {var} is not an input variable ({source})")
        elif values(value) != table[key]:
            bad.append(f"{where}: {var} = {value}, but {source} has {table[key]}")
    # the guide's tables alone state more than this many
    assert count >= 40, f"only {count} stated defaults found: is the convention kept?"
    assert not bad, "\n".join(bad)


def test_named_variables_exist(defaults):
    groups = {k.split(".")[0] for k in defaults}
    names = {k.split("(")[0] for k in defaults}
    bad = []
    for page in PAGES:
        if page in GENERATED | OWNED_ELSEWHERE:
            continue
        for n, line in enumerate(prose(page.read_text()).split("\n"), 1):
            for code in re.findall(r"`([^`]+)`", line):
                for m in re.finditer(r"(?<![\w./-])([a-z_0-9]+)\.([a-z_0-9]+)(?=[=\s(]|$)", code):
                    if m.group(1) in groups and f"{m.group(1)}.{m.group(2)}" not in names:
                        bad.append(f"{rel(page)}:{n}: {m.group(0)}")
    assert not bad, "no such input variable:\n" + "\n".join(bad)


# ----------------------------------------------------- words and page sizes
FORBIDDEN = [
    (r"\b[Ii]ssues? \d+", "an issue number"),
    (r"(?<![\w&/])#\d+\b", "an issue number"),
    (r"\b(this|last|same|previous|next|a) session\b|\bsessions\b|session's", "a session word"),
    (r"\blast stop\b", "a session word"),
    (r"\b(this|our|development|shared|2-core) machines?\b", "a machine anecdote"),
]


def test_no_issue_numbers_or_session_words():
    bad = []
    for page in PAGES:
        if page in GENERATED | OWNED_ELSEWHERE:
            continue
        for n, line in enumerate(page.read_text().split("\n"), 1):
            for pattern, what in FORBIDDEN:
                m = re.search(pattern, line)
                if m:
                    bad.append(f"{rel(page)}:{n}: {what}: {m.group(0)!r}")
    assert not bad, "\n".join(bad)


def test_page_sizes():
    bad = []
    for page in PAGES:
        if page in GENERATED | OWNED_ELSEWHERE | SIZE_PENDING:
            continue
        limit = STUDY_LIMIT if page.parent == DOC / "studies" else PAGE_LIMIT
        size = page.stat().st_size
        if size > limit:
            bad.append(f"{rel(page)}: {size} bytes > {limit}")
    assert not bad, "\n".join(bad)


# ------------------------------------------------- what the code cites in doc/
CITING = [ROOT / "Makefile", ROOT / "setup.sh", *ROOT.glob("input/*.nml"),
          *[p for d in ("src", "tests", "postproc") for p in (ROOT / d).rglob("*")
            if p.suffix in (".f90", ".F90", ".inc", ".fypp", ".fypi", ".pf", ".py", ".sh", "")
            and p.is_file()]]
# The validation driver writes the generated reports; its text is rewritten
# with the reports (doc/validation/README.md), not here.
CITING = [p for p in CITING if p.name != "validate.py"]
# the pages' own mentions of doc/ paths, outside links, too
CITING += [p for p in [ROOT / "README.md"] + PAGES if p not in GENERATED | OWNED_ELSEWHERE]
LABEL = re.compile(r"(?<![\w.])([BDEHIKMPRSTX][1-9])(?![\w.])")


def cited_text():
    for p in CITING:
        try:
            yield p, p.read_text()
        except UnicodeDecodeError:
            continue


def test_cited_doc_paths_exist():
    bad = []
    for p, text in cited_text():
        # pages and folders (doc/theory/, doc/studies/numerics.md), not the
        # file names a usage example writes to
        for m in re.finditer(r"\bdoc/(?:[\w-]+/)*(?:[\w-]+\.md\b)?", text):
            path = m.group(0)
            if not (ROOT / path).exists():
                line = text.count("\n", 0, m.start()) + 1
                bad.append(f"{rel(p)}:{line}: {path}")
    assert not bad, "cited doc/ paths that do not exist:\n" + "\n".join(bad)


def defined_labels():
    out = set()
    for page in (DOC / "theory").glob("*.md"):
        text = page.read_text()
        out |= set(re.findall(r"\(([A-Z][1-9])\)", text))
        for a, lo, hi in re.findall(r"\(([A-Z])([1-9])-\1([1-9])\)", text):
            out |= {f"{a}{k}" for k in range(int(lo), int(hi) + 1)}
    return out


def test_cited_labels_are_defined_in_theory():
    defined = defined_labels()
    assert len(defined) > 40, defined
    cited = {}
    for p, text in cited_text():
        # a label next to a doc/ citation or an equation's parentheses
        for m in re.finditer(r"\(([^()]*)\)", text):
            for lab in LABEL.findall(m.group(1)):
                cited.setdefault(lab, rel(p))
    missing = {lab: where for lab, where in cited.items() if lab not in defined}
    assert len(cited) > 30, cited
    assert not missing, f"labels cited but not defined in doc/theory/: {missing}"
