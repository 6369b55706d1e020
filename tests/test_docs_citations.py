"""Every section the code, the examples and the docs cite exists in the project's own docs.

Docstrings cite "docs/contract.md section N" (or "contract section N", "data-contract section N")
and "physics.md section N"; a reader must find that section in docs/contract.md and docs/physics.md,
not in a file outside the project (issue 30: the examples sent readers to sections that were not
there)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CITED = [
    *sorted((ROOT / "matid").rglob("*.py")),
    *sorted((ROOT / "matid").rglob("*.md")),
    *sorted((ROOT / "examples").rglob("*.toml")),
    *sorted((ROOT / "docs").glob("*.md")),
    ROOT / "README.md",
]
CONTRACT = re.compile(r"contract(?:\.md)?,? sections? (\d+)(?:\s*(?:-|and|,)\s*(\d+))?", re.I)
PHYSICS = re.compile(r"physics\.md,? (?:sections? )?(\d+)(?:\s*(?:-|and|,)\s*(\d+))?", re.I)


def headings(doc: str) -> set[int]:
    text = (ROOT / "docs" / doc).read_text(encoding="utf-8")
    return {int(m) for m in re.findall(r"^## (\d+)\.", text, re.M)}


def citations(pattern: re.Pattern) -> list[tuple[str, int]]:
    found = []
    for path in CITED:
        text = re.sub(r"\s+", " ", path.read_text(encoding="utf-8"))
        for m in pattern.finditer(text):
            first = int(m.group(1))
            last = int(m.group(2)) if m.group(2) else first
            found += [(str(path.relative_to(ROOT)), n) for n in range(first, last + 1)]
    return found


@pytest.mark.parametrize(("doc", "pattern"), [("contract.md", CONTRACT), ("physics.md", PHYSICS)])
def test_every_cited_section_exists(doc, pattern):
    cites = citations(pattern)
    assert len(cites) > 10, "the pattern no longer finds the code's citations"
    missing = sorted({(f, n) for f, n in cites if n not in headings(doc)})
    assert not missing, f"cited sections absent from docs/{doc}: {missing}"


def test_the_pattern_sees_a_missing_section(tmp_path):
    """The check itself can fail: a citation of a section the page lacks is reported."""
    text = "see docs/contract.md section 99 and physics.md section 42"
    assert [int(m.group(1)) for m in CONTRACT.finditer(text)] == [99]
    assert [int(m.group(1)) for m in PHYSICS.finditer(text)] == [42]
    assert 99 not in headings("contract.md") and 42 not in headings("physics.md")
