"""The status of every value (contract section 10): each route of matid.model.status.status, and where it
shows (stiffness.csv last column, stiffness.json, stiffness.xlsx, result.table())."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import math
import shutil

import numpy as np
import openpyxl
import pytest

from matid.app import pipeline
from matid.app.api import FitResult
from matid.fits.branch import record
from matid.fits.linear import fit_lines
from matid.io.results import CSV_COLUMNS, stiffness_csv, stiffness_json
from matid.io.study import load_study
from matid.io.xlsx import stiffness_xlsx
from matid.model.results import Estimate, TestFit
from matid.model.status import INSEPARABLE_R, STRONG_R, Status, status
from matid.physics.moduli import Section, modulus
from tests import TESTS
from tests.app.test_cli import small_study


def estimate(name="E_t", value=1e-4, rel=0.01, *, ci=True, warnings=(), method="linear", withheld=""):
    stderr = rel * value if rel is not None else None
    interval = (value - 1.96 * stderr, value + 1.96 * stderr) if ci and stderr is not None else None
    return Estimate(name, value, stderr, interval, 40, method, tuple(warnings), withheld=withheld)


def fit_of(*estimates, warnings=(), correlation=None, info=None):
    return TestFit(
        "extension", "T1", (), tuple(estimates), (), "x", "y",
        correlation=correlation or {}, warnings=tuple(warnings), info=info or {},
    )  # fmt: skip


# --- each route of the rule ---------------------------------------------------------------------


def test_ok_when_nothing_is_reported():
    est = estimate()
    assert status(est, fit_of(est)) == Status("ok")
    fixed = estimate("E_b", rel=None, ci=False, method="fixed")
    assert status(fixed, None) == Status("ok")  # a [[fixed]] value has no interval and needs none


def test_withheld_is_not_identifiable_with_what_to_measure():
    est = estimate("E_s_torsion", math.nan, None, ci=False, withheld="open section: no shear coefficient")
    verdict = status(est, fit_of(est))
    assert verdict.status == "not_identifiable" and verdict.reason == "open section: no shear coefficient"
    assert "three-point bend" in verdict.instead and not verdict.printed


def test_a_fit_saying_not_identifiable_reaches_the_status():
    why = "k2 and eta are not identifiable from the rates given: k2 and eta are correlated (r = 0.999)"
    k2 = estimate("sls_k2", warnings=[why])
    verdict = status(k2, fit_of(k2))
    assert verdict == Status("not_identifiable", why, verdict.instead) and "hold" in verdict.instead


@pytest.mark.parametrize(
    ("stderr", "ci", "words"),
    [
        (None, None, "no standard error and no interval"),
        (math.inf, None, "no standard error and no interval"),
        (1e-5, (-2e-5, 2.2e-4), "reaches zero"),
        (1e-5, (1e-5, math.inf), "unbounded"),
    ],
)
def test_intervals_that_do_not_bound_the_value(stderr, ci, words):
    est = Estimate("E_t", 1e-4, stderr, ci, 40, "linear")
    verdict = status(est, fit_of(est))
    assert verdict.status == "not_identifiable" and words in verdict.reason


def test_correlation_strong_is_check_and_inseparable_is_not_identifiable():
    k1, eta = estimate("sls_k1", 100.0), estimate("sls_eta", 500.0)
    cases = ((0.5, "ok"), (STRONG_R, "check"), (-0.99, "check"), (INSEPARABLE_R, "not_identifiable"))
    for r, expected in cases:
        fit = fit_of(k1, eta, correlation={"sls_k1|sls_eta": r})
        assert status(k1, fit).status == status(eta, fit).status == expected, r
    fit = fit_of(k1, eta, correlation={"sls_k1|sls_eta": -0.9995})
    assert "sls_eta" in status(k1, fit).reason and "sls_k1" in status(eta, fit).reason
    e_e = estimate("E_e", 100.0)  # E_e is the SLS's k1: k1's correlations are its own
    assert status(e_e, fit_of(e_e, eta, correlation={"sls_k1|sls_eta": 0.97})).status == "check"


def test_a_warning_of_the_fit_or_of_the_value_is_check():
    est = estimate(warnings=["torque offset of 2 % full scale"])
    assert status(est, fit_of(est)) == Status("check", "torque offset of 2 % full scale")
    plain = estimate()
    verdict = status(plain, fit_of(plain, warnings=["the SLS misses the hold"]))
    assert verdict == Status("check", "the SLS misses the hold")


def test_misfit_without_a_warning_text_is_check():
    est = estimate()
    fit = fit_of(est, info={"lack_of_fit": {"misfit": True, "reduced_chi2": 9.0}})
    assert status(est, fit).status == "check" and "lack of fit" in status(est, fit).reason
    assert status(est, fit_of(est, info={"lack_of_fit": {"misfit": False}})).status == "ok"


def test_model_form_error_in_a_record_widens_the_interval_or_makes_the_status_check():
    """A torsion record whose torque bends away from the line, fitted by a line over all its rows:
    softening by 8 % at the end widens the interval (residuals correlated: the sandwich), by 20 % the
    fit reports a misfit and the status is check; the same record made straight is ok."""
    rng = np.random.default_rng(21)
    x = np.linspace(0.0, 2.0, 200)
    noise = rng.normal(0.0, 2e-6, x.size)
    verdicts, widths = [], []
    for curvature in (0.0, 0.04, 0.1):
        y = 1e-4 * x * (1 - curvature * x) + noise
        line = fit_lines([record("torsion.csv", x, y, np.ones(x.size, dtype=bool))])
        est = Estimate("E_t", *line.value, "linear")
        warn = line.lof.warning("the line torque = c + E_t x")
        fit = fit_of(est, warnings=[warn] if warn else [], info={"lack_of_fit": line.lof.as_info()})
        verdicts.append(status(est, fit).status)
        widths.append(est.ci95[1] - est.ci95[0])
    assert verdicts == ["ok", "ok", "check"]
    assert widths[1] > 2 * widths[0]


# --- where the status shows ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def slit(tmp_path_factory):
    """The small demo study (extension, bending, torsion of T1) with T1 declared a slit tube."""
    folder = small_study(tmp_path_factory.mktemp("slit"))
    toml = (folder / "study.toml").read_text()
    slit_tube = toml.replace('inner_diameter = "1.6 mm"', 'inner_diameter = "1.6 mm"\nslit = true', 1)
    (folder / "study.toml").write_text(slit_tube)
    study = load_study(folder)
    assert study.specimen("T1").slit
    return pipeline.run_study(study)


def test_slit_tube_E_s_torsion_has_no_number_anywhere(slit):
    rows = {r["parameter"]: r for r in csv.DictReader(io.StringIO(stiffness_csv(slit)))}
    assert next(csv.reader(io.StringIO(stiffness_csv(slit)))) == CSV_COLUMNS and CSV_COLUMNS[-1] == "status"
    row = rows["E_s_torsion"]
    assert row["status"] == "not_identifiable"
    assert (row["value"], row["stderr"], row["ci95_low"], row["ci95_high"]) == ("", "", "", "")
    assert row["warnings"].startswith("not identifiable: E_s_torsion is not given for an open (slit) tube")
    assert "measure instead" in row["warnings"]
    assert rows["E_t"]["status"] == "ok" and float(rows["E_t"]["value"]) > 0
    item = json.loads(json.dumps(stiffness_json(slit), allow_nan=False))["specimens"]["T1"]["E_s_torsion"]
    assert item["value"] is None and item["ci95"] is None and item["status"] == "not_identifiable"
    assert item["measure_instead"] and "open (slit) tube" in item["status_reason"]
    table = FitResult(slit).table()
    assert list(table.columns) == CSV_COLUMNS
    one = table.set_index("parameter").loc["E_s_torsion"]
    assert one["status"] == "not_identifiable" and math.isnan(one["value"])  # pandas: missing
    book = openpyxl.load_workbook(io.BytesIO(stiffness_xlsx(slit)), read_only=True)
    sheet = list(book["stiffness"].iter_rows(values_only=True))
    assert sheet[0][-1] == "status"
    by_name = {r[1]: r for r in sheet[1:]}
    assert by_name["E_s_torsion"][-1] == "not_identifiable" and by_name["E_s_torsion"][2] is None


def test_every_value_has_a_status_in_every_output(slit):
    rows = list(csv.DictReader(io.StringIO(stiffness_csv(slit))))
    doc = stiffness_json(slit)
    assert rows and all(r["status"] in ("ok", "check", "not_identifiable") for r in rows)
    for r in rows:
        assert doc["specimens"][r["specimen"]][r["parameter"]]["status"] == r["status"]
        assert (r["value"] == "") == (r["status"] == "not_identifiable")


def test_a_check_status_whose_reason_is_no_warning_adds_it_to_the_warnings(slit):
    fit = next(f for f in slit.fits if f.kind == "extension")
    strong = dataclasses.replace(fit, correlation={"sls_k1|sls_eta": -0.97})
    result = dataclasses.replace(slit, fits=tuple(strong if f is fit else f for f in slit.fits))
    rows = {r["parameter"]: r for r in csv.DictReader(io.StringIO(stiffness_csv(result)))}
    assert rows["sls_eta"]["status"] == "check"
    assert "strongly correlated with sls_k1 (r = -0.970)" in rows["sls_eta"]["warnings"]


# --- a second lab's slit-tube torsion record (corpus) -----------------------------------------------

SLIT_RECORD = TESTS / "corpus" / "bluehill_slit_torsion.csv"
SLIT_STUDY = f"""
[study]
name = "slit tube, second lab"

[[specimen]]
id = "S2"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"
slit = true

[[test]]
kind = "torsion"
specimen = "S2"
file = "{SLIT_RECORD.name}"
length = "60 mm"
columns = {{ twist_angle = "Rotation", torque = "Torque" }}
"""


def test_slit_tube_record_gives_G_of_the_open_wall_and_no_E_s_torsion(tmp_path):
    """G by hand: the slope of the record's last and first rows (csv module, deg and N.mm to SI)
    times the gauge length, over the thin open wall's J = (1/3) 2 pi R_m t^3."""
    (tmp_path / "study.toml").write_text(SLIT_STUDY)
    shutil.copy(SLIT_RECORD, tmp_path)  # a study reads only its own folder (contract section 11)
    study = load_study(tmp_path)
    result = pipeline.run_study(study)
    rows = [r for r in csv.reader(SLIT_RECORD.read_text().splitlines()[8:]) if r]
    (_, a0, q0), (_, a1, q1) = rows[0], rows[-1]
    slope = (float(q1) - float(q0)) * 1e-3 / math.radians(float(a1) - float(a0))
    R_m, t = 1.0e-3, 0.4e-3
    G_hand = slope * 60e-3 / (2 * math.pi * R_m * t**3 / 3)
    E_t = next(f for f in result.fits if f.kind == "torsion").estimate("E_t")
    G = modulus("E_t", E_t.value, E_t.stderr, section=study.specimen("S2").section)
    assert G.value == pytest.approx(G_hand, rel=0.02)
    closed = modulus("E_t", E_t.value, E_t.stderr, section=Section("tube", 2.4e-3, 1.6e-3))
    assert closed.value < G.value / 10  # the closed-tube J would make G ~13x too small
    table = {r["parameter"]: r for r in csv.DictReader(io.StringIO(stiffness_csv(result)))}
    assert table["E_t"]["status"] == "ok"
    assert table["E_s_torsion"]["status"] == "not_identifiable" and table["E_s_torsion"]["value"] == ""
