"""Slack and preload before an extension run loads (matid/fits/extension/start.py, issue 28).

A grip that takes up slack moves the strain while the strip carries nothing, and a load cell that
was not zeroed adds a force the solid does not make. The records here come from laws written in
this file (the standard linear solid's closed form for a ramp and a hold, or a spring), not from
matid's model, with seeded noise: the crosshead travels a slack toe at the tare force, then the
strip, taut, answers from rest.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.app.pipeline import run_study
from matid.fits.extension import start
from matid.io.study import load_study
from matid.model.status import status
from tests.fits.extension.relaxation import write_bluehill

K1, K2, TAU = 40.0, 25.0, 5.0  # N, N, s
GAUGE = 0.05  # m
STRAIN = 0.04  # strain at the end of the ramp (of the taut strip)
DT = 0.05  # s


def sls_ramp_hold(s: np.ndarray, rate: float, ramp: float) -> np.ndarray:
    """Force of the SLS from rest, a ramp at ``rate`` lasting ``ramp`` s, then a hold, at times
    ``s`` since the strip became taut (closed form; 0 before)."""
    eta = K2 * TAU
    up = np.clip(s, 0.0, ramp)
    force = K1 * rate * up + eta * rate * (1.0 - np.exp(-up / TAU))
    after = s > ramp
    force[after] = K1 * rate * ramp + eta * rate * (1.0 - np.exp(-ramp / TAU)) * np.exp(
        -(s[after] - ramp) / TAU
    )
    return force


def slack_record(rate: float, *, slack: float, tare: float, hold: float, seed: int, noise: float = 0.003):
    """(t, crosshead strain, force): the crosshead travels ``slack`` (strain) at the tare force,
    then the taut strip is pulled by STRAIN at ``rate`` and held ``hold`` s."""
    rng = np.random.default_rng(seed)
    t_slack, ramp = slack / rate, STRAIN / rate
    t = np.arange(0.0, t_slack + ramp + hold + DT / 2, DT)
    eps = np.minimum(rate * t, slack + STRAIN)
    force = tare + sls_ramp_hold(t - t_slack, rate, ramp) + rng.normal(0.0, noise, t.size)
    return t, eps, force


def study(folder: Path, records, window: str = "") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    tests = []
    for i, (t, eps, force) in enumerate(records, 1):
        write_bluehill(folder / f"pull{i}.csv", t, eps * GAUGE, force)
        tests.append(
            f'[[test]]\nkind = "extension"\nspecimen = "S1"\nfile = "pull{i}.csv"\ngauge_length = "50 mm"\n'
            f'columns = {{ time = "Time", elongation = "Extension", force = "Load" }}\n{window}'
        )
    (folder / "study.toml").write_text(
        '[study]\nname = "slack"\n\n[[specimen]]\nid = "S1"\nouter_diameter = "2.4 mm"\n'
        'inner_diameter = "1.6 mm"\n\n' + "\n".join(tests),
        encoding="utf-8",
    )
    return folder / "study.toml"


def e_e_of(path: Path):
    (fit,) = run_study(load_study(path)).fits
    return fit, next(e for e in fit.estimates if e.parameter == "E_e")


@pytest.mark.parametrize("seed", range(3))
def test_sls_ramp_and_hold_after_a_slack_toe_and_a_tare_gives_E_e_within_1_percent(tmp_path, seed):
    """Slack 2 % of the ramp's strain at a 0.1 N tare (5 % of the peak force): the fit starts where
    the strip becomes taut, with the tare as a force offset, and says so."""
    record = slack_record(0.005, slack=0.02 * STRAIN, tare=0.1, hold=30.0, seed=seed)
    fit, e_e = e_e_of(study(tmp_path, [record]))
    assert e_e.value == pytest.approx(K1, rel=0.01)
    assert e_e.ci95[0] <= K1 <= e_e.ci95[1], e_e.ci95
    (said,) = [w for w in e_e.warnings if "slack before loading" in w]
    assert "force offset" in said
    (left,) = [n for reason, n in fit.info["left_out"]["pull1.csv"].items() if reason.startswith("slack")]
    t_slack = 0.02 * STRAIN / 0.005
    assert abs(left - t_slack / DT) <= 2, left  # the rows before the strip is taut, give or take one


@pytest.mark.parametrize("seed", range(3))
def test_two_rates_each_with_its_own_tare_and_slack(tmp_path, seed):
    """Two ramp-and-hold runs, different slack and tare each (a re-gripped strip, a load cell
    zeroed differently): one offset per run, E_e, k2 and eta back."""
    records = [
        slack_record(0.005, slack=0.03 * STRAIN, tare=0.08, hold=30.0, seed=seed),
        slack_record(0.02, slack=0.1 * STRAIN, tare=-0.05, hold=30.0, seed=seed + 10),
    ]
    fit, e_e = e_e_of(study(tmp_path, records))
    assert e_e.value == pytest.approx(K1, rel=0.01)
    values = {e.parameter: e.value for e in fit.estimates}
    assert values["sls_k2"] == pytest.approx(K2, rel=0.05)
    assert values["sls_eta"] == pytest.approx(K2 * TAU, rel=0.05)


@pytest.mark.parametrize("seed", range(3))
def test_a_single_elastic_ramp_after_slack_gives_its_slope(tmp_path, seed):
    """A hot tensile record's shape: a spring (no relaxation) pulled once after 12 s of slack at
    100 N, a window on the elastic part. A single ramp cannot resolve relaxation: E_e is the line's
    slope, within 1 % of the spring, status check with the reason."""
    rng = np.random.default_rng(seed)
    k, slack, rate = 3.3e6, 0.004, 5e-4
    t = np.arange(0.0, 20.0, 0.02)
    eps = rate * t
    force = 100.0 + k * np.maximum(eps - slack, 0.0) + rng.normal(0.0, 20.0, t.size)
    window = 'window = { elongation = ["0.22 mm", "0.4 mm"] }\n'
    fit, e_e = e_e_of(study(tmp_path, [(t, eps, force)], window))
    assert e_e.value == pytest.approx(k, rel=0.01)
    verdict = status(e_e, fit)
    assert verdict.status == "check"
    assert any("single ramp" in w for w in e_e.warnings)


# --------------------------------------------------------------------------- find


def _noise(force: np.ndarray) -> float:
    return float(np.std(np.diff(force, 2)) / np.sqrt(6.0))


def test_a_ramp_from_rest_at_zero_force_has_no_start():
    t = np.arange(0.0, 8.0, DT)
    force = sls_ramp_hold(t, 0.005, 8.0) + np.random.default_rng(0).normal(0.0, 0.003, t.size)
    assert start.find(0.005 * t, force, _noise(force)) is None


def test_a_record_whose_first_reading_is_on_the_ramp_has_no_start():
    """A fast ramp sampled slowly (a VHB relaxation): the force is 10 % of its peak at the first
    reading and leaves the band at the next; no rows lie before loading."""
    t = np.arange(0.02, 20.0, 0.02)
    eps = np.minimum(0.25 * t, 0.5)
    force = 0.3 * eps + 0.2 * (1.0 - np.exp(-t / 0.01)) * np.exp(-np.maximum(t - 2.0, 0.0) / 3.0)
    assert start.find(eps, force, 1e-3) is None


def test_slack_is_found_where_the_strip_becomes_taut():
    t, eps, force = slack_record(0.005, slack=0.1 * STRAIN, tare=0.0, hold=0.0, seed=1)
    found = start.find(eps, force, _noise(force))
    assert found is not None and found.kind == start.SLACK
    taut = int(round(0.1 * STRAIN / 0.005 / DT))
    assert abs(found.row - taut) <= 2, (found.row, taut)


def test_a_preload_held_at_rest_is_a_preload():
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 12.0, DT)
    eps = np.maximum(0.005 * (t - 2.0), 0.0)  # 2 s at rest, then the ramp
    force = 0.3 + K1 * eps + rng.normal(0.0, 0.003, t.size)
    found = start.find(eps, force, _noise(force))
    assert found is not None and found.kind == start.PRELOAD
    assert found.force == pytest.approx(0.3, abs=0.01)
    assert "0.3" in found.reason()


def test_the_plots_show_the_rows_before_the_strip_is_taut_as_not_used(tmp_path):
    """The fit starts where the strip becomes taut; its plots still draw every row of the file, the
    slack toe hollow (not used) and without a model line there (the old code dropped those rows
    from the series and the force-time figure)."""
    t, eps, force = slack_record(0.005, slack=0.2 * STRAIN, tare=0.1, hold=30.0, seed=0)
    fit, _ = e_e_of(study(tmp_path, [(t, eps, force)]))
    (series,) = fit.series
    assert series.x.size == t.size
    np.testing.assert_allclose(series.y, force, atol=1e-5)  # as the CSV holds them
    (left,) = [n for reason, n in fit.info["left_out"]["pull1.csv"].items() if reason.startswith("slack")]
    assert left > 10
    assert not series.used[:left].any() and series.used[left:].sum() > 0.9 * (t.size - left)
    assert np.isnan(series.y_fit[:left]).all() and np.isfinite(series.y_fit[left:]).all()
    plot = fit.info["plot_data"]["force_time"]["pull1.csv"]
    assert plot["time_s"].size == t.size and not plot["used"][:left].any()
    np.testing.assert_allclose(plot["time_s"], t, atol=1e-5)


# --- hand-made starts for what the mutation sample (benchmarks/mutation.sh, seed 29) showed ---


def _corner_record(scale: float = 1.0):
    """A noise-free spring behind slack: the strain moves 0.3 % per row, the strip becomes taut at
    strain 0.0093 (between rows 3 and 4: row 3 is the last one at or before it, and row 4 is already
    above the band), then its force rises K1 per unit strain to a peak; 2 rows hold it there.
    (eps, force, noise)."""
    eps = np.r_[0.003 * np.arange(30), np.full(2, 0.003 * 29)]
    force = scale * (0.1 + K1 * np.maximum(eps - 0.0093, 0.0))
    return eps, force, 0.0


def test_a_strip_taut_between_two_rows_starts_at_the_last_row_before_it():
    """The tangent of the taut strip meets the tare at strain 0.0093: the run starts at row 3
    (strain 0.009), the last row at or before it, a slack start (0.9 % of 8.7 % moved before)."""
    eps, force, noise = _corner_record()
    found = start.find(eps, force, noise)
    assert found is not None and found.kind == start.SLACK
    assert found.row == 3
    assert found.force == pytest.approx(0.1)
    assert found.strain == (eps[0], eps[3])  # from the first reading to the taut row


@pytest.mark.parametrize("scale", [1e-3, 1e3])
def test_the_start_does_not_depend_on_the_force_unit(scale):
    """The same record in mN or kN (force and noise scaled alike: a soft strip's slope below 1 N)
    has the same start."""
    eps, force, noise = _corner_record()
    for t, e, f in (slack_record(0.005, slack=0.1 * STRAIN, tare=0.05, hold=0.0, seed=1), (None, eps, force)):
        n = _noise(f) if t is not None else noise
        one, scaled = start.find(e, f, n), start.find(e, scale * f, scale * n)
        assert one is not None and scaled is not None
        assert (scaled.kind, scaled.row, scaled.strain) == (one.kind, one.row, one.strain)
        assert scaled.force == pytest.approx(scale * one.force)


def test_strain_taken_up_between_the_first_two_readings_is_slack():
    """The grip takes up 1 % strain between the first and the second reading, rests there at the
    tare, and the strip becomes taut at 1.1 % (between rows 9 and 10): the strain moved before the
    strip was taut, so the start is slack, spanning the first reading's strain to row 9's."""
    eps = np.r_[0.0, np.full(9, 0.01), 0.01 + 0.002 * np.arange(1, 41)]
    force = 0.2 + K1 * np.maximum(eps - 0.011, 0.0)
    found = start.find(eps, force, 0.0)
    assert found is not None and found.kind == start.SLACK
    assert found.strain[0] == 0.0 and found.row == 9


def test_a_preload_says_it_is_fitted_as_a_force_offset():
    eps = np.r_[np.zeros(10), 0.002 * np.arange(1, 41)]
    found = start.find(eps, 0.3 + K1 * eps, 0.0)
    assert found is not None and found.kind == start.PRELOAD
    assert found.reason().endswith("from rest with a force offset)")
