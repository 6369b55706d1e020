"""The stacked full-model Newton (matid.rod.batch_full) against one RodSystem solve per scene, and
[aim]'s starts solved as one stack against the same starts one by one."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import matid.rod.aim as A
from matid.errors import ConvergenceError
from matid.physics import kinematics as kin
from matid.rod import batch
from matid.rod.batch_full import FullStack, stackable
from matid.rod.cantilever import equilibrium, mesh, prepare_scene
from matid.rod.models import FULL
from matid.rod.scenes import Aim, load_scene
from tests import ROOT

AIM = ROOT / "examples" / "scenes" / "aim.toml"
ELEMENTS = 16
#: the field directions of matid.rod.aim.CANDIDATES: a cube's 26 faces, edges and corners
_C = np.array([v for v in np.ndindex(3, 3, 3) if v != (1, 1, 1)], float) - 1.0
CUBE = list(_C / np.linalg.norm(_C, axis=1, keepdims=True))


def _variants() -> list:
    """Scenes of one mesh (breaks at the ends only) with every stacked term, the aim example's rod
    and magnet at fields of 0.05 to 1 T (one of them with no stable path from the straight rod)."""
    base = dataclasses.replace(load_scene(AIM), aim=None)
    loads, rod, L = base.loads, base.rod, base.rod.length
    F = rod.E_b / L**2

    def at(B, **changes):
        return dataclasses.replace(base, loads=dataclasses.replace(loads, B=tuple(B), **changes))

    scenes = [at(1.0 * np.asarray(b)) for b in CUBE[::3]]  # (0, 0, -1) at 1 T fails
    scenes += [
        at((0.05, 0.02, 0.1), tip_force=(0.0, 2 * F, -F)),
        at((0.0, 0.1, 0.0), distributed_force=(F / L, 0.0, 0.0)),
        at((0.1, 0.0, 0.05), point_loads=((0.5 * L, (0.0, F, 0.0), (0.0, 0.0, 0.0)),)),
        at(
            (0.02, -0.1, 0.0),
            magnets=(),
            magnet_directions=(),
            magnetization=((0.0, L, 0.3 * loads.magnets[0][1] / L),),
        ),
        at((0.0, 0.2, 0.1), magnet_directions=((1.0, 0.0, 0.0),)),  # a magnet across the rod
        at(
            (0.1, 0.0, -0.05),
            magnets=(),
            magnet_directions=(),
            magnetization=((0.0, L, 0.3 * loads.magnets[0][1] / L),),
            magnetization_directions=((0.6, 0.0, 0.8),),
        ),
        dataclasses.replace(at((0.0, 0.2, 0.1)), rod=dataclasses.replace(rod, precurvature=(0.0, 20.0, 5.0))),
        dataclasses.replace(
            at((0.0, 0.2, 0.1)), rod=dataclasses.replace(rod, E_s=10 * rod.E_s, E_t=0.5 * rod.E_t)
        ),
    ]
    return scenes


def test_stacked_full_model_gives_each_scenes_own_answer_and_failure() -> None:
    scenes = _variants()
    parts = [prepare_scene(scene, FULL)[2:4] for scene in scenes]
    assert all(stackable(loads) for _, loads in parts)
    disc = mesh(ELEMENTS, (1.0,), 7, "P2", 2)
    stack = FullStack(disc, parts)
    X, info, _, reasons = batch.follow(stack, stack.reference())
    U = stack.expand(X).reshape(len(scenes), disc.nscalar, 7)
    tip = disc.vertex_dof(disc.vertices.size - 1)
    failed = 0
    for i, scene in enumerate(scenes):
        try:
            one = equilibrium(scene, elements=ELEMENTS, model=FULL)
        except ConvergenceError as exc:
            failed += 1
            assert reasons[i] is not None, (i, str(exc))
            assert str(exc).startswith(reasons[i]), (str(exc), reasons[i])  # the same load factor and reason
            continue
        assert reasons[i] is None, (i, reasons[i])
        assert one.disc.vertices.tolist() == disc.vertices.tolist()
        mine, theirs = U[i, tip], one.U[tip]
        assert np.abs(mine - theirs).max() <= 1e-10 * np.abs(theirs).max(), i
        if not any(scene.rod.precurvature):  # one scene alone starts a precurved rod from its arc
            assert one.info.iterations == info[i, 0] and one.info.steps == info[i, 1], (i, one.info, info[i])
        assert kin.d3(mine[3:].tolist()) == pytest.approx(one.tip()[3:].tolist(), abs=1e-10)
    assert failed == 1  # the field (0, 0, -1) at 1 T: unstable at load factor 0.17


def test_dead_moments_and_contact_do_not_stack() -> None:
    scene = dataclasses.replace(load_scene(AIM), aim=None)
    moment = dataclasses.replace(scene, loads=dataclasses.replace(scene.loads, tip_moment=(1e-4, 0.0, 0.0)))
    assert stackable(prepare_scene(scene, FULL)[3])
    assert not stackable(prepare_scene(moment, FULL)[3])
    point = load_scene(ROOT / "examples" / "scenes" / "point_load.toml")  # a point moment: unsymmetric
    assert not stackable(prepare_scene(point, FULL)[3])


@pytest.mark.parametrize("target, magnitude", [((0.0, 0.0, -1.0), 1.0), ((0.0, 1.0, 0.0), 0.16)])
def test_aims_stacked_starts_are_its_starts_one_by_one(monkeypatch, target, magnitude) -> None:
    scene = dataclasses.replace(load_scene(AIM), aim=Aim(target, magnitude))
    got = {}
    for stacked in (False, True):
        monkeypatch.setattr(A, "STACKED_STARTS", stacked)
        forward = A.Forward(scene, ELEMENTS)
        starts = A._nearest_starts(forward, np.asarray(target), magnitude)
        got[stacked] = ([tuple(b) for b in starts], forward.best, forward.solves)
    assert [tuple(b) for b in A.CANDIDATES] == [tuple(b) for b in CUBE]
    assert got[True][0] == got[False][0]
    assert len(got[True][0]) == len(A.CANDIDATES) - (magnitude == 1.0)  # (0, 0, -1) at 1 T fails
    assert got[True][1][0] == pytest.approx(got[False][1][0], abs=1e-10)
    assert got[True][2] == got[False][2] == len(got[True][0])  # converged forward solves
