"""The linear range of a record with little noise and a kink in its slope (matid/fits/onset.py).

A flexural coupon past yield, the law written here: a line, then a plastic hinge from YIELD on whose
slope falls linearly to zero over SOFT (a jump in the second derivative), with noise of 0.004 N on
forces up to 73 N. A Legendre series of degree 12 cannot follow that kink: its residuals stayed
~4x the noise and, read as AR(1) noise (rho 0.98, variance factor 81, n_eff 3.5), hid the yield
from the curvature test (p = 0.19: every row, yield included, taken as the line).
"""

import numpy as np
import pytest

from matid.fits import onset

SLOPE, YIELD, SOFT = 52.0e3, 1.3e-3, 0.4e-3  # N/m, m, m


def _coupon(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    d = np.linspace(0.3e-3, 1.7e-3, 281)
    force = SLOPE * (d - 0.3e-3) - 0.5 * SLOPE * np.maximum(d - YIELD, 0.0) ** 2 / SOFT
    return d, force + rng.normal(0.0, 0.004, d.size)


@pytest.mark.parametrize("seed", range(5))
def test_a_yield_kink_on_a_quiet_record_ends_the_linear_range(seed):
    d, force = _coupon(seed)
    top = float(d[onset.linear_range(d, force)].max())
    assert YIELD - 0.1e-3 <= top <= YIELD + 0.05e-3, top


@pytest.mark.parametrize("seed", range(3))
def test_noise_alone_keeps_the_whole_line(seed):
    """The series' degree rises only while it misses a curve: on a plain line with i.i.d. noise it
    stays, and every row is the linear range."""
    rng = np.random.default_rng(seed)
    d = np.linspace(0.0, 1.0e-3, 281)
    force = SLOPE * d + rng.normal(0.0, 0.004, d.size)
    assert onset.linear_range(d, force).all()
