"""The planar field term (matid.physics.planar.magnetic) against derivatives of its energy written
here, in both layouts of the Hessian."""

from __future__ import annotations

import numpy as np
import pytest

from matid.physics import planar


def _energy(t, mu, B):
    """The field's energy per length in the plane, -mu (sin t Bx + cos t Bz)."""
    return -mu * (np.sin(t) * B[0] + np.cos(t) * B[2])


@pytest.mark.parametrize("compact", [False, True])
def test_the_field_term_adds_the_derivatives_of_its_energy_in_theta(compact: bool) -> None:
    rng = np.random.default_rng(4)
    P = (3, 2)
    z = rng.normal(size=P + (6,))
    mu = rng.uniform(0.5, 2.0, P)
    B = (0.7, 0.0, -0.4)
    g = np.zeros(P + (6,))
    H = np.zeros((7,) + P) if compact else np.zeros(P + (6, 6))
    planar.magnetic(g, H, z, mu, B, compact=compact)
    t, h = z[..., 2], 1e-4
    dE = (_energy(t + h, mu, B) - _energy(t - h, mu, B)) / (2 * h)
    d2E = (_energy(t + h, mu, B) - 2 * _energy(t, mu, B) + _energy(t - h, mu, B)) / h**2
    assert g[..., 2] == pytest.approx(dE, abs=1e-7)
    others = np.delete(g, 2, axis=-1)
    assert not others.any()  # the field acts on the angle only
    tt = H[0] if compact else H[..., 2, 2]
    assert tt == pytest.approx(d2E, abs=1e-6)
    rest = H[1:] if compact else H.reshape(P + (36,))[..., [i for i in range(36) if i != 14]]
    assert not rest.any()
