"""matid.rod.stability: the eigenvalue test of loads without a potential, on states reached with
the test switched off (Newton converges to saddles and unstable states as well)."""

from __future__ import annotations

import numpy as np
import pytest

from matid.rod import cantilever, stability
from matid.rod.newton import follow
from matid.rod.system import RodSystem
from tests.rod.test_designer_stability import _oblique_moment, _saddle_scene


class Untested(RodSystem):
    """The rod without its admissibility test: follow returns whatever Newton converges to."""

    def reject(self, X, lam, factor=None):
        return None


def _state(scene, lams, elements=16):
    model, _, rod, loads, at = cantilever.prepare_scene(scene, "auto")
    disc = cantilever.mesh(elements, at, 7, "P2", 2)
    system = Untested(
        disc, rod, loads, model=model, c_u=cantilever.default_penalty(rod, "normalised"), banded=True
    )
    x, lam0 = system.reduce(system.reference()), 0.0
    for lam in lams:
        x, _ = follow(system, x, [lam], lam0=lam0)
        lam0 = lam
    return system, x, lam0


def test_the_saddle_of_the_tip_magnet_has_two_negative_real_eigenvalues():
    """The 174 deg / q = 5.8 scene with its 1e-6 N m twist: Newton from the straight rod lands on
    the saddle (tip 7.3 deg off the axis); the pencil has two real negative eigenvalues."""
    system, x, lam = _state(_saddle_scene(1e-6), [1.0])
    assert not system.symmetric
    assert system.negative_modes(x, lam) == 2
    assert np.all(system.unstable.real < -1e3) and np.all(np.abs(system.unstable.imag) < 1e-6 * 1e3)


def test_the_saddle_is_refused_by_reject():
    system, x, lam = _state(_saddle_scene(1e-6), [1.0])
    reason = RodSystem.reject(system, x, lam)
    assert reason is not None and "2 eigenvalue(s)" in reason


@pytest.mark.parametrize("lam, unstable", [(0.6, 0), (0.8, 2)])
def test_arpack_and_lapack_give_the_same_unstable_modes(lam, unstable, monkeypatch):
    """M L/E_b = 10 about (1, 1, 0.5): stable at load factor 0.6, a complex pair in the left
    half-plane at 0.8; the shift-invert of the 24 eigenvalues nearest zero finds what QZ finds."""
    system, x, lam = _state(_oblique_moment(10.0), [0.4, lam])
    K = system.evaluate(x, lam)[1]
    monkeypatch.setattr(stability, "DENSE", 10**9)
    dense = stability.unstable_modes(K.tocsr(), system.drag)
    monkeypatch.setattr(stability, "DENSE", 0)
    sparse = stability.unstable_modes(K.tocsr(), system.drag, K.factor)
    assert dense.size == sparse.size == unstable
    # QZ is backward stable on the whole pencil, whose largest eigenvalues (extension, the gauge)
    # are ~1e10 times these: 1e-5 relative is its accuracy here, not a loosened bound
    np.testing.assert_allclose(np.sort(dense.real), np.sort(sparse.real), rtol=1e-5)
    np.testing.assert_allclose(np.sort(np.abs(dense.imag)), np.sort(np.abs(sparse.imag)), rtol=1e-5)


def test_a_positive_definite_symmetric_part_is_stable_for_any_drag():
    """Positive second-order work (|M| = 1 E_b/L): Re lambda > 0 for the stated drag and others."""
    system, x, lam = _state(_oblique_moment(1.0), [1.0])
    K = system.evaluate(x, lam)[1].tocsr()
    assert stability.ldl_negative((K + K.T) * 0.5) == 0
    for rotary in (1e-6, 1.0, 1e3):
        assert stability.unstable_modes(K, stability.drag(system.disc, rotary), None).size == 0
