"""doc/reference/input.md's tables of variables are the program's own: `sph
--input-tables` writes them from the rows that describe each variable
(config's generic groups, each case's group), and the test asserts that
every table of doc/reference/input.md is exactly that output, so the documentation
cannot drift from what the program reads, checks and prints.

After changing a variable's row, rewrite the tables with
    make input-doc
(this file run as a script: /usr/bin/python3 tests/integration/test_input_doc.py --write).
"""
import re
import sys

from common import ROOT, run_sph

DOC = ROOT / "doc" / "reference" / "input.md"
# the table that follows a group's heading: its header, rule and rows
TABLE = re.compile(r"(^### `&(\w+)`[^\n]*\n\n)((?:\|[^\n]*\n)+)", re.M)


def generated_tables():
    """group -> its table (header, rule, rows; each line ending in a newline)."""
    p = run_sph(["--input-tables"])
    assert p.returncode == 0, p.out
    tables = {}
    for block in p.stdout.strip().split("\n\n"):
        lines = block.strip().split("\n")
        assert lines[0].startswith("&"), block
        tables[lines[0][1:]] = "\n".join(lines[1:]) + "\n"
    return tables


def doc_with_tables(text, tables):
    """text with the table under each group's heading replaced by tables[group];
    a group without a heading (a new case's) gets one, before `&parallel`'s."""
    in_doc = {m.group(2) for m in TABLE.finditer(text)}
    for group in tables:
        if group not in in_doc:
            at = text.index("### `&parallel`")
            text = (text[:at] + f"### `&{group}`: used when `run.case = '{group}'`\n\n|\n\n"
                    + text[at:])
    return TABLE.sub(lambda m: m.group(1) + tables.get(m.group(2), m.group(3)), text)


def test_doc_tables_are_the_programs():
    tables = generated_tables()
    assert len(tables) >= 10 and sum(t.count("\n") - 2 for t in tables.values()) > 50, tables
    text = DOC.read_text()
    in_doc = {m.group(2): m.group(3) for m in TABLE.finditer(text)}
    assert sorted(in_doc) == sorted(tables), "doc/reference/input.md: a group without its section"
    for group, table in tables.items():
        assert in_doc[group] == table, \
            f"doc/reference/input.md: the table of &{group} is not `sph --input-tables`' (make input-doc)"


def test_help_and_tables_agree_on_defaults():
    # --help prints group.variable = default from the same rows
    p = run_sph(["--help"])
    assert p.returncode == 0, p.out
    tables = generated_tables()
    seen = 0
    for line in p.stdout.splitlines():
        m = re.match(r"  (\w+)\.(\w+) = (.*?)(\s{2,}|\s*$)", line)
        if m:
            group, name, default = m.group(1), m.group(2), m.group(3).strip()
            assert f"| `{name}` | " in tables[group], (group, name)
            assert f"`{default}`" in tables[group], (group, name, default)
            seen += 1
    assert seen > 40


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit(__doc__)
    DOC.write_text(doc_with_tables(DOC.read_text(), generated_tables()))
    print(f"rewrote the tables of {DOC}")
