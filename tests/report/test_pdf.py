"""The PDF report typeset by reportlab: producer, searchable text, outline, split tables, one process.

Checked with pypdf, which did not make the PDF: the text a reader's search finds, the outline a
viewer shows, the pages a table runs over.
"""

from __future__ import annotations

import ast
import io
import json
import os
import re
from html.parser import HTMLParser
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from reportlab.pdfbase.pdfmetrics import stringWidth as text_width

from matid.app.cli import main
from matid.model.results import Failure, InputFile, StudyResult
from matid.model.study import Specimen, Study
from matid.report import render_report
from matid.report.pdfparts import SANS, column_widths, register_fonts
from tests import ROOT
from tests.report.test_report import make_result

pypdf = pytest.importorskip("pypdf")


def _text(pdf: bytes) -> str:
    return "\n".join(page.extract_text() for page in pypdf.PdfReader(io.BytesIO(pdf)).pages)


def _squeezed(text: str) -> str:
    """Without white space: a line break the typesetting put inside a sentence does not count."""
    return re.sub(r"\s+", "", text)


def _outline(pdf: bytes) -> list[tuple[int, str]]:
    """(depth, title) of every outline entry, in order."""
    reader = pypdf.PdfReader(io.BytesIO(pdf))
    entries: list[tuple[int, str]] = []

    def walk(items, depth: int) -> None:
        for item in items:
            if isinstance(item, list):
                walk(item, depth + 1)
            else:
                entries.append((depth, item.title))

    walk(reader.outline, 0)
    return entries


class _Sections(HTMLParser):
    """The HTML page's sections (h2 of each <section>) and articles (h3 of each <article>)."""

    def __init__(self) -> None:
        super().__init__()
        self.found: list[tuple[int, str]] = []  # (0 for a section, 1 for an article, its heading)
        self._open: list[str] = []
        self._heading: tuple[int, list[str]] | None = None
        self._wanted: int | None = None

    def handle_starttag(self, tag, attrs) -> None:
        if tag in ("section", "article"):
            self._wanted = 0 if tag == "section" else 1
        elif tag in ("h2", "h3") and self._wanted == (0 if tag == "h2" else 1):
            self._heading = (self._wanted, [])

    def handle_endtag(self, tag) -> None:
        if tag in ("h2", "h3") and self._heading is not None:
            self.found.append((self._heading[0], "".join(self._heading[1]).strip()))
            self._heading, self._wanted = None, None

    def handle_data(self, data) -> None:
        if self._heading is not None:
            self._heading[1].append(data)


@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "out"
    assert main(["demo", "--quiet", "--out", str(out)]) == 0
    return out


def test_demo_pdf_is_made_by_reportlab_and_its_text_has_every_warning(demo):
    data = (demo / "report.pdf").read_bytes()
    assert "ReportLab" in pypdf.PdfReader(io.BytesIO(data)).metadata.producer
    doc = json.loads((demo / "stiffness.json").read_text(encoding="utf-8"))
    warnings = {
        w for params in doc["specimens"].values() for item in params.values() for w in item["warnings"]
    }
    assert warnings  # the demo warns (else this test shows nothing)
    text = _squeezed(_text(data))
    for warning in warnings:
        assert _squeezed(warning) in text, warning
    for unit in ("N m^2", "N s", "MPa", "rad/m", "mm"):
        assert _squeezed(unit) in text, unit


def test_demo_pdf_has_every_character_the_html_page_shows(demo):
    """Greek letters, ±, the superscripts of ×10⁻⁵, ⚠: whatever the page prints, the PDF's text has."""
    pdf = _text((demo / "report.pdf").read_bytes())
    html = (demo / "report.html").read_text(encoding="utf-8")
    body = re.sub(r"<[^>]*>", " ", html[html.index("<body>") :])  # texts, not tags or attributes
    wanted = {c for c in body if ord(c) > 127 and not c.isspace()} - {"–"}  # &ndash; left in the page's prose
    assert {"±", "σ", "τ", "⚠"} <= wanted
    assert wanted <= set(pdf), wanted - set(pdf)


def test_greek_letters_and_symbols_extract_from_the_pdf():
    base = make_result(kinds=("torsion",))
    name = "Tube η τ ± 0.5 ° µm σ χ² ×10⁻⁵"
    study = Study(name, base.study.source, base.study.specimens, base.study.tests)
    text = _text(render_report(StudyResult(study, base.inputs, base.fits))["report.pdf"])
    assert name in text
    for char in "ητ±°µσχ²⁻⁵":
        assert char in text


def test_every_section_of_the_html_page_is_in_the_pdf_outline():
    out = render_report(make_result())
    parser = _Sections()
    parser.feed(out["report.html"].decode("utf-8"))
    html = parser.found
    assert [d for d, _ in html].count(0) >= 7 and [d for d, _ in html].count(1) >= 6  # sections, specimens
    pdf = _outline(out["report.pdf"])
    assert pdf == html  # the same headings, in the same order, specimens under their section


def test_a_table_longer_than_a_page_repeats_its_header_on_each_page():
    base = make_result(kinds=("torsion",))
    names = [f"run_{i:03d}.csv" for i in range(160)]
    inputs = tuple(InputFile(ROOT / "data" / n, f"{i:064x}", {}, {}, n_rows=10) for i, n in enumerate(names))
    study = Study(base.study.name, base.study.source, (Specimen("T1", 2e-3),), ())
    reader = pypdf.PdfReader(io.BytesIO(render_report(StudyResult(study, inputs, ()))["report.pdf"]))
    shas = [f"{i:064x}" for i in range(len(names))]
    pages = [page.extract_text() for page in reader.pages]
    holding = [text for text in pages if any(sha in text for sha in shas)]  # the table's pages
    assert len(holding) >= 3  # the provenance table runs over three pages or more
    for text in holding:
        assert re.search(r"file\s+rows\s+sha256", text)
    for sha in shas:  # every row once, whole
        assert sum(text.count(sha) for text in holding) == 1


@given(
    st.lists(st.text(alphabet="abc ±η", min_size=0, max_size=30), min_size=1, max_size=6),
    st.floats(min_value=30.0, max_value=600.0),
)
def test_columns_share_the_width_and_keep_short_ones_whole(cells, available):
    register_fonts()
    header = tuple(f"h{j}" for j in range(len(cells)))
    widths = column_widths(header, [tuple(cells)], [SANS] * len(cells), 7.0, available)
    natural = [
        max(text_width(c, SANS, 7.0), text_width(h, "DejaVuSans-Bold", 7.0))
        for c, h in zip(cells, header, strict=True)
    ]
    assert all(w <= n + 7.0 + 1e-6 for w, n in zip(widths, natural, strict=True))  # never wider than its text
    assert sum(widths) <= max(available, sum(natural) + 7.0 * len(cells)) + 1e-6
    if sum(n + 7.0 for n in natural) <= available:  # all fit: all whole
        assert all(w >= n + 6.0 - 1e-6 for w, n in zip(widths, natural, strict=True))


def test_report_is_rendered_in_this_process(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the report started another process")

    monkeypatch.setattr(os, "fork", refuse)
    monkeypatch.setattr("subprocess.Popen.__init__", refuse)
    monkeypatch.setattr("multiprocessing.process.BaseProcess.start", refuse)
    out = render_report(make_result(kinds=("torsion", "extension")))
    assert out["report.pdf"].startswith(b"%PDF")


def test_the_report_uses_no_private_name_of_a_dependency():
    """No ``from dep import _x`` and no ``obj._x`` but on self or cls, anywhere in matid/report."""
    folder = Path(__file__).resolve().parents[2] / "matid" / "report"
    found = []
    for path in sorted(folder.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and not (node.module or "").startswith("matid"):
                found += [f"{path.name}: {a.name}" for a in node.names if a.name.startswith("_")]
            elif isinstance(node, ast.Import):
                found += [f"{path.name}: {a.name}" for a in node.names if "._" in f".{a.name}"]
            elif isinstance(node, ast.Attribute) and re.fullmatch(r"_[^_].*|_", node.attr):
                if not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
                    found.append(f"{path.name}:{node.lineno}: .{node.attr}")
    assert not found


@pytest.mark.parametrize("name", ["x" * 2000, "word " * 600], ids=["one word", "many words"])
def test_a_heading_taller_than_a_page_is_split_and_keeps_its_outline_entry(name):
    """A study name of 2000 characters (the longest a study.toml value may be) is the first page's
    heading: platypus splits it across pages (its parts are made as paragraphs)."""
    base = make_result(kinds=("torsion",))
    study = Study(name, base.study.source, base.study.specimens, base.study.tests)
    pdf = render_report(StudyResult(study, base.inputs, base.fits))["report.pdf"]
    assert _squeezed(name) in _squeezed(_text(pdf))
    assert [title for depth, title in _outline(pdf) if depth == 0][0] == "Summary of stiffnesses"


@pytest.mark.parametrize("reason", ["x" * 5000, "reason " * 800], ids=["one word", "many words"])
def test_a_table_row_taller_than_a_page_continues_on_the_next(reason):
    """A failure's reason in the summary table's last column, taller than a page (and one word
    wider than the table): the row is split across pages, the long word across lines."""
    base = make_result(kinds=("torsion",))
    result = StudyResult(base.study, base.inputs, base.fits, failures=(Failure("torsion", "T2", reason),))
    pdf = render_report(result)["report.pdf"]
    assert _squeezed(reason) in _squeezed(_text(pdf))
