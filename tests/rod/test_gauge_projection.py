"""Newton's gauge projection (matid.rod.newton.PROJECT_ABOVE, RodSystem.project, FullStack.project):
each node's q back on |q| = 1 in the normalised full model, nothing else moved; no projection for
the planar model, the raw variant or a contact; fewer evaluations on the peers' 3D bend, same tip.
The sweep over 3D scenes: benchmarks/gauge_projection.py."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import matid.rod.newton as nw
from matid.bench import peers
from matid.bench import scenes as S
from matid.physics import kinematics as kin
from matid.rod import batch
from matid.rod.batch_full import FullStack
from matid.rod.cantilever import INTORDER, default_penalty, equilibrium, mesh, prepare_scene
from matid.rod.models import FULL, PLANAR
from matid.rod.scenes import scene_from_dict
from matid.rod.system import RodSystem
from tests.rod.test_aligned import _counted  # the same counter of RodSystem.evaluate

SCALE = S.E_B / S.L**2
#: stacked evaluations (rows) allowed for three 3D bends at 4 elements (measured: 24 with the
#: projection, 31 without; projected at every step, the continuation crawls on for minutes)
CAP = 1000


def _scene(kappa=(0.0, math.pi / 4, 0.0), force=(0.5, 1.5, -0.5), **extra):
    """A 3D cantilever of the bench's rod: precurvature kappa / L, tip force in E_b/L^2."""
    rod = {"length": S.L, "E_b": S.E_B, "E_t": 0.7 * S.E_B, "E_s": 1e4 * SCALE, "E_e": 1e4 * SCALE,
           "precurvature": [k / S.L for k in kappa]}  # fmt: skip
    raw = {"rod": rod, "tip": {"force": [f * SCALE for f in force]}}
    for key, value in extra.items():
        if key == "rod":
            rod.update(value)
        else:
            raw[key] = value
    return scene_from_dict(raw)


def _system(scene, *, elements=4, element="P2", variant=kin.NORMALISED, model="auto") -> RodSystem:
    chosen, _, rod, loads, at = prepare_scene(scene, model)
    disc = mesh(elements, at, 3 if chosen == PLANAR else 7, element, INTORDER[element])
    c_u = default_penalty(rod, variant)
    return RodSystem(disc, rod, loads, model=chosen, variant=variant, c_u=c_u, banded=True)


def _perturbed(system: RodSystem, seed: int, size: float) -> np.ndarray:
    """The reference state plus a random perturbation of every free dof (|q| off 1 at every node)."""
    rng = np.random.default_rng(seed)
    x = system.reduce(system.reference())
    return x + size * rng.standard_normal(x.size)


def _unit_directors(U: np.ndarray) -> np.ndarray:
    q = U[:, 3:7] / np.linalg.norm(U[:, 3:7], axis=1, keepdims=True)
    return np.array(kin.directors(q.T)).transpose(2, 0, 1)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(
    seed=st.integers(0, 2**32 - 1),
    size=st.floats(1e-3, 0.5),
    element=st.sampled_from(["P2", "Hermite"]),
    elements=st.integers(1, 6),
)
def test_project_puts_each_nodes_q_on_the_unit_sphere_and_moves_no_director(seed, size, element, elements):
    system = _system(_scene(), elements=elements, element=element)
    X = _perturbed(system, seed, size)
    before = X.copy()
    U0 = system.expand(X).reshape(system.disc.nscalar, 7)
    U = system.expand(system.project(X)).reshape(system.disc.nscalar, 7)
    values, slopes = system.disc.value_dofs, system.disc.slope
    assert np.array_equal(X, before)  # the caller's state is not written to
    assert np.abs(np.linalg.norm(U[values, 3:7], axis=1) - 1.0).max() <= 1e-14
    assert np.abs(_unit_directors(U[values]) - _unit_directors(U0[values])).max() <= 1e-14
    assert np.array_equal(U[:, :3], U0[:, :3])  # positions (and their slopes) untouched
    assert np.array_equal(U[slopes], U0[slopes])  # the Hermite's slopes keep theirs
    assert np.abs(U[values, 3:7] - U0[values, 3:7]).max() > 0.0  # q really moved


def test_no_projection_for_the_planar_model_the_raw_variant_or_a_contact():
    planar = _system(S.tip_force(3.0))
    raw = _system(_scene(), variant=kin.RAW)
    wall = {"point": [-0.5 * S.L, 0.0, 0.0], "normal": [1.0, 0.0, 0.0]}
    contact = _system(_scene(rod={"outer_diameter": 2 * S.R_O}, wall=[wall]))
    assert (planar.model, raw.model, contact.model) == (PLANAR, FULL, FULL)
    assert any(term.branch(prep) is not None for term, prep in contact.nodal)  # the contact is there
    for system in (planar, raw, contact):
        X = _perturbed(system, 7, 0.3)
        assert np.array_equal(system.project(X.copy()), X), system.terms


def test_full_stack_projects_the_rows_asked_as_rod_system_does_and_no_other():
    scenes = [_scene(), _scene((1.0, 0.5, 0.3), (-2.0, 0.3, 1.0)), _scene((3.0, 0.0, 0.0), (1.0, 4.0, 0.0))]
    systems = [_system(scene, elements=5, model=FULL) for scene in scenes]
    parts = [prepare_scene(scene, FULL)[2:4] for scene in scenes]
    stack = FullStack(systems[0].disc, parts)
    X = np.stack([_perturbed(system, i, 0.2) for i, system in enumerate(systems)])
    rows = np.array([True, False, True])
    Y = stack.project(X.copy(), rows)
    for i, system in enumerate(systems):
        expected = system.project(X[i]) if rows[i] else X[i]
        assert np.array_equal(Y[i], expected), i


def test_the_peers_3d_bend_takes_fewer_evaluations_with_the_projection_to_the_same_tip(monkeypatch):
    calls, tips, counts, on = _counted(monkeypatch), {}, {}, nw.PROJECT_ABOVE
    for threshold in (on, math.inf):
        monkeypatch.setattr(nw, "PROJECT_ABOVE", threshold)
        calls.clear()
        eq = equilibrium(peers.precurved_3d(), elements=4)
        counts[threshold], tips[threshold] = len(calls), eq.U[eq.disc.vertex_dof(eq.disc.ne), :3]
    assert counts[on] < counts[math.inf], counts
    assert np.abs(tips[on] - tips[math.inf]).max() <= 1e-9  # scaled by L


def test_the_stacked_newton_projects_too(monkeypatch):
    """batch.newton hands its states to FullStack.project: fewer stacked evaluations on 3D bends."""
    scenes = [peers.precurved_3d(f) for f in (0.5, 1.0, 2.0)]
    parts = [prepare_scene(scene, FULL)[2:4] for scene in scenes]
    disc = mesh(4, (1.0,), 7, "P2", 2)
    rows, original, out, on = [], FullStack.evaluate, {}, nw.PROJECT_ABOVE

    def evaluate(self, X, *args, **kw):
        rows.append(X.shape[0])
        assert sum(rows) <= CAP, "the stacked solve runs away (projected at every step, it crawls)"
        return original(self, X, *args, **kw)

    monkeypatch.setattr(FullStack, "evaluate", evaluate)
    for threshold in (on, math.inf):
        monkeypatch.setattr(nw, "PROJECT_ABOVE", threshold)
        rows.clear()
        stack = FullStack(disc, parts)
        X, _, _, reasons = batch.follow(stack, stack.reference())
        assert reasons == [None] * len(scenes)
        out[threshold] = (sum(rows), stack.expand(X).reshape(len(scenes), disc.nscalar, 7)[:, :, :3])
    assert out[on][0] < out[math.inf][0], (out[on][0], out[math.inf][0])
    assert np.abs(out[on][1] - out[math.inf][1]).max() <= 1e-9
