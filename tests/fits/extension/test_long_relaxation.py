"""Long relaxation records (issue 21): a 90 000-row ramp and hour-long hold, integrated by
solve_ivp and written as an Instron Bluehill export (tests/fits/extension/relaxation.py), is
fitted, reported in SI and cgs and plotted as bin means; the fit on bin means agrees with
the fit on every row of a smaller record."""

from __future__ import annotations

import pytest

from matid.app.pipeline import run_study
from matid.fits.extension import reduce
from matid.io.results import stiffness_csv, stiffness_json
from matid.io.study import load_study
from tests.fits.extension.relaxation import ARMS, K0, make_study

TRUTH = {"prony_k0": K0, "prony_k1": ARMS[0][0], "prony_tau1": ARMS[0][1]}
TRUTH |= {"prony_k2": ARMS[1][0], "prony_tau2": ARMS[1][1]}
ROWS = 90_000


@pytest.fixture(scope="module")
def long_record(tmp_path_factory):
    return run_study(load_study(make_study(tmp_path_factory.mktemp("long"), n=ROWS, dt=0.05)))


def test_long_relaxation_is_fitted_and_reported_in_every_unit_system(long_record):
    """The generator's constants within 2 % (hand values: the record was made from them),
    and stiffness.json/.csv in SI and cgs with the time constants in seconds."""
    assert not long_record.failures
    (fit,) = long_record.fits
    estimates = {e.parameter: e for e in fit.estimates}
    for name, value in TRUTH.items():
        assert estimates[name].value == pytest.approx(value, rel=0.02), name
        assert estimates[name].n_points == ROWS
    for units in ("SI", "cgs"):
        doc = stiffness_json(long_record, units)["specimens"]["R1"]
        assert doc["prony_tau1"]["unit"] == doc["prony_tau2"]["unit"] == "s"
        assert doc["prony_tau2"]["value"] == pytest.approx(estimates["prony_tau2"].value)
        assert "prony_tau2" in stiffness_csv(long_record, units)


def test_plots_of_a_long_record_draw_bin_means(long_record):
    (fit,) = long_record.fits
    (series,) = fit.series
    assert 100 < series.x.size < 2000 and series.y.size == series.y_fit.size == series.x.size
    (curve,) = fit.info["plot_data"]["force_time"].values()
    assert curve["time_s"].size == series.x.size
    assert curve["time_s"][0] < 1.0 and curve["time_s"][-1] > 0.99 * (ROWS - 1) * 0.05


def _fit(folder, n, arms, seed, monkeypatch, reduce_above):
    monkeypatch.setattr(reduce, "REDUCE_ABOVE", reduce_above)
    result = run_study(load_study(make_study(folder, n=n, dt=0.5, seed=seed, arms=arms)))
    (fit,) = result.fits
    return {e.parameter: e for e in fit.estimates}


@pytest.mark.parametrize(
    "arms, names",
    [
        (((25.0, 10.0),), ("sls_k1", "sls_k2", "sls_eta")),
        (ARMS, ("prony_k0", "prony_k1", "prony_tau1", "prony_k2", "prony_tau2")),
    ],
)
def test_fit_on_bin_means_agrees_with_the_fit_on_every_row(tmp_path, monkeypatch, arms, names):
    """6000 rows (a 3000 s hold), AR(1) noise: the same values within two standard errors
    of their difference's scale, and the same standard errors within 5 %."""
    full = _fit(tmp_path / "full", 6000, arms, 1, monkeypatch, 10**9)
    binned = _fit(tmp_path / "binned", 6000, arms, 1, monkeypatch, 1000)
    for name in names:
        a, b = full[name], binned[name]
        assert b.n_points == a.n_points == 6000
        assert abs(b.value - a.value) < 2 * a.stderr, name
        assert b.stderr == pytest.approx(a.stderr, rel=0.05), name
