"""A curve with no single slope: its linear range and the interval of its slope (issue 28 item 2).

The laws are written here (a tube whose torque softens from the first row on, as a closed tube on
a machine's angle channel does); the reference slopes are least-squares lines computed here over
windows a hand would take, never matid's own range.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.fits.branch import UNLOADING
from matid.fits.torsion import fit_torsion
from matid.model import study
from matid.model.measurement import Measurement, Table

LENGTH = 0.254  # m


def run(x: np.ndarray, torque: np.ndarray) -> Measurement:
    test = study.Test("torsion", "T1", Path("soft.csv"), {"length": LENGTH}, window={})
    table = Table(Path("soft.csv"), {"twist_angle": x * LENGTH, "torque": torque}, {}, {}, "")
    return Measurement(test, table)


def hand_slope(x: np.ndarray, torque: np.ndarray, share=(0.1, 0.8)) -> float:
    """Line over the rows whose torque lies in 10-80 % of its excursion (numpy only)."""
    lo, hi = torque.min() + np.array(share) * np.ptp(torque)
    keep = (torque >= lo) & (torque <= hi)
    return float(np.polyfit(x[keep], torque[keep], 1)[0])


def softening(seed: int, *, n=1143, bend=0.55, step=0.0014, noise=0.18):
    """torque = k x (1 - bend x) from the first row on, x read in steps of ``step`` (a quantised
    angle channel); k = 700 N m^2 / m over x up to 0.26 rad/m: the tangent falls 14 %."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 0.26, n)
    torque = 700.0 * x * (1.0 - bend * x) + rng.normal(0.0, noise, n)
    return np.round(x / step) * step, torque


@pytest.mark.parametrize("seed", range(4))
def test_a_curve_bent_from_the_start_keeps_its_linear_range_at_the_start(seed):
    """Regression (closed tube, machine angle: 12 of 1143 rows, E_t -22 %): the segmented fit put the
    upper onset a few rows after the start, a quadratic over the rest; the range then held 16-47
    rows and the slope scattered. Now such an onset is a curve bent from the start and trimming
    finds the range in the first half of the record (tangent 700 to 610; on the old code seed 0
    gave 559 from 16 rows), and the interval covers the hand's 10-80 % line (it did not for seeds 2, 3).
    Which part of a uniformly bent record trimming keeps still varies with the noise (-2 to -10 %
    from the tangent at the start here): the interval, not the value, carries that."""
    x, torque = softening(seed)
    est = fit_torsion([run(x, torque)], specimen="T1").estimate("E_t")
    assert est.n_points >= 0.1 * x.size
    assert est.value == pytest.approx(700.0, rel=0.1)
    assert est.ci95[0] <= hand_slope(x, torque) <= est.ci95[1]


@pytest.mark.parametrize("seed", range(3))
def test_the_interval_of_a_slope_that_depends_on_its_range_covers_the_other_ranges(seed):
    """Regression (slit tube: 2.087 [2.083, 2.090] against 2.019 over 10-80 % of the torque): where
    the line misses the data or holds few of the loading rows, the interval is the noise's on one
    range. Now it spans the slopes over the halves of the fitted and the accepted rows, and a
    warning says so and what to do."""
    x, torque = softening(seed, bend=1.0, step=1e-5, noise=0.05)
    est = fit_torsion([run(x, torque)], specimen="T1").estimate("E_t")
    spread = [w for w in est.warnings if "depends on the range fitted" in w]
    assert len(spread) == 1 and "Set a window" in spread[0]
    assert "range_spread" in est.extra["warning_kinds"]
    assert est.ci95[0] <= hand_slope(x, torque) <= est.ci95[1]
    assert est.ci95[0] <= hand_slope(x, torque, (0.05, 0.5)) <= est.ci95[1]


# --- a tube twisted from a preload, with a toe and softening, unloaded to rest past its start ----------

K_PRE, PEAK = 25.0, 2.3  # N m^2 (torque per twist per length), N m


def preloaded_twist(torque: np.ndarray, *, seat=0.029, plastic=0.03, start=0.17) -> np.ndarray:
    """Twist per length [rad/m] of the loading branch at ``torque``: elastic (K_PRE), plus a seating
    twist that grows from the preload ``start`` x PEAK as 1 - (1 - s)^3 until 0.3 PEAK (a toe), plus
    a plastic twist growing as the cube of the torque beyond PEAK / 2 (softening): linear in between."""
    s = np.clip((torque - start * PEAK) / ((0.3 - start) * PEAK), 0.0, 1.0)
    yielded = np.clip(torque - 0.5 * PEAK, 0.0, None) / (0.5 * PEAK)
    return (torque + seat * PEAK * (1 - (1 - s) ** 3) + plastic * 0.5 * PEAK * yielded**3) / K_PRE


def preloaded(seed: int, *, rows=2600, noise=0.0035, start=0.17) -> tuple[np.ndarray, np.ndarray]:
    """A record in the shape of an MTS TestSuite torsion export (mc-slit-angle): it starts under a
    preload, loads at a constant twist rate to PEAK, then unloads elastically (slope K_PRE, so the
    plastic and seating twists stay: hysteresis) to zero torque, past its start. Noise on torque."""
    grid = np.linspace(0.0, PEAK, 20001)
    curve = preloaded_twist(grid, start=start)
    x_up = np.linspace(preloaded_twist(np.array([start * PEAK]), start=start)[0], curve[-1], rows // 2)
    x_down = np.linspace(curve[-1], curve[-1] - PEAK / K_PRE, rows - rows // 2 + 1)[1:]
    torque = np.r_[np.interp(x_up, curve, grid), PEAK - K_PRE * (curve[-1] - x_down)]
    return np.r_[x_up, x_down], torque + np.random.default_rng(seed).normal(0.0, noise * PEAK, rows)


def loading_window_slope(x: np.ndarray, torque: np.ndarray, share=(0.1, 0.8)) -> float:
    """The benchmark's hand line (benchmarks/real_records_hand.torsion): rows from the start to the
    extreme torque whose rise lies in 10-80 % of the excursion (numpy only)."""
    peak = int(np.argmax(np.abs(torque - torque[0])))
    rise = np.abs(torque[: peak + 1] - torque[0]) / abs(torque[peak] - torque[0])
    keep = (rise >= share[0]) & (rise <= share[1])
    return float(np.polyfit(x[: peak + 1][keep], torque[: peak + 1][keep], 1)[0])


@pytest.mark.parametrize("seed", range(3))
def test_a_return_past_a_preloaded_start_is_not_loading(seed):
    """Regression (mc-slit-angle): the rows that unload from the preload to rest move away from the
    start, the other way; they were taken as a second loading (164 of the 1300 rows after the peak
    here, left out only as "before the linear range", where they pulled the onset test; with an
    exponential toe instead, E_t came out 20-50 % high in 4 of 10 seeds). Every row after the peak
    is now unloading."""
    x, torque = preloaded(seed)
    fit = fit_torsion([run(x, torque)], specimen="T1")
    assert fit.info["left_out"]["soft.csv"][UNLOADING] >= x.size - x.size // 2 - 1
    assert not fit.series[0].used[x.size // 2 :].any()
    assert fit.estimate("E_t").value == pytest.approx(K_PRE, rel=0.01)


@pytest.mark.slow
def test_the_interval_of_a_preloaded_record_covers_its_stiffness_and_the_hand_line():
    """Regression (mc-slit-angle: 25.42 "check" [25.26, 25.83], hand 25.14 over 10-80 % of the torque):
    the linear range lies between a toe and softening, under half of the loading rows; the interval
    spanned the halves of that range only, never the slopes with the rows left out on either side.
    Now, where the range holds few loading rows, it spans the range extended to either end too.
    Over 20 seeds the interval holds the law's K_PRE and the hand's line each in >= 18 (200 seeds:
    189 and 199, benchmarks/torsion_coverage.py); on the old code 5 and 8 of 20 (most values "ok"
    with a noise interval of ~0.2 %)."""
    hits = np.zeros((20, 2), dtype=bool)
    for seed in range(20):
        x, torque = preloaded(seed)
        est = fit_torsion([run(x, torque)], specimen="T1").estimate("E_t")
        assert est.value == pytest.approx(K_PRE, rel=0.01)
        hits[seed] = [est.ci95[0] <= v <= est.ci95[1] for v in (K_PRE, loading_window_slope(x, torque))]
    assert hits.sum(axis=0).min() >= 18, hits.sum(axis=0)


# --- a long dense record that softens a little: the onset test accepts it, trimming cuts the bend --------


def dense(seed: int, bend: float, *, n=5000, noise=1.0):
    """torque = 700 x (1 - bend x) over x up to 0.26 rad/m in n rows, white noise (N m)."""
    x = np.linspace(0.0, 0.26, n)
    return x, 700.0 * x * (1.0 - bend * x) + np.random.default_rng(seed).normal(0.0, noise, n)


@pytest.mark.parametrize("seed", range(4))
def test_a_dense_record_that_bends_a_little_is_not_ok_with_a_noise_interval(seed):
    """Regression (slit tube, extensometer channel: 1.976 [1.968, 1.984] "ok" against 1.949 over
    10-80 % of the torque): the onset test accepts the whole record as one line, trimming keeps
    the part where the bend is no longer significant, and the interval was that part's noise
    (the old code: no warning, the hand's line outside for every seed). A parabola over the
    accepted rows finds the bend; the interval then spans the slopes over the ranges."""
    x, torque = dense(seed, 0.03)
    est = fit_torsion([run(x, torque)], specimen="T1").estimate("E_t")
    assert "range_spread" in est.extra["warning_kinds"]
    assert any("accepts as one line bend" in w for w in est.warnings)
    assert est.ci95[0] <= hand_slope(x, torque) <= est.ci95[1]


@pytest.mark.parametrize("seed", range(4))
def test_a_dense_straight_record_keeps_its_noise_interval(seed):
    """A straight record of the same shape: no bend found, so no warning (status ok)."""
    x, torque = dense(seed, 0.0)
    est = fit_torsion([run(x, torque)], specimen="T1").estimate("E_t")
    assert est.warnings == ()
    assert est.value == pytest.approx(700.0, rel=0.002)
