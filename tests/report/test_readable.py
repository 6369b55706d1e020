"""What a lab engineer reads (issue 22): no Python repr, no generated label, no bare number in a
table, and the same status for every value on page 1 (HTML and PDF), in stiffness.csv, .json,
.xlsx and ``result.table()`` (docs/contract.md section 10).

The reports read are the demo's (every test kind, a value to check) and the synthetic study of
tests/report/test_report.py (every test kind, failures, pending fits, a fixed value).
"""

from __future__ import annotations

import csv
import dataclasses
import html as htmllib
import io
import json
import re
from html.parser import HTMLParser
from importlib import resources
from pathlib import Path

import pytest

from matid.app.api import fit
from matid.fits.kinds import KINDS
from matid.io.study import TABLE_KEYS, TEST_COMMON_KEYS
from matid.model.study import PARAMETER_KINDS, Test
from matid.report import render_report
from matid.report.quantities import UNSTATED
from matid.report.summary import interval_text, value_cells
from matid.report.verdict import STATUS_WORDS
from tests.report.test_report import make_result

pypdf = pytest.importorskip("pypdf")
openpyxl = pytest.importorskip("openpyxl")

DEMO = Path(str(resources.files("matid.example")))
#: A Python repr or a raw dump in the page.
REPRS = ("{'", "[{", "index []", "np.float64", "array(", "': ", "None,")
#: snake_case words: a generated label, unless a name the user writes (a parameter, a study key,
#: a column of the contract) or part of a file name.
SNAKE = re.compile(r"(?<![\w.\-/])[a-z][a-z0-9]*(?:_[a-z0-9]+)+(?![\w./])")
FILE_NAME = re.compile(r"[^\s/]+\.(?:csv|txt|dat|toml|json|xlsx|py)\b")
USER_NAMES = {
    *PARAMETER_KINDS,
    *(k for keys in TABLE_KEYS.values() for k in keys),
    *(k for kind in KINDS for k in kind.test_keys),
    *TEST_COMMON_KEYS,
    *(f.name for f in dataclasses.fields(Test)),
    *(c for kind in KINDS for c in kind.columns),
}
#: A table cell that is a number (or an interval "a to b") with nothing else.
BARE_NUMBER = re.compile(r"^[-+−]?\d[\d.,]*(?:e[-+]?\d+)?(?:\s*(?:to|,)\s*[-+−]?\d[\d.]*(?:e[-+]?\d+)?)?$")
#: Words of a header or label naming a quantity without unit (a count, a ratio, a statistic).
DIMENSIONLESS = re.compile(
    r"points|rows|runs|\br\b|R²|χ²|p-value|\bp\b|autocorrelation|factor|ratio|number|elements|solves|"
    r"relative|variance of ln|BIC|AIC|sum of squares|/ noise|rel\. error|level|arms|\bn\b|fitted|left out",
    re.IGNORECASE,
)


class Tables(HTMLParser):
    """Every <table> of a page as (header, rows) of cell texts; kv tables have no header."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[tuple[list[str], list[list[str]]]] = []
        self._stack: list[tuple[list[str], list[list[str]]]] = []
        self._cell: list[str] | None = None
        self._in_head = False

    def handle_starttag(self, tag, attrs) -> None:
        if tag == "table":
            self._stack.append(([], []))
        elif tag == "thead":
            self._in_head = True
        elif tag == "tr" and self._stack and not self._in_head:
            self._stack[-1][1].append([])
        elif tag in ("td", "th") and self._stack:
            self._cell = []

    def handle_endtag(self, tag) -> None:
        if tag == "table" and self._stack:
            self.tables.append(self._stack.pop())
        elif tag == "thead":
            self._in_head = False
        elif tag in ("td", "th") and self._stack and self._cell is not None:
            text = " ".join("".join(self._cell).split())
            header, rows = self._stack[-1]
            (header if self._in_head else rows[-1]).append(text)
            self._cell = None

    def handle_data(self, data) -> None:
        if self._cell is not None:
            self._cell.append(data)


def visible_text(page: str) -> str:
    """The text a reader sees: no style, no image data, no tags."""
    page = re.sub(r"<style.*?</style>", " ", page, flags=re.S)
    page = re.sub(r"<[^>]+>", " ", page)
    return " ".join(htmllib.unescape(page).split())


def tables_of(page: str) -> list[tuple[list[str], list[list[str]]]]:
    parser = Tables()
    parser.feed(page)
    return parser.tables


def unit_problems(page: str) -> list[str]:
    """Table cells holding a bare number whose column (or row label) names no unit."""
    problems = []
    for header, rows in tables_of(page):
        has_unit_column = "unit" in header
        for row in rows:
            for j, cell in enumerate(row):
                if j == 0 or not BARE_NUMBER.match(cell):
                    continue
                # the column's header, the table's first header (e.g. "record, points") and the row's label
                name = " ".join([*header[:1], header[j] if j < len(header) else "", row[0]])
                if has_unit_column or "[" in name or DIMENSIONLESS.search(name):
                    continue
                problems.append(f"{name!r}: {cell!r} (row {row[0]!r})")
    return problems


def readability_problems(page: str) -> list[str]:
    text = visible_text(page)
    problems = [
        f"repr {r!r}: ...{text[max(text.find(r) - 60, 0) : text.find(r) + 40]}..." for r in REPRS if r in text
    ]
    words = set(SNAKE.findall(FILE_NAME.sub(" ", text))) - USER_NAMES
    problems += [f"generated label {w!r}" for w in sorted(words)]
    return problems + unit_problems(page)


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The demo fitted once: its FitResult and the folder of its written files."""
    result = fit(DEMO)
    out = tmp_path_factory.mktemp("demo")
    result.write(out)
    return result, out


@pytest.fixture(scope="module")
def synthetic() -> str:
    return render_report(make_result())["report.html"].decode("utf-8")


def test_demo_report_reads_without_repr_label_or_bare_number(demo):
    assert demo[0].ok, demo[0].failures  # the report of a demo whose every fit ran
    page = (demo[1] / "report.html").read_text(encoding="utf-8")
    assert readability_problems(page) == []
    assert UNSTATED not in page  # every figure the fitters write has its quantity registered


def test_every_kind_report_reads_without_repr_label_or_bare_number(synthetic):
    assert readability_problems(synthetic) == []


def test_the_checks_find_what_they_look_for():
    """The checks above are not vacuous: a dict dump, a generated label, a bare noise all fail."""
    page = (
        "<p>noise_per_run {'a': 1}</p><table><thead><tr><th>item</th><th>value</th></tr></thead>"
        "<tbody><tr><td>noise</td><td>5.945e-6</td></tr></tbody></table>"
        "<table><tbody><tr><td>Units as written</td><td>index []</td></tr></tbody></table>"
    )
    found = " ".join(readability_problems(page))
    assert "{'" in found and "index []" in found and "noise_per_run" in found and "5.945e-6" in found


def page1_statuses(text: str, doc: dict) -> dict[tuple[str, str], str]:
    """(specimen, parameter) -> the status words found with the parameter on page 1's text."""
    found = {}
    words = "|".join(map(re.escape, STATUS_WORDS.values()))
    for sid, params in doc["specimens"].items():
        for name in params:
            match = re.search(
                rf"\b{re.escape(sid)}\s+(?:\S+ = )?{re.escape(name)}(?: = \S+)?\s+({words})", text
            )
            found[(sid, name)] = match.group(1) if match else "missing"
    return found


def test_each_value_has_one_status_in_every_output(demo):
    result, out = demo
    doc = json.loads((out / "stiffness.json").read_text(encoding="utf-8"))
    expected = {
        (s, p): item["status"] for s, params in doc["specimens"].items() for p, item in params.items()
    }
    assert set(expected.values()) >= {"ok", "check"}  # the demo has both (else this shows little)
    rows = list(csv.DictReader(io.StringIO((out / "stiffness.csv").read_text(encoding="utf-8"))))
    assert {(r["specimen"], r["parameter"]): r["status"] for r in rows} == expected
    sheet = openpyxl.load_workbook(out / "stiffness.xlsx", read_only=True)["stiffness"]
    cells = list(sheet.iter_rows(values_only=True))
    head = list(cells[0])
    xlsx = {
        (r[head.index("specimen")], r[head.index("parameter")]): r[head.index("status")] for r in cells[1:]
    }
    assert xlsx == expected
    table = result.table()
    assert {(r.specimen, r.parameter): r.status for r in table.itertuples()} == expected
    words = {key: STATUS_WORDS[s] for key, s in expected.items()}
    page = (out / "report.html").read_text(encoding="utf-8")
    summary = page.split('<section id="summary">', 1)[1].split("</section>", 1)[0]
    assert page1_statuses(visible_text(summary), doc) == words
    pdf = pypdf.PdfReader(out / "report.pdf")
    first = " ".join(pdf.pages[0].extract_text().split())
    assert page1_statuses(first, doc) == words


def test_nose_travel_E_s_of_T2_shows_its_status_and_interval_not_a_plain_stderr(demo):
    _, out = demo
    item = json.loads((out / "stiffness.json").read_text(encoding="utf-8"))["specimens"]["T2"]["E_s"]
    assert item["status"] != "ok"  # the demo's nose-travel E_s is read with its warnings
    value, stderr, _, low, high, unit = value_cells(item)
    first = " ".join(pypdf.PdfReader(out / "report.pdf").pages[0].extract_text().split())
    page = visible_text((out / "report.html").read_text(encoding="utf-8").split("</section>", 2)[0])
    for text in (first, page):
        assert f"{value} ± {stderr}" not in text and f"{value} {interval_text(low, high)} {unit}" in text
        assert f"E_s {STATUS_WORDS[item['status']]} {value}" in text


def test_a_value_the_data_do_not_determine_shows_no_number_and_what_to_measure():
    """A torsion E_t whose 95 % interval reaches zero: page 1 says 'not identifiable', prints no
    value or interval of it, and says what to measure instead; the report still reads cleanly."""
    from dataclasses import replace

    from matid.io.results import stiffness_json

    base = make_result(kinds=("torsion",))
    fit = base.fits[0]
    loose = [replace(e, value=2e-6, stderr=5e-6, ci95=(-8e-6, 1.2e-5)) if e.parameter == "E_t" else e
             for e in fit.estimates]  # fmt: skip
    result = replace(base, fits=(replace(fit, estimates=tuple(loose)),))
    item = stiffness_json(result)["specimens"]["T1"]["E_t"]
    assert item["status"] == "not_identifiable" and item["value"] is None  # decided by matid.model.status
    out = render_report(result)
    page = out["report.html"].decode("utf-8")
    summary = visible_text(page.split('<section id="summary">', 1)[1].split("</section>", 1)[0])
    row = summary[summary.index("T1 E_t ") :]
    assert row.startswith("T1 E_t not identifiable no value — ") and "Measure instead: " in row
    assert not re.search(r"[-−]?8(\.0*)?e-0?6|1\.2e-0?5|2(\.0*)?e-0?6", summary)
    assert readability_problems(page) == []
    first = " ".join(pypdf.PdfReader(io.BytesIO(out["report.pdf"])).pages[0].extract_text().split())
    assert "T1 E_t not identifiable no value" in first and "Measure instead" in first
