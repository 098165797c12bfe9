"""Sizes a newcomer reads in one sitting: no Fortran source under src/ (.f90,
.F90, .fypp, .inc, .fypi) over MAX_FILE_LINES lines, no procedure over
MAX_PROCEDURE_LINES lines, but for the exceptions below, each with its reason.

A procedure is measured from its `subroutine` or `function` statement to its
`end subroutine` or `end function`, both included, with its internal
procedures (after its `contains`); each internal procedure is measured too.
Sources are measured as written in src/: a fypp template or an included
file as it stands, not as expanded.  An exception that is no longer needed
fails too, so that the list only ever shrinks.
"""
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SUFFIXES = (".f90", ".F90", ".fypp", ".inc", ".fypi")
MAX_FILE_LINES = 800
MAX_PROCEDURE_LINES = 120

# The exceptions, path (from the repository's root) -> reason.  "pending":
# over today in code that another change is reworking; remove the entry
# when that change lands.
ALLOWED_FILES = {}
# (path, procedure) -> reason
ALLOWED_PROCEDURES = {
    ("src/sph/pair_loop.fypi", "${name}$"):
        "the template of the pair loops: one visit of a row, read top to bottom (the "
        "partners, each pair's terms from pair_terms.fypi, the lanes, the scatter to j); "
        "split, the generated loops would no longer vectorise as one",
}

# a procedure's first statement: prefixes, a result type, then the keyword
# and the name (fypp's ${name}$ included); `end ...` and `module procedure`
# lines are not one
_TYPE = r"(?:integer|real|logical|character|complex|type|class)\s*(?:\((?:[^()]|\([^()]*\))*\))?"
_PREFIX = r"(?:(?:pure|impure|elemental|recursive|non_recursive|module)\s+)"
START = re.compile(rf"^\s*{_PREFIX}*(?:{_TYPE}\s+)?{_PREFIX}*(subroutine|function)\s+([^\s(&]+)",
                   re.I)
END = re.compile(r"^\s*end\s*(subroutine|function)\b", re.I)


def sources():
    return sorted(p for p in (ROOT / "src").glob("*/*") if p.name.endswith(SUFFIXES))


def relative(path):
    return path.relative_to(ROOT).as_posix()


def procedures(text):
    """(name, first line, number of lines) of every procedure in `text`."""
    found, open_ = [], []
    for number, line in enumerate(text.splitlines(), start=1):
        code = line.split("!", 1)[0]      # a "!" in a string cuts it short: fine here
        if END.match(code):
            assert open_, f"line {number}: an end without its procedure"
            name, first = open_.pop()
            found.append((name, first, number - first + 1))
        elif not re.match(r"^\s*end\b", code, re.I) and (m := START.match(code)):
            open_.append((m.group(2), number))
    assert not open_, f"no end for {open_}"
    return found


def test_measure():
    text = """module m
contains
  pure integer(i8) function f(x) result(y)   ! a function
    y = x
  contains
    subroutine inner()
    end subroutine inner
  end function f
  subroutine ${name}$(&
  end subroutine ${name}$
end module m
"""
    assert procedures(text) == [("inner", 6, 2), ("f", 3, 6), ("${name}$", 9, 2)]


def test_files_are_short():
    long = {relative(p): n for p in sources()
            if (n := len(p.read_text().splitlines())) > MAX_FILE_LINES}
    over = {path: n for path, n in long.items() if path not in ALLOWED_FILES}
    assert not over, f"over {MAX_FILE_LINES} lines (split the file by concern): {over}"


def test_procedures_are_short():
    over = {}
    for path in sources():
        for name, first, n in procedures(path.read_text()):
            if n > MAX_PROCEDURE_LINES and (relative(path), name) not in ALLOWED_PROCEDURES:
                over[f"{relative(path)}:{first} {name}"] = n
    assert not over, (f"over {MAX_PROCEDURE_LINES} lines (split it by its phases, or say in "
                      f"ALLOWED_PROCEDURES why it reads better long): {over}")


def test_file_exceptions_still_needed():
    # (one test over the list, which may be empty)
    stale = [path for path in sorted(ALLOWED_FILES)
             if not ((ROOT / path).exists()
                     and len((ROOT / path).read_text().splitlines()) > MAX_FILE_LINES)]
    assert not stale, f"no longer over {MAX_FILE_LINES} lines: remove from ALLOWED_FILES: {stale}"


@pytest.mark.parametrize("path,name", sorted(ALLOWED_PROCEDURES))
def test_procedure_exception_still_needed(path, name):
    file = ROOT / path
    lengths = [n for p, _, n in procedures(file.read_text()) if p == name] if file.exists() else []
    assert any(n > MAX_PROCEDURE_LINES for n in lengths), \
        f"{path} {name} is no longer over {MAX_PROCEDURE_LINES} lines: remove it from " \
        "ALLOWED_PROCEDURES"
