"""A curve with no single slope: its linear range and the interval of its slope (issue 28 item 2).

The laws are written here (a tube whose torque softens from the first row on, as a closed tube on
a machine's angle channel does); the reference slopes are least-squares lines computed here over
windows a hand would take, never matid's own range.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.fits.torsion import fit_torsion
from matid.model import study
from matid.model.measurement import Measurement, Table

LENGTH = 0.254  # m


def run(x: np.ndarray, torque: np.ndarray) -> Measurement:
    test = study.Test("torsion", "T1", Path("soft.csv"), {"length": LENGTH}, window={})
    return Measurement(test, Table(Path("soft.csv"), {"twist_angle": x * LENGTH, "torque": torque}, {}, {}, ""))


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
