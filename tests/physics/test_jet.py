"""Jet arithmetic (matid.physics.jet) against derivatives written out by hand."""

from __future__ import annotations

import numpy as np

from matid.physics import jet
from matid.physics.jet import Jet

X, Y = np.array([0.3, -1.2]), np.array([2.0, 0.7])  # two points


def _xy(hessian: bool = True) -> tuple[Jet, Jet]:
    return tuple(Jet.variables(np.stack([X, Y]), hessian=hessian))


def test_a_number_minus_a_jet():
    x, _ = _xy()
    f = 3.0 - x
    np.testing.assert_allclose(f.v, 3.0 - X)
    np.testing.assert_allclose(f.g, np.broadcast_to([-1.0, 0.0], (2, 2)))
    np.testing.assert_allclose(f.h, 0.0)


def test_quotients_of_jets_and_by_numbers():
    """d(x/y) = (1/y, -x/y^2), d2(x/y) = [[0, -1/y^2], [-1/y^2, 2x/y^3]]; x/2 = 0.5 x."""
    x, y = _xy()
    f = x / y
    np.testing.assert_allclose(f.v, X / Y)
    np.testing.assert_allclose(f.g, np.stack([1 / Y, -X / Y**2], axis=-1))
    hess = np.zeros((2, 2, 2))
    hess[:, 0, 1] = hess[:, 1, 0] = -1 / Y**2
    hess[:, 1, 1] = 2 * X / Y**3
    np.testing.assert_allclose(f.h, hess)
    half = x / 2.0
    np.testing.assert_allclose(half.v, X / 2)
    np.testing.assert_allclose(half.g, np.broadcast_to([0.5, 0.0], (2, 2)))


def test_the_chain_rule_without_a_hessian_keeps_the_gradient():
    """sin(x y) with gradients only: cos(x y) (y, x), no Hessian."""
    x, y = _xy(hessian=False)
    f = jet.sin(x * y)
    assert f.h is None
    np.testing.assert_allclose(f.v, np.sin(X * Y))
    np.testing.assert_allclose(f.g, np.cos(X * Y)[:, None] * np.stack([Y, X], axis=-1))
