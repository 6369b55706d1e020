"""Provisional meshes of the error estimate (equilibrium(confirm=False)): Newton stops once its
quadratic model forecasts the next correction below XTOL and the confirming evaluation waits for
Equilibrium.confirmed: the answer is the confirmed one, only the coarser meshes save an evaluation."""

from contextlib import contextmanager
from dataclasses import replace

import numpy as np
import pytest

from matid.bench import scenes as S
from matid.bench.peers import precurved_3d
from matid.rod import cantilever, newton
from matid.rod import system as rod_system
from matid.rod.api import solve
from matid.rod.cantilever import equilibrium
from matid.rod.transfer import interpolate_p2


@contextmanager
def counted():
    """Every RodSystem.evaluate as (elements, tangent), appended to the list yielded."""
    calls, original = [], rod_system.RodSystem.evaluate

    def evaluate(self, X, lam, *, tangent=True, **kw):
        calls.append((self.disc.ne, tangent))
        return original(self, X, lam, tangent=tangent, **kw)

    rod_system.RodSystem.evaluate = evaluate
    try:
        yield calls
    finally:
        rod_system.RodSystem.evaluate = original


SCENES = {
    "magnetic": lambda: S.magnetic(6.4, 120.0),
    "tip_force": lambda: S.tip_force(5.0),
    "3d": precurved_3d,
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_a_deferred_confirmation_is_the_last_iteration_it_stands_for(name, monkeypatch):
    """With the confirmation from the residual off (CHORD_LAST = 0): bit for bit the full solve."""
    monkeypatch.setattr(newton, "CHORD_LAST", 0.0)
    scene = SCENES[name]()
    coarse = equilibrium(scene, elements=8)
    now = equilibrium(scene, elements=16, start=coarse)
    late = equilibrium(scene, elements=16, start=coarse, confirm=False)
    if late.pending is not None:
        assert late.info.iterations == now.info.iterations - 1
    done = late.confirmed()
    assert done.pending is None and done.confirmed() is done
    assert np.array_equal(done.U, now.U)  # bit for bit: the same evaluation, tangent and correction
    assert np.array_equal(done.stress, now.stress)
    assert done.info.iterations == now.info.iterations


#: Point stresses of one state solved twice agree to about this (scaled; stiffnesses up to 1e8
#: times XTOL-sized differences of the displacements): measured 6e-6 on the 3D bend.
STRESS_ROUNDOFF = 1e-5


@pytest.mark.parametrize("name", ["magnetic", "tip_force"])
def test_a_confirmation_from_the_residual_lands_on_the_same_root(name):
    """The last correction from the residual and the factor one correction earlier
    (newton.confirm_by_residual): one tangent evaluation fewer than the full solve, the same
    iterations, the same root to round-off, and point stresses that a solve started at the answer
    reproduces (what the next mesh's first tangent reads)."""
    scene = SCENES[name]()
    coarse = equilibrium(scene, elements=8)
    now = equilibrium(scene, elements=16, start=coarse)
    late = equilibrium(scene, elements=16, start=coarse, confirm=False)
    assert late.pending is not None and late.info.last <= newton.CHORD_LAST
    with counted() as calls:
        done = late.confirmed()
    assert [tangent for _, tangent in calls] == [False]
    assert done.info.iterations == now.info.iterations
    assert np.abs(done.U - now.U).max() <= 1e-12 * np.abs(now.U).max()
    again = equilibrium(scene, elements=16, start=done)
    assert np.abs(again.U - done.U).max() <= 1e-12 * np.abs(now.U).max()
    assert np.abs(again.stress - done.stress).max() <= STRESS_ROUNDOFF


def test_no_confirmation_from_the_residual_after_a_mixed_tangent(monkeypatch):
    """A factor after a correction above MIXED_ABOVE is the mixed tangent, not the true one the
    stability test must read: info.last is inf and the confirmation is a full iteration. (From the
    P2 interpolant of the 8-element state, the magnetic cantilever's 16-element corrections are
    1.7e-4 (above MIXED_ABOVE: the next tangent is mixed), then 7e-8: accepted.)"""
    monkeypatch.setattr(cantilever, "interpolate_warm", lambda v, x, s, kinks: interpolate_p2(v, x, s))
    scene = SCENES["magnetic"]()
    late = equilibrium(scene, elements=16, start=equilibrium(scene, elements=8), confirm=False)
    assert late.pending is not None and late.info.last == np.inf
    with counted() as calls:
        late.confirmed()
    assert calls[0][1] is True


def test_the_saving_is_taken_where_the_forecast_allows():
    """Magnetic cantilever, 16 elements warm from 8: corrections 2e-4, 4e-8 -> forecast 1e-15."""
    scene = SCENES["magnetic"]()
    late = equilibrium(scene, elements=16, start=equilibrium(scene, elements=8), confirm=False)
    assert late.pending is not None


@pytest.mark.parametrize("name", sorted(SCENES))
def test_provisional_continuation_lands_on_the_confirmed_root(name):
    scene = SCENES[name]()
    now = equilibrium(scene, elements=4)
    late = equilibrium(scene, elements=4, confirm=False)
    assert late.info.iterations < now.info.iterations
    done = late.confirmed()
    assert np.abs(done.U - now.U).max() <= 1e-12 * np.abs(now.U).max()
    assert done.info.iterations <= now.info.iterations


@pytest.mark.parametrize("name", sorted(SCENES))
def test_solve_answers_with_the_confirmed_chain_of_meshes(name):
    scene = SCENES[name]()
    sol = solve(scene)
    last = None
    for n in sol.extra["error_estimate"]["meshes"]:
        last = equilibrium(scene, elements=n, start=last)
    assert sol.elements == last.disc.ne
    L = scene.rod.length
    assert np.abs(sol.position - last.solution().position).max() <= 1e-12 * L
    assert np.abs(sol.d3 - last.solution().d3).max() <= 1e-12


def test_a_failed_confirmation_solves_the_mesh_again_confirmed():
    scene = SCENES["magnetic"]()
    coarse = equilibrium(scene, elements=8)
    now = equilibrium(scene, elements=16, start=coarse)
    late = equilibrium(scene, elements=16, start=coarse, confirm=False)
    system, X, redo = late.pending
    broken = replace(late, pending=(system, X * np.nan, redo))  # its Newton fails at once
    again = broken.confirmed()
    assert again.pending is None
    assert np.array_equal(again.U, now.U) and again.info.iterations == now.info.iterations
