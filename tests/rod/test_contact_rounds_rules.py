"""matid.rod.contact_rounds.settle seen from outside: the Newton iterations a solve reports count
those spent settling the contacts, and a settle that gives up says why (the wall tolerance and
the number of multiplier updates)."""

from __future__ import annotations

import pytest

from matid.errors import ConvergenceError
from matid.rod import cantilever
from matid.rod import contact_rounds as CR
from matid.rod.api import solve
from matid.rod.scenes import scene_from_dict
from matid.rod.terms.contact import contact_of

L, EB, R_O = 0.05, 1e-5, 0.5e-3
ES = 1e9 * EB / L**2


def _tip_on_a_wall():
    """A cantilever whose tip a force of 3 E_b/L^2 pushes onto a wall at 0.2 L (a case of
    tests/rod/test_contact.py, against the shooting reference there)."""
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": ES, "E_e": ES, "outer_diameter": 2 * R_O}
    wall = {"point": [0.2 * L, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}
    return scene_from_dict(
        {"rod": rod, "tip": {"force": [3 * EB / L**2, 0, 0]}, "wall": [wall], "elements": 8}
    )


def _tip_magnet_on_a_wall(elements: int):
    """A tip magnet (B = 30 mT along x, m B L/E_b = 3) turning the tip onto a wall at 0.25 L (a case
    of tests/rod/test_contact.py): the field's torque makes the tangent depend on the load."""
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": ES, "E_e": ES, "outer_diameter": 2 * R_O}
    B, m = 0.03, 3 * EB / L / 0.03
    wall = {"point": [0.25 * L, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}
    raw = {"rod": rod, "field": {"B": [B, 0, 0]}, "magnet": [{"at": L, "moment": m}], "wall": [wall]}
    return scene_from_dict({**raw, "elements": elements})


@pytest.mark.parametrize("elements", [8, 16])
def test_one_multiplier_update_settles_a_tip_on_a_wall(monkeypatch, elements):
    """The multipliers' step is Newton's on the complementarity problem (S = G K^-1 G^T with K the
    tangent at the converged load): from the continuation's penalty state, one update brings the
    tip to its wall to first order, and the next check finds it settled. A tangent at another
    load (the field's torque scales with it) needs a second update (measured: 2, 1, 2, 1)."""
    updates = []

    def watched_settle(system, X, info):
        X = settle(system, X, info)
        updates.append(contact_of(system)[1]["state"].outer)
        return X

    settle = cantilever.settle
    monkeypatch.setattr(cantilever, "settle", watched_settle)
    solve(_tip_magnet_on_a_wall(elements))
    assert updates and all(n <= 1 for n in updates), updates


def test_the_reported_newton_iterations_count_those_that_settle_the_contacts(monkeypatch):
    """Each settle adds the iterations of its Newton solves (counted here as they return) to the
    solve's count, which the solution reports (solution.json's newton_iterations)."""
    settles, its = [], []

    def counted_newton(*args, **kwargs):
        out = newton(*args, **kwargs)
        its.append(out[1])
        return out

    def watched_settle(system, X, info):
        before, first = info.iterations, len(its)
        X = settle(system, X, info)
        settles.append((info.iterations - before, sum(its[first:])))
        return X

    newton, settle = CR.newton, cantilever.settle
    monkeypatch.setattr(CR, "newton", counted_newton)
    monkeypatch.setattr(cantilever, "settle", watched_settle)
    sol = solve(_tip_on_a_wall())
    assert settles and all(added == spent for added, spent in settles), settles
    assert sum(spent for _, spent in settles) > 0  # the contacts took Newton solves to settle
    assert sol.newton_iterations >= sum(spent for _, spent in settles)


def test_a_settle_that_gives_up_names_the_tolerance_and_the_updates(monkeypatch):
    """With no multiplier update allowed the tip cannot be brought to its wall: the error says
    what was not met and after how many updates."""
    monkeypatch.setattr(CR, "MAX_UPDATES", 0)
    scene = _tip_on_a_wall()
    with pytest.raises(
        ConvergenceError, match=r"contact: the walls are not met within \S+ L after 0 multiplier updates"
    ):
        solve(scene)
