"""The plain cases kept (issue 28): records in the shapes test machines write, generated here by
laws written in this file (not matid's example generator), fitted back with seeded noise.

A short torsion tube leaves its linear range and passes a peak (the paper's Fig. 3): the torque
is ``E_t k`` up to an onset twist per length, then ``E_t (k - x^2 / (2 s))`` with x the excess,
which peaks at ``x = s`` and falls after it.
"""

import numpy as np
import pytest

from matid.fits import branch

E_T = 4.4e-5  # N m^2
ONSET, SCALE = 60.0, 150.0  # rad/m: linear up to ONSET; the peak at ONSET + SCALE


def _past_peak_torsion(length: float, step_deg: float, seed: int, noise: float = 0.002):
    rng = np.random.default_rng(seed)
    phi = np.deg2rad(np.arange(0.0, 180.0 + 1e-9, step_deg))
    k = phi / length
    excess = np.maximum(k - ONSET, 0.0)
    torque = E_T * (k - excess**2 / (2.0 * SCALE))
    return phi, torque + rng.normal(0.0, noise * np.max(np.abs(torque)), phi.size)


def _slope(rec) -> float:
    return float(np.polyfit(rec.x[rec.used], rec.y[rec.used], 1)[0])


@pytest.mark.parametrize("step_deg", [2.0, 4.0, 5.0])
@pytest.mark.parametrize("seed", range(5))
def test_short_torsion_tube_past_its_peak_gives_E_t_within_1_percent(step_deg, seed):
    length = 0.012  # the peak at 2.52 rad (144 deg): the record passes it and falls
    phi, torque = _past_peak_torsion(length, step_deg, seed)
    rec = branch.automatic(branch.record("torsion.csv", phi, torque, np.ones(phi.size, dtype=bool)))
    assert _slope(rec) * length == pytest.approx(E_T, rel=0.01)
    # at 1.25 x the onset the torque is ~3 noise deviations below the line: such rows must be out
    assert not np.any(rec.used & (phi / length > ONSET * 1.25)), "rows past the onset entered the line"


def test_rows_past_the_peak_are_left_out_with_their_reason():
    phi, torque = _past_peak_torsion(0.012, 2.0, seed=0)
    rec = branch.automatic(branch.record("torsion.csv", phi, torque, np.ones(phi.size, dtype=bool)))
    past = rec.excluded[branch.PAST_PEAK]
    peak = np.deg2rad(144.0)
    assert past.any() and np.all(phi[past] > peak - np.deg2rad(10.0))


@pytest.mark.parametrize("seed", range(3))
def test_a_softening_plateau_without_a_fall_is_not_cut_as_a_peak(seed):
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 1.0, 120)
    y = np.minimum(x, 0.6) + rng.normal(0.0, 1e-3, x.size)  # flat after 0.6: no fall
    assert not branch.past_peak(x, y).any()
