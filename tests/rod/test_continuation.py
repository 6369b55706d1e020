"""The continuation's first step (newton.definite_step): halved before any Newton while the
unloaded rod's tangent is not positive definite at the step's load; never changes the answer."""

import numpy as np
import pytest

from matid.bench import scenes as S
from matid.physics import kinematics as kin
from matid.rod.cantilever import default_penalty, equilibrium, mesh, prepare_scene, probe_start
from matid.rod.models import PLANAR
from matid.rod.newton import definite, definite_step, follow
from matid.rod.scenes import scene_from_dict
from matid.rod.system import RodSystem


def _system(scene, elements: int = 4) -> RodSystem:
    chosen, _, rod, loads, at = prepare_scene(scene, "auto")
    disc = mesh(elements, at, 3 if chosen == PLANAR else 7, "P2", 2)
    c_u = default_penalty(rod, kin.NORMALISED)
    return RodSystem(disc, rod, loads, model=chosen, c_u=c_u, banded=True, mixed=True)


def _start(system: RodSystem) -> np.ndarray:
    return system.reduce(system.reference())


def _dead_load_scenes():
    scale = S.E_B / S.L**2
    moment = scene_from_dict({"rod": S._rod(), "tip": {"moment": [0.0, 3.0 * S.E_B / S.L, 0.0]}})
    weight = scene_from_dict({"rod": S._rod(), "load": {"distributed_force": [40.0 * scale / S.L, 0, 0]}})
    return {
        "tip force": S.tip_force(50.0),
        "end moment": moment,
        "distributed": weight,
        "field at 90 deg": S.magnetic(30.0, 90.0),  # B_3 = 0: no torque stiffness on the straight rod
        "field at 60 deg": S.magnetic(30.0, 60.0),  # m B_3 > 0: stiffens it
    }


@pytest.mark.parametrize("name", sorted(_dead_load_scenes()))
def test_dead_loads_leave_the_unloaded_tangent_positive_definite(name):
    """The reason probe_start skips them (planar model): at any load the unloaded rod's tangent is
    the elastic one, or stiffer."""
    scene = _dead_load_scenes()[name]
    system = _system(scene)
    assert not probe_start(system.rod, system.loads, system.model)
    for lam in (1.0, 10.0):
        assert definite(system, _start(system), lam) is True


def test_a_field_beyond_the_straight_rods_stability_limit_is_detected():
    scene = S.magnetic(6.4, 120.0)
    system = _system(scene)
    assert probe_start(system.rod, system.loads, system.model)
    x0 = _start(system)
    assert definite(system, x0, 0.0) is True
    assert definite(system, x0, 1.0) is False
    assert definite(system, x0, 0.5) is True
    assert definite_step(system, x0, 0.0, 1.0, 1.0, 1e-6) == 0.5
    assert definite_step(system, x0, 0.0, 0.5, 1.0, 1e-6) == 1.0  # a stable target: unchanged


def test_halvings_are_bounded():
    scene = S.magnetic(64.0, 179.0)  # far beyond the straight rod's limit
    system = _system(scene)
    step = definite_step(system, _start(system), 0.0, 1.0, 1.0, 1e-6)
    assert step >= 2.0**-10
    assert definite(system, _start(system), step) is True or step == 2.0**-10


def test_no_test_in_3d():
    system = _system(S.spatial(stiff=1e3, rigid=True), 16)
    assert system.model != PLANAR and not probe_start(system.rod, system.loads, system.model)


@pytest.mark.parametrize("elements", [4, 16])
def test_the_tested_first_step_saves_the_failed_newton_and_keeps_the_answer(elements):
    scene = S.magnetic(6.4, 120.0)  # equilibrium starts it turned into the field (rod.aligned)
    system = _system(scene, elements)
    X, untested = follow(system, _start(system), [1.0], definite_start=False)
    system = _system(scene, elements)
    X_tested, tested = follow(system, _start(system), [1.0], definite_start=True)
    # the full load fails from the straight rod (its iterations are lost: NewtonInfo counts only
    # the accepted ones); the tested first step is one Newton can take
    assert untested.rejected >= 1 and tested.rejected == 0
    assert tested.iterations <= untested.iterations
    assert np.allclose(X, X_tested, rtol=0, atol=1e-9)
    assert np.allclose(system.expand(X), equilibrium(scene, elements=elements).U.ravel(), rtol=0, atol=1e-9)
