"""The standard linear solid's force (matid.physics.sls) on closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from matid.physics.sls import sls_force

K1, K2, ETA = 40.0, 25.0, 125.0  # N, N, N s: tau = 5 s


def test_one_interval_is_the_ramp_closed_form():
    """Two samples, a ramp of rate r for t: F = k1 r t + eta r (1 - exp(-t / tau))."""
    t, r = 1.5, 0.01
    force = sls_force(np.array([0.0, t]), np.array([0.0, r * t]), K1, K2, ETA)
    closed = K1 * r * t + ETA * r * (1.0 - np.exp(-t * K2 / ETA))
    assert force[0] == 0.0 and force[1] == pytest.approx(closed, rel=1e-13)


@pytest.mark.parametrize(("k2", "eta"), [(0.0, ETA), (K2, 0.0), (-1.0, ETA), (K2, -1.0)])
def test_k2_and_eta_must_be_positive(k2, eta):
    with pytest.raises(ValueError, match="k2 and eta must be positive"):
        sls_force(np.array([0.0, 1.0, 2.0]), np.array([0.0, 0.01, 0.02]), K1, k2, eta)
