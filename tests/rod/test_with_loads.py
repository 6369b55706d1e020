"""RodSystem.with_loads (the field sensitivities of [aim]): the system of other loads, bound anew."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from matid.rod.cantilever import default_penalty, equilibrium, prepare_scene, scaled
from matid.rod.models import FULL
from matid.rod.scenes import load_scene
from matid.rod.system import RodSystem
from tests import ROOT

EXAMPLES = ROOT / "examples" / "scenes"


@pytest.mark.parametrize("name", ["aim", "magnetization_direction", "magnet_direction"])
def test_with_loads_is_a_new_system_of_those_loads(name: str) -> None:
    """At a converged state of the scene, the rebound system in another field has the residual and
    tangent, to the bit, of a RodSystem built from scratch in that field, and differs from the
    original system's (the loads were rebound, not kept)."""
    scene = dataclasses.replace(load_scene(EXAMPLES / f"{name}.toml"), aim=None)
    if not any(scene.loads.B):
        scene = dataclasses.replace(scene, loads=dataclasses.replace(scene.loads, B=(0.0, 0.0, 0.05)))
    eq = equilibrium(scene, elements=8, model=FULL)
    _, _, rod, loads, _ = prepare_scene(scene, FULL)
    c_u = default_penalty(rod, "normalised")
    system = RodSystem(eq.disc, rod, loads, model=FULL, c_u=c_u, banded=True)
    X = system.reduce(eq.U.ravel())
    other = dataclasses.replace(scene, loads=dataclasses.replace(scene.loads, B=(0.03, -0.02, 0.01)))
    new_loads = scaled(other, None)[1]
    fresh = RodSystem(eq.disc, rod, new_loads, model=FULL, c_u=c_u, banded=True)
    rebound = system.with_loads(new_loads)
    R1, K1 = fresh.evaluate(X, 1.0)
    R2, K2 = rebound.evaluate(X, 1.0)
    assert np.array_equal(R1, R2)
    assert np.array_equal(K1.ab, K2.ab)
    assert rebound.terms == fresh.terms and rebound.symmetric == fresh.symmetric
    R0 = system.evaluate(X, 1.0)[0]
    assert np.abs(R0 - R2).max() > 1e-8  # another field: another residual


def test_with_loads_reads_the_symmetry_of_its_own_terms() -> None:
    """A dead tip moment in 3D has no potential: the system rebound with one is unsymmetric even
    after the original (symmetric) system was asked."""
    scene = dataclasses.replace(load_scene(EXAMPLES / "magnet_direction.toml"), aim=None)
    eq = equilibrium(scene, elements=4, model=FULL)
    _, _, rod, loads, _ = prepare_scene(scene, FULL)
    system = RodSystem(eq.disc, rod, loads, model=FULL, c_u=default_penalty(rod, "normalised"), banded=True)
    assert system.symmetric
    twisted = dataclasses.replace(scene, loads=dataclasses.replace(scene.loads, tip_moment=(0.0, 1e-5, 2e-5)))
    rebound = system.with_loads(scaled(twisted, None)[1])
    assert not rebound.symmetric
    assert system.symmetric
