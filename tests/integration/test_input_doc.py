"""doc/input.md documents every input variable the program describes: each
group of `sph --help` has its section, each variable its row there with the
same default.  The rows of config (generic groups) and of each case are the
one description; this keeps the hand-written tables in step with them."""
import re

from common import ROOT, run_sph


def described_variables():
    """(group, variable, default text) from `sph --help`."""
    p = run_sph(["--help"])
    assert p.returncode == 0, p.out
    found = []
    for line in p.stdout.splitlines():
        m = re.match(r"  (\w+)\.(\w+)(\(1:3,k\))? = (.*?)(\s{2,}|\s*$)", line)
        if m:
            found.append((m.group(1), m.group(2), None if m.group(3) else m.group(4).strip()))
    return found


def doc_sections():
    """group -> the text of its section `### `&group`` in doc/input.md."""
    text = (ROOT / "doc" / "input.md").read_text()
    parts = re.split(r"^### `&(\w+)`", text, flags=re.M)
    return {parts[k]: parts[k + 1].split("\n## ")[0] for k in range(1, len(parts), 2)}


def test_doc_has_every_variable_with_its_default():
    variables = described_variables()
    assert len(variables) > 40, variables
    sections = doc_sections()
    for group, name, default in variables:
        assert group in sections, f"doc/input.md has no section for &{group}"
        rows = [r for r in sections[group].splitlines() if r.startswith(f"| `{name}` |")]
        assert len(rows) == 1, f"doc/input.md: &{group} has {len(rows)} rows for {name}"
        if default is not None:
            assert f"`{default}`" in rows[0], f"doc/input.md: {group}.{name} default {default}"
