"""Where warnings appear (stiffness.csv, stiffness.json, terminal, --strict) and stiffness.xlsx."""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io
import json
from pathlib import Path

import openpyxl
import pytest

from matid.app import pipeline
from matid.app.cli import main
from matid.io.results import stiffness_csv, stiffness_json
from matid.io.study import load_study
from matid.io.xlsx import stiffness_xlsx
from tests.app.test_cli import CSV_HEADER, small_study

FIT_WARNING = "standard linear solid misses the relaxation: reduced chi2 = 40; measure a longer hold"
E_T_WARNING = "torque offset of 2 % full scale; re-zero the torque cell"


def add_warnings(monkeypatch) -> None:
    """The real extension and torsion fits, plus a fit-level warning (extension) and one on E_t."""

    def wrap(kind, fit_warnings, estimate_warnings):
        real = pipeline.FITTERS[kind]

        def fitter(measurements, **kwargs):
            fit = real(measurements, **kwargs)
            estimates = tuple(
                dataclasses.replace(e, warnings=(*e.warnings, *estimate_warnings)) for e in fit.estimates
            )
            return dataclasses.replace(fit, warnings=(*fit.warnings, *fit_warnings), estimates=estimates)

        monkeypatch.setitem(pipeline.FITTERS, kind, fitter)

    wrap("extension", [FIT_WARNING], [])
    wrap("torsion", [], [E_T_WARNING])


def drop_test(study: Path, file: str) -> None:
    """Remove the [[test]] of ``file`` from the study (another subset: another value)."""
    toml = (study / "study.toml").read_text()
    blocks = toml.split("[[test]]")
    (study / "study.toml").write_text("[[test]]".join(b for b in blocks if f'"{file}"' not in b))


def bending_study(folder: Path) -> Path:
    """T1 of the demo with its magnetic bending and torsion tests only: the quickest to fit and render."""
    small_study(folder)
    for run_ in ("r1", "r2", "r3"):
        drop_test(folder, f"extension_T1_{run_}.csv")
    return folder


@pytest.fixture(scope="module")
def warned(tmp_path_factory):
    """A fitted small study with both warnings, and a requested window (twist <= 1 rad) on the torsion tests.

    The window keeps 9 of 25 rows per file: enough for the per-file tare offset the torsion fit estimates
    (a window of 0.05 rad keeps one row per file, and the fit then fails, as it should).
    """
    with pytest.MonkeyPatch.context() as mp:
        add_warnings(mp)
        study = load_study(small_study(tmp_path_factory.mktemp("warned")))
        window = {"twist_angle": (0.0, 1.0)}
        tests = tuple(
            dataclasses.replace(t, window=window) if t.kind == "torsion" else t for t in study.tests
        )
        return pipeline.run_study(dataclasses.replace(study, tests=tests))


def run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_csv_warnings_column(warned):
    text = stiffness_csv(warned)
    assert text.splitlines()[0] == CSV_HEADER and CSV_HEADER.endswith(",warnings,status")
    rows = {r["parameter"]: r for r in csv.DictReader(io.StringIO(text))}
    for name in ("E_e", "sls_k1", "sls_k2", "sls_eta"):  # a fit's warning concerns all its parameters
        assert rows[name]["warnings"] == FIT_WARNING
    assert rows["E_t"]["warnings"] == E_T_WARNING
    assert rows["E_b"]["warnings"] == ""


def test_csv_joins_several_warnings(warned):
    first = warned.fits[0]
    both = dataclasses.replace(first, warnings=("one", "two"))
    result = dataclasses.replace(warned, fits=(both, *warned.fits[1:]))
    assert first.kind == "extension"
    rows = {r["parameter"]: r for r in csv.DictReader(io.StringIO(stiffness_csv(result)))}
    assert rows["E_e"]["warnings"] == "one; two"


def test_json_every_parameter_has_warnings_and_window(warned):
    doc = json.loads(json.dumps(stiffness_json(warned)))  # plain JSON, no numpy leftovers
    params = doc["specimens"]["T1"]
    for name, item in params.items():
        assert isinstance(item["warnings"], list), name
        window = item["window"]
        assert 0 < window["rows_used"] <= window["rows_read"]
    assert params["E_e"]["warnings"] == [FIT_WARNING] and params["E_b"]["warnings"] == []
    assert params["E_t"]["warnings"] == [E_T_WARNING]
    torsion_files = {t.file.name for t in warned.study.tests if t.kind == "torsion"}
    assert params["E_t"]["window"]["requested"] == {f: {"twist_angle": [0.0, 1.0]} for f in torsion_files}
    assert params["E_b"]["window"]["requested"] == {}
    rows_read = sum(f.n_rows for f in warned.inputs if f.path.name in torsion_files)
    assert params["E_t"]["window"]["rows_read"] == rows_read
    assert any(E_T_WARNING in w for w in doc["warnings"])


def test_xlsx_sheets(warned):
    book = openpyxl.load_workbook(io.BytesIO(stiffness_xlsx(warned)), read_only=True)
    assert book.sheetnames == ["stiffness", "warnings", "inputs"]
    sheet = [list(r) for r in book["stiffness"].iter_rows(values_only=True)]
    rows = list(csv.reader(io.StringIO(stiffness_csv(warned))))
    assert ",".join(sheet[0]) == CSV_HEADER and len(sheet) == len(rows)
    for cells, text in zip(sheet[1:], rows[1:], strict=True):
        assert cells[:2] == text[:2] and isinstance(cells[2], float)
        assert cells[2] == pytest.approx(float(text[2]), rel=1e-9)
        assert (cells[-1] or "") == text[-1]
    warnings = list(book["warnings"].iter_rows(values_only=True))
    assert warnings[0] == ("specimen", "concerns", "warning")
    assert ("T1", "extension", FIT_WARNING) in warnings and ("T1", "E_t", E_T_WARNING) in warnings
    inputs = list(book["inputs"].iter_rows(values_only=True))
    assert inputs[0] == ("file", "sha256", "rows_used", "rows_read")
    by_file = {r[0]: r for r in inputs[1:]}
    assert set(by_file) == {f.path.name for f in warned.inputs}
    for f in warned.inputs:
        name, sha, used, read = by_file[f.path.name]
        assert sha == f.sha256 and read == f.n_rows and 0 < used <= read


def test_terminal_lists_warnings_and_strict_exits_1(tmp_path, monkeypatch):
    add_warnings(monkeypatch)
    monkeypatch.setattr(pipeline, "render_report", lambda result, *, units: {"report.html": "<html/>"})
    study = small_study(tmp_path / "study")
    code, out, _ = run(["fit", str(study), "--out", str(tmp_path / "a"), "--quiet"])
    assert code == 0, out
    tail = out.split("warnings (3):", 1)[
        1
    ]  # extension, E_t and E_s_torsion (from E_t): at the end of the run, before the paths
    assert f"T1 extension: {FIT_WARNING}" in tail and f"T1 E_t: {E_T_WARNING}" in tail
    assert tail.index(E_T_WARNING) < tail.index("outputs:")
    code, _, _ = run(["fit", str(study), "--out", str(tmp_path / "b"), "--quiet", "--strict"])
    assert code == 1
    assert (tmp_path / "b" / "stiffness.xlsx").is_file()  # --strict changes the exit code, not the files


def test_strict_without_warnings_exits_0(tmp_path, monkeypatch):
    monkeypatch.setattr(pipeline, "render_report", lambda result, *, units: {"report.html": "<html/>"})
    study = small_study(tmp_path / "study")
    code, out, _ = run(["fit", str(study), "--out", str(tmp_path / "o"), "--quiet", "--strict"])
    assert code == 0 and "warnings: none" in out
    assert Path(tmp_path / "o" / "stiffness.csv").read_text().splitlines()[1].endswith(",,ok")
