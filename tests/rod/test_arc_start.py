"""The unloaded precurved arc as Newton's start (issue 32 item 3): it is the unloaded rod's
equilibrium up to the discretisation, and starting from it changes the work, never the answer."""

import math

import numpy as np
import pytest

from matid.bench.peers import precurved_3d
from matid.rod import starts
from matid.rod.arc import arc
from matid.rod.cantilever import default_penalty, equilibrium, mesh, prepare_scene
from matid.rod.models import PLANAR
from matid.rod.scenes import scene_from_dict
from matid.rod.system import RodSystem


def _system(scene, elements: int, model: str) -> RodSystem:
    chosen, _, rod, loads, at = prepare_scene(scene, model)
    disc = mesh(elements, at, 3 if chosen == PLANAR else 7, "P2", 2)
    return RodSystem(disc, rod, loads, model=chosen, c_u=default_penalty(rod, "normalised"), banded=True)


@pytest.mark.parametrize(
    "kappa, model",
    [((0.0, math.pi / 4, 0.0), "auto"), ((0.0, 1.2, 0.0), "full"), ((0.3, -0.7, 0.5), "full")],
)
def test_the_arc_is_the_unloaded_equilibrium_up_to_the_discretisation(kappa, model):
    """The Newton correction from the arc of an unloaded rod falls with the mesh like the P2 error
    (measured h^4: 16x per doubling); a wrong arc (sign, axis, half angle of q) would leave an O(1)
    correction on every mesh."""
    rod = {"length": 2.0, "E_b": 3.0, "E_t": 2.0, "E_s": 1e3, "E_e": 1e3, "precurvature": list(kappa)}
    scene = scene_from_dict({"rod": rod})
    steps = []
    for n in (4, 8, 16):
        system = _system(scene, n, model)
        assert system.model == (PLANAR if model == "auto" else model)
        U = arc(system)
        R, K = system.evaluate(system.reduce(U.ravel()), 1.0)
        steps.append(float(np.abs(K.factor().solve(-R)).max()))
    assert steps[0] < 1e-4
    assert steps[1] < steps[0] / 8 and steps[2] < steps[1] / 8


def test_no_arc_for_a_straight_rod():
    scene = scene_from_dict({"rod": {"length": 1.0, "E_b": 1.0, "E_t": 1.0, "E_s": 1e3, "E_e": 1e3}})
    assert arc(_system(scene, 4, "full")) is None


def test_the_arc_start_gives_the_continuations_answer(monkeypatch):
    scene = precurved_3d()
    from_arc = equilibrium(scene, elements=8)
    monkeypatch.setattr(starts, "arc", lambda system: None)
    continued = equilibrium(scene, elements=8)
    assert np.allclose(from_arc.U, continued.U, rtol=0, atol=1e-9)
    assert from_arc.info.iterations < continued.info.iterations
