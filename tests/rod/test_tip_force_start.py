"""The rod turned by a dead tip force as Newton's start (rod.aligned under a [tip] force, issue
32.3): the same closed form as in a field, with the force's stresses; close to the elastica, used
only where it applies, and it changes the work, never the answer (the continuation from the
straight rod is the reference, and the fallback)."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from matid.bench import scenes as S
from matid.rod import starts
from matid.rod.aligned import BUCKLING, aligned
from matid.rod.cantilever import equilibrium, prepare_scene
from matid.rod.newton import follow
from matid.rod.scenes import scene_from_dict
from tests.rod.test_aligned import _counted, _system  # the same 4-element system and counter


def _scene(alpha: float, beta_deg: float, **tip) -> object:
    """A dead tip force alpha E_b/L^2 at beta_deg from +z (the unloaded d3) towards +x."""
    beta, F = math.radians(beta_deg), alpha * S.E_B / S.L**2
    raw = {"rod": S._rod(), "tip": {"force": [F * math.sin(beta), 0.0, F * math.cos(beta)], **tip}}
    return scene_from_dict(raw)


def _shot(alpha: float, beta: float):
    """(theta, theta', x, z) along the inextensible, unshearable rod under the dead tip force, by
    shooting: theta'' = alpha sin(theta - beta), theta(0) = 0, theta'(0) = m (scipy's solve_ivp)
    with m the root of theta'(1) = 0 nearest below the first integral's bound
    m^2 <= 2 alpha (1 - cos beta) (the rod turned the short way towards the force)."""

    def shot(m):
        def rhs(t, y):
            return [y[1], alpha * math.sin(y[0] - beta), math.sin(y[0]), math.cos(y[0])]

        return solve_ivp(rhs, (0.0, 1.0), [0.0, m, 0.0, 0.0], rtol=1e-12, atol=1e-12, dense_output=True)

    top = math.copysign(math.sqrt(2.0 * alpha * (1.0 - math.cos(beta))), beta)
    ms = np.linspace(top, 0.0, 81)
    tip = [shot(m).y[1, -1] for m in ms]
    i = next(i for i in range(ms.size - 1) if tip[i] * tip[i + 1] <= 0.0)
    m = brentq(lambda m: shot(m).y[1, -1], *sorted((ms[i], ms[i + 1])), xtol=1e-14)
    return shot(m).sol


@pytest.mark.parametrize(
    "alpha, beta_deg, tol",  # tol: twice the measured largest error of the start (16 elements)
    [(5.0, 90.0, 1e-3), (20.0, 150.0, 2e-4), (50.0, 170.0, 2e-6), (5.0, -60.0, 1e-3)],
)
def test_the_start_is_near_the_elastica(alpha, beta_deg, tol):
    """theta, x, z at the dofs and the point stresses F.d1, F.d3 on the elastica's directors
    (measured: 4.1e-4 / 6.3e-5 / 8.2e-7 in theta at 5, 90 deg (P2); 20, 150 deg; 50, 170 deg;
    stresses 1.9e-3 / 1.1e-3 / 3.4e-5 of alpha). A force towards -x turns the scene's plane
    (e_a = -e1): the start lies in it."""
    scene = _scene(alpha, beta_deg)
    system = _system(scene, elements=16)
    e_a = prepare_scene(scene, "auto")[1]
    beta = math.radians(beta_deg)
    beta = math.atan2(math.sin(beta) * e_a[0], math.cos(beta))
    U, stress = aligned(system)
    theta, _, x, z = _shot(alpha, beta)(system.disc.s_dof)
    assert np.abs(U[:, 2] - theta).max() < tol
    assert np.abs(U[:, 0] - x).max() < tol and np.abs(U[:, 1] - z).max() < tol
    assert np.abs(U[system.disc.vertex_dof(0)]).max() < 1e-15  # the clamp
    at = _shot(alpha, beta)(system.disc.s_quad.ravel())[0].reshape(system.disc.s_quad.shape)
    F = alpha * np.array([math.sin(beta), math.cos(beta)])
    n1, n3 = F[0] * np.cos(at) - F[1] * np.sin(at), F[0] * np.sin(at) + F[1] * np.cos(at)
    assert np.abs(stress[..., 0] - n1).max() < 5 * tol * alpha
    assert np.abs(stress[..., 1] - n3).max() < 5 * tol * alpha


def test_the_starts_stresses_are_near_the_converged_ones():
    """P2 (alpha = 5, 90 deg), 4 and 16 elements: the start's (n1, n3) within 1e-3 of alpha of
    converged_stress() (measured 1.9e-3 on 16; the point stresses are the system's)."""
    scene = S.tip_force(5.0)
    for n in (4, 16):
        stress = aligned(_system(scene, elements=n))[1]
        converged = equilibrium(scene, elements=n).stress
        assert np.abs(stress - converged).max() < 1e-3 * 5.0
        assert np.abs(converged).max() > 4.9  # the force, not zero


def test_p2s_coarse_mesh_needs_no_continuation(monkeypatch):
    """P2 of the peers bench (alpha = 5, perpendicular), its error estimate's 4-element mesh as
    solve asks for it: 2 Newton evaluations in one load step (8434bb3: 7 from the straight rod,
    corrections 2.5, 2, 0.55, 0.3, 0.046, 2.1e-3, 1.9e-6; with zero point stresses 3), the
    continuation's state."""
    scene = S.tip_force(5.0)
    calls = _counted(monkeypatch)
    eq = equilibrium(scene, elements=4, confirm=False)
    assert len(calls) <= 2 and eq.info.steps == 1
    system = _system(scene)
    X, info = follow(system, system.reduce(system.reference()), [1.0])
    assert np.allclose(system.expand(X), eq.U.ravel(), rtol=0, atol=1e-9)
    start = aligned(system)
    monkeypatch.setattr(starts, "aligned", lambda system: (start[0], np.zeros_like(start[1])))
    calls.clear()
    equilibrium(scene, elements=4, confirm=False)
    assert len(calls) > 2  # the force's stresses in the first tangent save one


SAME = {
    "P2": (5.0, 90.0),
    "small": (0.3, 30.0),
    "against the rod, 150 deg, alpha = 20": (20.0, 150.0),
    "near the axis beyond buckling": (3.0, 178.0),
    "towards -x": (5.0, -120.0),
    "alpha = 50, 60 deg": (50.0, 60.0),
}


@pytest.mark.parametrize("name", sorted(SAME))
def test_the_start_gives_the_continuations_answer(name, monkeypatch):
    scene = _scene(*SAME[name])
    assert aligned(_system(scene)) is not None
    calls = _counted(monkeypatch)
    turned = equilibrium(scene, elements=8)
    cost = len(calls)
    monkeypatch.setattr(starts, "aligned", lambda system: None)
    calls.clear()
    continued = equilibrium(scene, elements=8)
    assert turned.info.steps == 1
    assert np.allclose(turned.U, continued.U, rtol=0, atol=1e-9)
    assert cost < len(calls)


def test_a_failed_start_falls_back_on_the_continuation(monkeypatch):
    """Newton fails from the start (here a non-finite one): the continuation from the straight rod
    runs as without the start, the same state bit for bit; the attempt costs its one evaluation."""
    scene = S.tip_force(5.0)
    calls = _counted(monkeypatch)
    monkeypatch.setattr(starts, "aligned", lambda system: None)
    continued = equilibrium(scene, elements=4)
    cost = len(calls)
    calls.clear()
    nan = np.full((_system(scene).disc.nscalar, 3), np.nan)
    monkeypatch.setattr(starts, "aligned", lambda system: (nan, np.zeros(system.disc.s_quad.shape + (2,))))
    fallen = equilibrium(scene, elements=4)
    assert np.array_equal(fallen.U, continued.U)
    assert fallen.info.steps == continued.info.steps and fallen.info.iterations == continued.info.iterations
    assert len(calls) == cost + 1


NOT_APPLICABLE = {
    "a tip moment too": _scene(5.0, 90.0, moment=[0.0, 1e-3, 0.0]),
    "below buckling near the axis": _scene(2.0, 165.0),
    "along the axis, below buckling": _scene(1.0, 180.0),
    "just beyond buckling near the axis": _scene(1.03 * BUCKLING, 170.0),
    "near the axis beyond buckling": _scene(5.0, 179.5),
    "along the axis beyond buckling": _scene(5.0, 180.0),
    "a segment": scene_from_dict(
        {
            "rod": S._rod(),
            "tip": {"force": [5.0 * S.E_B / S.L**2, 0.0, 0.0]},
            "segment": [{"from": 0.0, "to": S.L / 2, "E_b": 2 * S.E_B}],
        }
    ),
    "precurved": scene_from_dict(
        {
            "rod": S._rod(precurvature=[0.0, 1.0 / S.L, 0.0]),
            "tip": {"force": [5.0 * S.E_B / S.L**2, 0.0, 0.0]},
        }
    ),
}


@pytest.mark.parametrize("name", sorted(NOT_APPLICABLE))
def test_no_start_where_it_does_not_apply(name):
    assert aligned(_system(NOT_APPLICABLE[name])) is None


def test_no_start_in_3d():
    assert aligned(_system(S.tip_force(5.0), model="full")) is None
