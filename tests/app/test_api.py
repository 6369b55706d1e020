"""The Python API (matid.fit, matid.load_study, FitResult): the guide's notebook session, run as written."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

import matid
from matid.app import pipeline
from matid.errors import DataError, FitError
from tests import ROOT
from tests.app.test_cli import small_study
from tests.io.test_results import bending_study

GUIDE = ROOT / "docs" / "guide.md"


def notebook_session() -> str:
    """The Python block under the user guide's heading 'From Python: a notebook session'."""
    text = GUIDE.read_text(encoding="utf-8")
    section = text.split("## From Python: a notebook session", 1)[1]
    match = re.search(r"```python\n(.*?)```", section, re.S)
    assert match, "docs/guide.md lost its notebook session"
    return match.group(1)


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """Run the guide's session in a folder whose data/example is a small study (T1's bending and torsion).

    The code is the guide's, unchanged; only the study behind "data/example" is smaller
    than the demo, to keep the test fast.
    """
    cwd = tmp_path_factory.mktemp("notebook")
    bending_study(cwd / "data" / "example")
    namespace: dict = {}
    before = Path.cwd()
    out = io.StringIO()
    try:
        os.chdir(cwd)
        with contextlib.redirect_stdout(out):
            exec(compile(notebook_session(), "docs/guide.md", "exec"), namespace)
    finally:
        os.chdir(before)
    return namespace, out.getvalue(), cwd


def test_readme_notebook_session_runs(session):
    ns, printed, cwd = session
    result = ns["result"]
    assert isinstance(result, matid.FitResult) and result.ok is True
    assert "['T1']" in printed
    table = ns["table"]
    assert isinstance(table, pd.DataFrame)
    assert set(table.parameter) == {"E_b", "E_t", "E_s_torsion"}  # E_s_torsion follows from E_t
    out = cwd / "reports" / "example"
    names = {Path(p).name for p in ns["paths"]}
    assert names == {"report.html", "report.pdf", "stiffness.csv", "stiffness.json", "stiffness.xlsx"}
    assert all((out / n).is_file() for n in names)
    html = result._repr_html_()  # what Jupyter shows for the session's last line
    assert "E_b" in html and "No warnings." in html


def test_table_is_stiffness_csv(session):
    """The DataFrame holds what stiffness.csv holds, row for row."""
    ns, _, cwd = session
    rows = list(csv.DictReader((cwd / "reports" / "example" / "stiffness.csv").open(encoding="utf-8")))
    table = ns["result"].table()
    assert list(table.columns) == list(rows[0])
    assert len(table) == len(rows)
    for row, (_, frame) in zip(rows, table.iterrows(), strict=True):
        assert (row["specimen"], row["parameter"], row["unit"]) == (
            frame.specimen,
            frame.parameter,
            frame.unit,
        )
        assert float(row["value"]) == pytest.approx(frame.value, rel=1e-9)
        assert row["warnings"] == frame.warnings


def test_surface_is_plain_data(session):
    result = session[0]["result"]
    assert isinstance(result.warnings, list) and all(isinstance(w, str) for w in result.warnings)
    assert isinstance(result.failures, list) and isinstance(result.ok, bool)
    assert result.name.startswith("SYNTHETIC demo")
    assert "FitResult" in repr(result)


def test_cgs_table(session):
    result = session[0]["result"]
    si, cgs = result.table(), result.table(units="cgs")
    e_b = (si.parameter == "E_b").to_numpy()
    assert cgs[e_b].unit.item() == "dyn cm^2"
    assert cgs[e_b].value.item() == pytest.approx(si[e_b].value.item() * 1e9, rel=1e-12)


def test_warnings_and_failures_reach_the_api(tmp_path, monkeypatch):
    """A failed fit is a failure and a warning, not an exception; _repr_html_ lists the warnings."""
    study = small_study(tmp_path / "study")

    def broken(measurements, *, specimen, fixed, known):
        raise FitError("twist channel saturated <at 3 deg>")

    monkeypatch.setitem(pipeline.FITTERS, "torsion", broken)
    result = matid.fit(study / "study.toml")
    assert result.ok is False
    assert result.failures == ["T1 torsion: twist channel saturated <at 3 deg>"]
    assert any("saturated" in w for w in result.warnings)
    assert "E_t" not in set(result.table().parameter)
    html = result._repr_html_()
    assert "Warnings (1)" in html and "&lt;at 3 deg&gt;" in html  # escaped


def test_bad_input_raises_data_error(tmp_path):
    with pytest.raises(DataError, match="not found"):
        matid.load_study(tmp_path / "nowhere")
    with pytest.raises(DataError, match="not found"):
        matid.fit(tmp_path / "nowhere")


def test_import_matid_and_the_cli_stay_light():
    """``import matid`` and ``import matid.app.cli`` load no numerical stack (time: measured, not tested)."""
    heavy = ["numpy", "pandas", "scipy", "matplotlib", "pint", "lmfit", "skfem", "matid.bench", "matid.rod"]
    code = (
        "import sys, json, matid, matid.app.cli; "
        f"print(json.dumps([m for m in {heavy!r} if m in sys.modules]))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == []


def test_printed_table_tells_value_and_bounds_apart(session):
    """E_b ~ 6.5e-5 N m^2 with a 0.2 % interval: printed, value and bounds differ (pandas' default
    six decimals print all three as 0.000065); the numbers behind stay the floats of stiffness.csv."""
    table = session[0]["result"].table()
    text = repr(table)
    for row in table.itertuples():
        low, value, high = (f"{x:.{digits(row)}g}" for x in (row.ci95_low, row.value, row.ci95_high))
        assert len({low, value, high}) == 3, row  # the data tell them apart at this precision
        line = next(line for line in text.splitlines() if f" {row.parameter} " in f" {line} ")
        shown = re.findall(r"-?\d+\.\d+(?:e[-+]\d+)?", line)[:4]  # value, stderr, low, high
        assert len({shown[0], shown[2], shown[3]}) == 3, line
        assert float(shown[0]) == pytest.approx(row.value, rel=abs(row.stderr / row.value))
    assert isinstance(table.value.iloc[0], float)


def digits(row) -> int:
    """Significant digits that resolve the standard error of ``row`` to two figures."""
    import math

    return max(2, int(math.floor(math.log10(abs(row.value))) - math.floor(math.log10(row.stderr))) + 2)


def test_notebook_view_is_page_one(session):
    """The Jupyter view: status in words, value, 95 % interval and unit per value, no ± stderr."""
    result = session[0]["result"]
    page = result._repr_html_()
    for row in result.table().itertuples():
        assert f"<td>{row.parameter}</td>" in page
    assert "use it" in page and " to " in page and "±" not in page


def test_plot_returns_the_fit_figure(session):
    from matplotlib.figure import Figure

    result = session[0]["result"]
    fig = result.plot("E_b", "T1")
    assert isinstance(fig, Figure) and fig.axes and fig.axes[0].lines
    with pytest.raises(DataError, match="no fit gives E_s of specimen T1; fitted: T1 E_b"):
        result.plot("E_s", "T1")


@pytest.mark.parametrize("method", ["table", "write", "plot"])
def test_an_unknown_unit_system_names_the_argument_and_the_choices(session, tmp_path, method):
    """Before: ``table(units="bogus")`` raised KeyError: 'bogus' (write and plot too, deep inside).
    After: a ValueError (matid.units.UnitError) naming ``units`` and the systems there are, before any
    work."""
    result = session[0]["result"]
    call = {
        "table": lambda: result.table(units="bogus"),
        "write": lambda: result.write(tmp_path / "out", units="bogus"),
        "plot": lambda: result.plot("E_b", "T1", units="bogus"),
    }[method]
    with pytest.raises(ValueError, match=r"units must be one of 'SI', 'cgs', got 'bogus'"):
        call()
    assert not (tmp_path / "out").exists()
