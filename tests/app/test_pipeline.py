"""The pipeline: dispatch of fits per specimen and kind, fixed values, failures, atomic outputs."""

from __future__ import annotations

import hashlib
import json
import shutil
from datetime import datetime
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from matid.app import pipeline
from matid.app.pipeline import FITTERS, run_study, write_outputs
from matid.errors import ConvergenceError, DataError, FitError
from matid.io.study import load_study
from matid.model.results import Estimate
from matid.model.results import TestFit as Fit

DEMO = Path(str(resources.files("matid.example")))
OUTPUTS = {"report.html", "report.pdf", "stiffness.csv", "stiffness.json", "stiffness.xlsx"}

SPECIMEN = """
[study]
name = "small T1 study"

[[specimen]]
id = "T1"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"
"""

TESTS = {
    "extension": 'gauge_length = "50 mm"',
    "magnetic_bending": 'free_length = "60 mm"\nmagnet_moment = "0.0125 A m^2"',
    "torsion": 'length = "60 mm"',
    "three_point_bend": 'span = "10 mm"\nspecimen_length = "30 mm"\n'
    'support_radius = "2 mm"\nnose_radius = "2 mm"',
}
FILES = {
    "extension": "extension_T1_r1.csv",
    "magnetic_bending": "bending_T1_L60.csv",
    "torsion": "torsion_T1_L60.csv",
    "three_point_bend": "3pb_T1_S10.csv",
}


def small_study(folder: Path, *, fixed: str = "", exclude: tuple[str, ...] = ()) -> Path:
    """One test of each kind on T1, files copied from the demo study."""
    text = [SPECIMEN]
    for kind, setup in TESTS.items():
        shutil.copy(DEMO / FILES[kind], folder / FILES[kind])
        flag = "\nexclude = true" if kind in exclude else ""
        text.append(f'[[test]]\nkind = "{kind}"\nspecimen = "T1"\nfile = "{FILES[kind]}"\n{setup}{flag}\n')
    (folder / "study.toml").write_text("\n".join(text) + fixed, encoding="utf-8")
    return folder / "study.toml"


def fake_fit(parameter: str, value: float, calls: list | None = None):
    """A fitter giving ``parameter`` = ``value`` that records its keyword arguments."""

    def fit(measurements, *, specimen, fixed, known) -> Fit:
        if calls is not None:
            calls.append({"tests": [m.test for m in measurements], "fixed": fixed, "known": known})
        kind = measurements[0].test.kind
        est = Estimate(parameter, value, 0.01 * value, None, 10, "fake")
        return Fit(kind, specimen.id, tuple(m.test for m in measurements), (est,), (), "x", "y")

    return fit


def raising(exc: BaseException):
    def fit(measurements, *, specimen, fixed, known) -> Fit:
        raise exc

    return fit


@pytest.fixture(scope="module")
def demo():
    return run_study(load_study(DEMO))


def truth() -> dict:
    return json.loads((DEMO / "ground_truth.json").read_text())["specimens"]


def test_demo_fits_close_to_ground_truth(demo):
    table = demo.estimates()
    for sid, expected in truth().items():
        assert table[sid]["E_e"].value == pytest.approx(expected["E_e"], rel=0.005)
        assert table[sid]["E_b"].value == pytest.approx(expected["E_b"], rel=0.005)
        assert table[sid]["E_t"].value == pytest.approx(expected["E_t"], rel=0.01)
    assert demo.ok and not demo.failures


def test_demo_fits_e_s_after_e_b_and_e_e(demo):
    assert not demo.pending and not demo.failures
    for sid, params in demo.estimates().items():
        assert params["E_s"].method == "cosserat-fe"
        bend = next(f for f in demo.fits if f.kind == "three_point_bend" and f.specimen == sid)
        # the bend fit held the specimen's own fitted E_b and E_e
        assert bend.info["E_b_used"] == params["E_b"].value
        assert bend.info["E_e_used"] == params["E_e"].value


def test_demo_records_every_input_file(demo):
    study = demo.study
    assert [f.path for f in demo.inputs] == [t.file for t in study.tests]
    for item in demo.inputs:
        assert item.sha256 == hashlib.sha256(item.path.read_bytes()).hexdigest()
        assert item.n_rows > 0 and item.units
    assert demo.inputs[0].metadata["specimen"] == "T1"


def test_demo_records_run_and_versions(demo):
    assert datetime.fromisoformat(demo.started).tzinfo is not None
    assert demo.runtime_s > 0
    expected = {"matid", "numpy", "scipy", "lmfit", "scikit-fem", "pint", "matplotlib", "python"}
    assert set(demo.versions) == expected


def test_progress_names_each_fit(tmp_path):
    lines: list[str] = []
    result = run_study(load_study(small_study(tmp_path)), progress=lines.append)
    assert result.ok, result.failures  # every fit ran to its end, the bend's solver included
    assert any("fitting torsion T1" in line and "torsion_T1_L60.csv" in line for line in lines)
    assert any(line.startswith("torsion T1: done in") for line in lines)


def test_bend_fitter_sees_earlier_estimates(tmp_path, monkeypatch):
    calls: list[dict] = []
    monkeypatch.setitem(FITTERS, "extension", fake_fit("E_e", 120.0))
    monkeypatch.setitem(FITTERS, "magnetic_bending", fake_fit("E_b", 6.5e-5))
    monkeypatch.setitem(FITTERS, "three_point_bend", fake_fit("E_s", 21.0, calls))
    result = run_study(load_study(small_study(tmp_path)))
    (call,) = calls
    assert call["known"]["E_e"].value == 120.0 and call["known"]["E_b"].value == 6.5e-5
    assert result.estimates()["T1"]["E_s"].value == 21.0
    assert not result.pending


def test_fixed_parameter_is_reported_not_fitted(tmp_path, monkeypatch):
    fixed = '\n[[fixed]]\nspecimen = "T1"\nparameter = "E_b"\nvalue = "7e-5 N m^2"\n'
    calls: list[dict] = []
    monkeypatch.setitem(FITTERS, "magnetic_bending", raising(AssertionError("must not run")))
    monkeypatch.setitem(FITTERS, "three_point_bend", fake_fit("E_s", 21.0, calls))
    result = run_study(load_study(small_study(tmp_path, fixed=fixed)))
    e_b = result.estimates()["T1"]["E_b"]
    assert (e_b.value, e_b.method, e_b.stderr) == (7e-5, "fixed", None)
    assert [f.kind for f in result.fits if f.kind == "magnetic_bending"] == []
    assert calls[0]["known"]["E_b"].method == "fixed"


def test_fixed_sls_values_go_to_the_extension_fit(tmp_path, monkeypatch):
    fixed = '\n[[fixed]]\nspecimen = "T1"\nparameter = "E_e"\nvalue = "120 N"\n'
    calls: list[dict] = []
    monkeypatch.setitem(FITTERS, "extension", fake_fit("sls_k2", 90.0, calls))
    result = run_study(load_study(small_study(tmp_path, fixed=fixed)))
    assert calls[0]["fixed"] == {"E_e": 120.0}
    assert result.ok, result.failures


def test_real_extension_fit_holds_fixed_e_e(tmp_path):
    fixed = '\n[[fixed]]\nspecimen = "T1"\nparameter = "E_e"\nvalue = "121 N"\n'
    result = run_study(load_study(small_study(tmp_path, fixed=fixed)))
    assert result.ok, result.failures
    fit = next(f for f in result.fits if f.kind == "extension")
    assert fit.estimate("E_e").value == 121.0 and fit.estimate("E_e").method == "fixed"
    assert fit.estimate("sls_k2").method == "sls"


def test_all_sls_parameters_fixed_skips_extension(tmp_path, monkeypatch):
    fixed = "".join(
        f'\n[[fixed]]\nspecimen = "T1"\nparameter = "{p}"\nvalue = {v}\n'
        for p, v in [("E_e", 120.0), ("sls_k2", 90.0), ("sls_eta", 450.0)]
    )
    monkeypatch.setitem(FITTERS, "extension", raising(AssertionError("must not run")))
    result = run_study(load_study(small_study(tmp_path, fixed=fixed)))
    assert result.estimates()["T1"]["sls_eta"].method == "fixed"
    assert result.ok


def test_different_fixed_e_e_and_sls_k1_is_a_data_error(tmp_path):
    fixed = "".join(
        f'\n[[fixed]]\nspecimen = "T1"\nparameter = "{p}"\nvalue = {v}\n'
        for p, v in [("E_e", 120.0), ("sls_k1", 121.0)]
    )
    with pytest.raises(DataError, match=r"study\.toml.*E_e and sls_k1"):
        run_study(load_study(small_study(tmp_path, fixed=fixed)))


def test_excluded_tests_are_not_fitted(tmp_path, monkeypatch):
    monkeypatch.setitem(FITTERS, "torsion", raising(AssertionError("must not run")))
    result = run_study(load_study(small_study(tmp_path, exclude=("torsion",))))
    (excluded,) = [p for p in result.pending if p.kind == "torsion"]
    assert "excluded" in excluded.reason
    assert result.ok and "E_t" not in result.estimates()["T1"]
    assert len(result.inputs) == 4  # excluded files are still read and listed


@pytest.mark.parametrize(
    "exc",
    [FitError("slope undefined"), ConvergenceError("no equilibrium", load_factor=0.4),
     np.linalg.LinAlgError("singular matrix")],
)  # fmt: skip
def test_failed_fit_is_recorded_and_the_run_goes_on(tmp_path, monkeypatch, exc):
    monkeypatch.setitem(FITTERS, "torsion", raising(exc))
    result = run_study(load_study(small_study(tmp_path)))
    (failure,) = result.failures
    assert (failure.kind, failure.specimen) == ("torsion", "T1")
    assert str(exc) in failure.reason
    assert not result.ok
    assert {"E_b", "E_e"} <= set(result.estimates()["T1"])


def test_fit_data_error_propagates(tmp_path, monkeypatch):
    monkeypatch.setitem(FITTERS, "torsion", raising(DataError("bad torque", file="t.csv")))
    with pytest.raises(DataError, match="t.csv"):
        run_study(load_study(small_study(tmp_path)))


def test_programming_errors_are_not_swallowed(tmp_path, monkeypatch):
    monkeypatch.setitem(FITTERS, "torsion", raising(TypeError("bug")))
    with pytest.raises(TypeError, match="bug"):
        run_study(load_study(small_study(tmp_path)))


def test_bend_fitter_without_tests_fails_clearly():
    with pytest.raises(FitError, match="no three-point-bend tests"):
        FITTERS["three_point_bend"]([], specimen=None, fixed={}, known={})


def test_write_outputs_writes_every_file(tmp_path, demo):
    paths = write_outputs(demo, tmp_path / "out", units="cgs")
    assert {p.name for p in paths} == OUTPUTS
    assert {p.name for p in (tmp_path / "out").iterdir()} == OUTPUTS
    doc = json.loads((tmp_path / "out" / "stiffness.json").read_text())
    assert doc["unit_system"] == "cgs"


def test_write_outputs_renders_before_writing(tmp_path, demo, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    for name in OUTPUTS:
        (out / name).write_text(f"old {name}")

    def broken(result, *, units):
        raise RuntimeError("renderer crashed")

    monkeypatch.setattr(pipeline, "render_report", broken)
    with pytest.raises(RuntimeError, match="renderer crashed"):
        write_outputs(demo, out)
    assert {p.name: p.read_text() for p in out.iterdir()} == {n: f"old {n}" for n in OUTPUTS}
