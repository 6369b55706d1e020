"""Issue 11 end to end on data we did not make: the shared 3D-continuum tube (T20) written as a
ZwickRoell testXpert export (cp1252, ';', decimal comma, a preamble), fitted by ``matid fit``.
Every warning of its nose-travel E_s must reach the terminal, stiffness.csv, stiffness.json
and the report's summary page (HTML and PDF), not only the fit object."""

from __future__ import annotations

import contextlib
import csv
import io
import json

import pytest
from pypdf import PdfReader

from matid.app.cli import main
from tests import ROOT, TESTS

REFERENCE = ROOT.parent / "shared" / "reference" / "tube3d" / "T20.json"
SOURCE = REFERENCE if REFERENCE.exists() else TESTS / "data" / "tube3d" / "T20.json"
STUDY = """[study]
name = "continuum tube T20, testXpert export"

[[specimen]]
id = "T"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"
poisson_ratio = 0.45

[[fixed]]
specimen = "T"
parameter = "E_b"
value = "6.5345e-5 N m^2"

[[fixed]]
specimen = "T"
parameter = "E_e"
value = "125.66 N"

[[test]]
kind = "three_point_bend"
specimen = "T"
file = "T20_nose.TXT"
span = "20 mm"
specimen_length = "28 mm"
support_radius = "2 mm"
nose_radius = "2 mm"
encoding = "cp1252"
columns = { deflection = "Standardweg", force = "Standardkraft" }
"""
REASONS = ("E_s is likely too low", "E_s is poorly determined")


def _comma(x: float) -> str:
    return f"{x:.6g}".replace(".", ",")


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    rows = json.loads(SOURCE.read_text())["rows"]
    folder = tmp_path_factory.mktemp("t20")
    lines = ["Prüfer: Müller", "Prüfvorschrift;DIN EN ISO 178"]
    lines += ["Prüfzeit;Standardweg;Standardkraft", "s;mm;N"]
    lines.append("0,000;0,0000;0,0000")
    lines += [f"{i + 1},000;{_comma(r['delta'])};{_comma(r['F'])}" for i, r in enumerate(rows)]
    (folder / "T20_nose.TXT").write_bytes(("\r\n".join(lines) + "\r\n").encode("cp1252"))
    (folder / "study.toml").write_text(STUDY, encoding="utf-8")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["fit", str(folder), "--out", str(folder / "out"), "--quiet"])
    return code, out.getvalue() + err.getvalue(), folder / "out"


def test_the_export_is_read_and_fitted(fitted):
    code, terminal, out = fitted
    assert code == 0, terminal
    doc = json.loads((out / "stiffness.json").read_text())
    assert "E_s" in doc["specimens"]["T"]


@pytest.mark.parametrize("reason", REASONS)
def test_each_warning_reaches_every_place_a_reader_looks(fitted, reason):
    _, terminal, out = fitted
    assert reason in terminal
    item = json.loads((out / "stiffness.json").read_text())["specimens"]["T"]["E_s"]
    assert any(w.startswith(reason) for w in item["warnings"])
    with open(out / "stiffness.csv", newline="", encoding="utf-8") as handle:
        row = next(r for r in csv.DictReader(handle) if r["parameter"] == "E_s")
    assert reason in row["warnings"]
    html = (out / "report.html").read_text(encoding="utf-8")
    assert reason in html[: html.index("Material moduli")]  # the summary's warning box
    first_page = PdfReader(out / "report.pdf").pages[0].extract_text()
    assert reason.split(" is ")[1] in " ".join(first_page.split())
