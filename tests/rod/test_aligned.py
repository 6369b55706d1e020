"""The magnetised rod turned into a field beyond buckling as Newton's start (rod.aligned, issue
32.3): close to the elastica, used only where it applies, and it changes the work, never the
answer (the continuation from the straight rod is the reference, and the fallback)."""

import copy
import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from matid.bench import scenes as S
from matid.physics import kinematics as kin
from matid.rod import starts
from matid.rod import system as rod_system
from matid.rod.aligned import BUCKLING, aligned
from matid.rod.cantilever import default_penalty, equilibrium, mesh, prepare_scene
from matid.rod.models import PLANAR
from matid.rod.newton import follow
from matid.rod.scenes import scene_from_dict
from matid.rod.system import RodSystem


def _system(scene, elements: int = 4, model: str = "auto") -> RodSystem:
    chosen, _, rod, loads, at = prepare_scene(scene, model)
    disc = mesh(elements, at, 3 if chosen == PLANAR else 7, "P2", 2)
    c_u = default_penalty(rod, kin.NORMALISED)
    return RodSystem(disc, rod, loads, model=chosen, c_u=c_u, banded=True, mixed=True)


def _counted(monkeypatch) -> list:
    """Every RodSystem.evaluate from now on appends its load factor to the list returned."""
    calls, original = [], rod_system.RodSystem.evaluate

    def evaluate(self, X, lam, **kw):
        calls.append(lam)
        return original(self, X, lam, **kw)

    monkeypatch.setattr(rod_system.RodSystem, "evaluate", evaluate)
    return calls


def _elastica(q: float, psi: float):
    """(theta, x, z) at points s of the inextensible, unshearable rod: theta'' = q sin(theta - psi),
    theta(0) = 0, theta'(1) = 0 (scipy's collocation from the linearised solution), x' = sin theta,
    z' = cos theta."""
    s = np.linspace(0.0, 1.0, 401)
    k = math.sqrt(q)
    decay = np.cosh(k * (1.0 - s)) / math.cosh(k)
    guess = np.vstack([psi * (1.0 - decay), psi * k * np.sinh(k * (1.0 - s)) / math.cosh(k)])

    def rhs(t, y):
        return np.vstack([y[1], q * np.sin(y[0] - psi)])

    out = solve_bvp(rhs, lambda a, b: np.array([a[0], b[1]]), s, guess, tol=1e-9, max_nodes=100000)
    assert out.success
    fine = np.linspace(0.0, 1.0, 20001)
    th = out.sol(fine)[0]
    h = fine[1] - fine[0]
    x = np.concatenate([[0.0], np.cumsum(0.5 * h * (np.sin(th[1:]) + np.sin(th[:-1])))])
    z = np.concatenate([[0.0], np.cumsum(0.5 * h * (np.cos(th[1:]) + np.cos(th[:-1])))])
    return lambda t: (out.sol(t)[0], np.interp(t, fine, x), np.interp(t, fine, z))


@pytest.mark.parametrize(
    "q, psi_deg, tol",  # q = mu B L^2/E_b (signed mu), the field at psi_deg from +z towards +x
    [(6.4, 120.0, 2e-3), (20.0, 170.0, 3e-4), (6.4, -150.0, 1e-2), (-6.4, 60.0, 2e-3)],
)
def test_the_start_is_near_the_elastica(q, psi_deg, tol):
    """Within twice the measured error of the start (max over the dofs of 16 elements: 1.1e-3 at
    q = 6.4, 120 deg; 1.5e-4 at 20, 170 deg; 5.1e-3 at 6.4, 150 deg) of scipy's elastica, the short
    way round: mu < 0 lines d3 up against B (60 deg -> -120 deg). With kappa = k (no fit) it is
    8.9e-3 / 6.4e-4 / 2.2e-2 off, linearised 0.085 / 0.24 / 0.18."""
    system = _system(S.magnetic(q, psi_deg), elements=16)
    e_a = prepare_scene(S.magnetic(q, psi_deg), "auto")[1]
    psi = math.radians(psi_deg if q > 0 else psi_deg - 180.0)
    psi = math.atan2(math.sin(psi) * e_a[0], math.cos(psi))  # in the plane (e_a, e3): e_a = +-e1
    U = aligned(system)[0]
    theta, x, z = _elastica(abs(q), psi)(system.disc.s_dof)
    assert np.abs(U[:, 2] - theta).max() < tol
    assert np.abs(U[:, 0] - x).max() < tol and np.abs(U[:, 1] - z).max() < tol
    assert np.abs(U[system.disc.vertex_dof(0)]).max() < 1e-15  # the clamp


def test_p1s_coarse_mesh_needs_no_continuation(monkeypatch):
    """P1 of the peers bench (q = 6.4, 120 deg), its error estimate's 4-element mesh as solve asks
    for it: 2 Newton evaluations in one load step (d2e7e0f: 13, a definite probe, Newton at 0.5
    from the straight rod, 2 predictor residuals, Newton at 1), the continuation's state."""
    scene = S.magnetic(6.4, 120.0)
    calls = _counted(monkeypatch)
    eq = equilibrium(scene, elements=4, confirm=False)
    assert len(calls) <= 2 and eq.info.steps == 1
    system = _system(scene)
    X, info = follow(system, system.reduce(system.reference()), [1.0], definite_start=True)
    assert info.steps >= 2
    assert np.allclose(system.expand(X), eq.U.ravel(), rtol=0, atol=1e-9)


SAME = {
    "P1": S.magnetic(6.4, 120.0),
    "170 deg, q = 20": S.magnetic(20.0, 170.0),
    "mu < 0": S.magnetic(-6.4, 60.0),
    "the field on the other side": S.magnetic(6.4, -120.0),
    "100 deg, q = 40": S.magnetic(40.0, 100.0),
    "just beyond buckling": S.magnetic(1.05 * BUCKLING / math.cos(math.radians(30.0)), 150.0),
    "soft shear": S.magnetic(6.4, 120.0, E_s=10.0, E_e=10.0),
}


@pytest.mark.parametrize("name", sorted(SAME))
def test_the_start_gives_the_continuations_answer(name, monkeypatch):
    scene = SAME[name]
    assert aligned(_system(scene)) is not None
    turned = equilibrium(scene, elements=8)
    monkeypatch.setattr(starts, "aligned", lambda system: None)
    continued = equilibrium(scene, elements=8)
    assert turned.info.steps == 1 and continued.info.steps >= 2
    assert np.allclose(turned.U, continued.U, rtol=0, atol=1e-9)
    assert turned.info.iterations < continued.info.iterations


def test_a_failed_start_falls_back_on_the_continuation(monkeypatch):
    """Newton fails from the start (here a non-finite one): the continuation from the straight rod
    runs as without the start, the same state bit for bit; the attempt costs its one evaluation."""
    scene = S.magnetic(6.4, 120.0)
    calls = _counted(monkeypatch)
    monkeypatch.setattr(starts, "aligned", lambda system: None)
    continued = equilibrium(scene, elements=4)
    cost = len(calls)
    calls.clear()
    monkeypatch.setattr(starts, "aligned", lambda system: (np.full((system.disc.nscalar, 3), np.nan), None))
    fallen = equilibrium(scene, elements=4)
    assert np.array_equal(fallen.U, continued.U)
    assert fallen.info.steps == continued.info.steps >= 2
    assert len(calls) == cost + 1


def _raw(**changes) -> dict:
    raw = copy.deepcopy(S.magnetic_raw(6.4, 120.0))
    for key, value in changes.items():
        raw[key] = value
    return raw


def _rod(**more) -> dict:
    return dict(S._rod(), **more)


NOT_APPLICABLE = {
    "below buckling": S.magnetic(0.95 * BUCKLING / math.cos(math.radians(30.0)), 150.0),
    "field at 60 deg": S.magnetic(30.0, 60.0),
    "near reversal (179.5 deg)": S.magnetic(1.05 * BUCKLING, 179.5),
    "reversed": S.magnetic(20.0, 180.0),
    "a tip magnet": scene_from_dict(S.tip_magnet_raw(6.4, 120.0)),
    "magnetised on half the rod": scene_from_dict(
        _raw(magnetization=[dict(S.magnetic_raw()["magnetization"][0], to=S.L / 2)])
    ),
    "a segment": scene_from_dict(_raw(segment=[{"from": 0.0, "to": S.L / 2, "E_b": 2 * S.E_B}])),
    "a tip force": scene_from_dict(_raw(tip={"force": [1e-3, 0.0, 0.0]})),
    "precurved": scene_from_dict(_raw(rod=_rod(precurvature=[0.0, 1.0 / S.L, 0.0]))),
    "beyond MAX_Q": scene_from_dict(
        _raw(field={"B": S.field(120.0, 1.0)}, magnetization=[{"from": 0.0, "to": S.L, "per_length": 2e5}])
    ),
}


@pytest.mark.parametrize("name", sorted(NOT_APPLICABLE))
def test_no_start_where_it_does_not_apply(name):
    assert aligned(_system(NOT_APPLICABLE[name])) is None


def test_no_start_in_3d():
    assert aligned(_system(S.magnetic(6.4, 120.0), model="full")) is None


def test_the_stack_starts_there_too(monkeypatch):
    """solve_many's first mesh (rod.many): the scenes with the start leave the continuation, the
    rest follow it as before; the answers are solve()'s. 4 elements: 9-10 stacked evaluations (the
    two started scenes' Newton, 4; the stack's admissibility test evaluates a tangent again when the
    last factorisation is not the definite one, which round-off in the start decides; then the
    third's continuation alone, 5; d2e7e0f: 59, the three continued together)."""
    from matid.rod import batch
    from matid.rod.api import solve
    from matid.rod.many import solve_many

    scenes = [S.magnetic(6.4, 120.0), S.magnetic(20.0, 150.0), S.magnetic(2.0, 30.0)]
    calls, original = [], batch.Stack.evaluate

    def evaluate(self, *args, **kw):
        calls.append(self.disc.ne)
        return original(self, *args, **kw)

    monkeypatch.setattr(batch.Stack, "evaluate", evaluate)
    many = solve_many(scenes, elements=8)
    assert calls.count(4) <= 10
    for scene, got in zip(scenes, many, strict=True):
        want = solve(scene, elements=8)
        assert np.max(np.abs(got.position - want.position)) / S.L < 1e-9
        assert np.max(np.abs(got.d3 - want.d3)) < 1e-9
