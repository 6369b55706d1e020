"""The rules of matid.rod.contact_mesh and contact_ends on hand-made results, where the answer is
known in closed form.

A result here is what contact_mesh reads of a converged cantilever: ``disc.vertices`` and
``contact`` = (contacts with their s range, -, touch points, (s, f, -, g) of the P2 nodes). The
gap the rod leaves beside a stretch is a quadratic c (s - q)^2 whose smallest point q is chosen by
the test, so where each end must go is known without matid.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from matid.errors import ConvergenceError
from matid.rod import contact_ends as E
from matid.rod import contact_mesh as CR

#: 10 elements on [0, 1]: vertices every 0.1, P2 nodes every 0.05
VERTICES = np.linspace(0.0, 1.0, 11)
NODES = np.linspace(0.0, 1.0, 21)
H = 0.1  # element length


def _result(a: float, b: float, left: float, right: float, *, touches=(), entries=None):
    """A rod lying on one wall from vertex a to vertex b (every node between loaded), whose gap
    beside it is (s - left)^2 up to a and (s - right)^2 from b (0 between)."""
    tol = 1e-12
    gap = np.where(
        NODES <= a + tol, (NODES - left) ** 2, np.where(NODES >= b - tol, (NODES - right) ** 2, 0.0)
    )
    force = np.where((NODES >= a - tol) & (NODES <= b + tol), 1.0, 0.0)
    contact = (
        [{"s": (a, b)}] if entries is None else entries,
        None,
        list(touches),
        (NODES, force[None, :], None, gap[None, :]),
    )
    return SimpleNamespace(contact=contact, disc=SimpleNamespace(vertices=VERTICES))


@pytest.mark.parametrize(("off", "on"), [(0.02, True), (0.03, False)])
def test_a_stretch_end_moves_to_where_the_gap_beside_it_is_smallest(off, on):
    """The left end of a stretch on 0.5-0.7 L goes to the smallest point 0.5 - off of the gap's
    quadratic; it is on its vertex only within OFF_END (0.25) of the element outside it, 0.025 L."""
    qa, qb, said = E.stretch_ends(_result(0.5, 0.7, 0.5 - off, 0.7), 0.5, 0.7)
    assert qa == pytest.approx(0.5 - off, abs=1e-12) and qb == pytest.approx(0.7, abs=1e-12)
    assert said is on and (abs(qa - 0.5) <= E.OFF_END * H) is on


def test_a_stretch_end_moves_at_most_one_element_beyond_the_nodes_it_is_read_from():
    """The gap beside the left end falling towards 0.75 L (inside the stretch, past the right end)
    moves that end one element beyond the three nodes it is read from (0.4-0.5 L), to 0.6 L."""
    qa, qb, said = E.stretch_ends(_result(0.5, 0.7, 0.75, 0.7), 0.5, 0.7)
    assert qa == pytest.approx(0.5 + H, abs=1e-12) and qb == pytest.approx(0.7, abs=1e-12)
    assert not said


@pytest.mark.parametrize("shift", [0.0, 0.01])
def test_a_stretch_end_is_read_where_a_cubic_gap_beside_it_is_smallest(shift):
    """The gap beside each end of a stretch on 0.5-0.7 L is c2 d^2 + c3 d^3 from where the rod
    leaves its wall, at the vertices (shift 0) or 0.01 L inside them, with c3 h = 1.2 c2 (the
    workspace in a straight lumen 1 % wider than the tube: c2 = 5e-3, c3 ~ 0.06 at 0.054 L
    elements). Each end is read there; the quadratic of the element outside it read 0.0107 L off."""
    left, right = 0.5 + shift, 0.7 - shift
    d = np.where(NODES < left, left - NODES, np.where(NODES > right, NODES - right, 0.0))
    gap = 5e-3 * d**2 + 0.06 * d**3
    force = np.where((NODES >= 0.5 - 1e-12) & (NODES <= 0.7 + 1e-12), 1.0, 0.0)
    result = _result(0.5, 0.7, 0.5, 0.7)
    result.contact = (result.contact[0], None, [], (NODES, force[None, :], None, gap[None, :]))
    qa, qb, on = E.stretch_ends(result, 0.5, 0.7)
    assert qa == pytest.approx(left, abs=1e-9) and qb == pytest.approx(right, abs=1e-9) and on


def test_a_stretch_end_inside_the_loaded_nodes_moves_to_the_last_of_them():
    """A vertex at 0.5 L with the rod loaded from 0.35 L (the stretch reaches past it): the end
    moves out to where the gap beside 0.35 L is smallest, not to a reading of the zero gaps of the
    loaded nodes beside the vertex (0.4 L)."""
    qa, qb, on = E.stretch_ends(_result(0.35, 0.7, 0.35, 0.7), 0.5, 0.7)
    assert qa == pytest.approx(0.35, abs=1e-9) and qb == pytest.approx(0.7, abs=1e-9) and not on


def test_round_off_reactions_and_gaps_beside_a_stretch_end_leave_it_where_it_is():
    """A rod lying straight along its wall, loaded at 0.5-0.7 L: the nodes beyond carry reactions
    of 2e-14 (below LOADED of the largest) and gaps of 7e-18 (below FLAT). The ends stay on their
    vertices (they walked 0.95 -> 0.62 L in 16 rounds on such a rod pressed at its tip)."""
    result = _result(0.5, 0.7, 0.5, 0.7)
    force = np.where((NODES >= 0.5 - 1e-12) & (NODES <= 0.7 + 1e-12), 1.0, 0.0)
    force[[4, 7, 16]] = 2e-14
    gap = np.full(NODES.size, 7e-18)
    result.contact = (result.contact[0], None, [], (NODES, force[None, :], None, gap[None, :]))
    qa, qb, on = E.stretch_ends(result, 0.5, 0.7)
    assert qa == pytest.approx(0.5, abs=1e-12) and qb == pytest.approx(0.7, abs=1e-12) and on


def test_a_point_whose_gap_slopes_are_level_is_a_short_stretch_between_its_nodes():
    """A point on its vertex 0.234375 L whose gap slope there and at its last most loaded node
    0.25 L are 0.0019587 and 0.0019958 (the workspace in a 1 % wider lumen, E_b = 9e-5 N m^2, B =
    (10, 0, 17.3) mT): their secant's zero is at -0.59 L, outside the rod; the rod lies along its
    wall there, a short stretch. Slopes of opposite signs keep the secant: a touching point."""
    p, node = 0.234375, 0.25
    level = CR._next(("point", p), (0.2493, p, 0.0019587, None), ("point", p, (p, node, 0.0019958, None)))
    assert level == ("stretch", p, node)
    crossing = CR._next(("point", p), (0.2493, p, 0.001, None), ("point", p, (p, node, -0.001, None)))
    assert crossing == ("point", pytest.approx(0.5 * (p + node), abs=1e-12))


def test_a_round_goes_on_doubling_until_its_stretch_ends_agree_on_two_meshes():
    """unsettled: reads 2e-4 L apart on the last two meshes go on, 5e-5 L apart stop; with
    ``short`` only a stretch shorter than an element beside it counts (0.2 L against 0.1 L: not)."""
    result, stretch = _result(0.5, 0.7, 0.5, 0.7), [("stretch", 0.5, 0.7)]
    now = [((0.5002, 0.7, 41), True)]
    assert E.unsettled(result, stretch, now, [((0.5, 0.7, 21), True)], 1e-4)
    assert not E.unsettled(result, stretch, now, [((0.50015, 0.7, 21), True)], 1e-4)
    assert not E.unsettled(result, stretch, now, [((0.5, 0.7, 21), True)], 1e-4, short=True)
    assert not E.unsettled(result, stretch, [((0.5002, 0.7, 41), False)], [((0.5, 0.7, 21), True)], 1e-4)


@pytest.mark.parametrize(
    ("node", "part"), [(0.3, False), (0.4, True), (0.6, True), (0.8, True), (0.9, False)]
)
def test_a_touch_on_a_stretch_or_the_element_beside_it_is_part_of_it(node, part):
    """A stretch from 0.5 to 0.7 L: a touch whose most loaded node lies on its elements or on the
    element beside either end (0.4-0.8 L) is that stretch seen on a coarse mesh."""
    result = _result(0.5, 0.7, 0.5, 0.7)
    assert bool(CR._part_of(result, (node, node, 0.0, None), ("stretch", 0.5, 0.7))) is part


def test_interior_contacts_are_in_the_order_of_where_they_touch():
    """Two walls touched beside the same node (0.5 L) at 0.52 and 0.48 L: sorted by where they
    touch, as the rounds pair them with their contacts; the tip's element (beyond 0.9 L) is left out."""
    touches = [(0.52, 0.5, 1.0, None), (0.95, 0.95, 0.0, None), (0.48, 0.5, -1.0, None)]
    result = _result(0.5, 0.5, 0.5, 0.5, touches=touches, entries=[])
    assert [t[0] for t in CR.interior_contacts(result)] == [0.48, 0.52]


def _solver(results):
    """A stand-in for ``meshes_at``: the result of each call in turn (the last one repeated),
    with what it was asked for."""
    given = []

    def meshes_at(points, enough=None, stretches=(), more=None):
        given.append((points, stretches))
        return results[min(len(given) - 1, len(results) - 1)], object()

    return meshes_at, given


def test_a_stretch_found_by_the_first_solve_is_meshed_at_its_ends_and_settles():
    """The first solve (no points) finds the rod lying on its wall from 0.4 to 0.6 L with the gap
    leaving it smoothly at both ends: the next solve has a vertex at each end, is told they bound a
    stretch (for stretch_order), and the ends stay (step 0)."""
    result = _result(0.4, 0.6, 0.4, 0.6)
    meshes_at, given = _solver([result])
    answer, _, rounds, step = CR.contact_rounds(meshes_at, 1e-6)
    assert given == [((), ()), ((0.4, 0.6), ((0.4, 0.6),))]
    assert answer is result and step < 1e-12 and len(rounds) == 2
    ((a, b),) = [entry["s"] for entry in answer.contact[0]]
    assert a == pytest.approx(0.4, abs=1e-12) and b == pytest.approx(0.6, abs=1e-12)


def test_contact_rounds_stop_after_contact_rounds_rounds(monkeypatch):
    """A stretch whose ends move out by 0.01 L each round never settles: the first solve and
    CONTACT_ROUNDS rounds, then a ConvergenceError naming the round."""
    calls = []

    def meshes_at(points, enough=None, stretches=(), more=None):
        calls.append(points)
        return _result(0.4, 0.6, 0.4, 0.6), object()

    monkeypatch.setattr(CR, "stretch_ends", lambda result, a, b: (a - 0.01, b + 0.01, True))
    with pytest.raises(ConvergenceError, match=f"after round {CR.CONTACT_ROUNDS} ") as err:
        CR.contact_rounds(meshes_at, 1e-6)
    assert len(calls) == 1 + CR.CONTACT_ROUNDS and err.value.info["round"] == CR.CONTACT_ROUNDS
    assert calls[-1] == pytest.approx(
        (0.4 - 0.01 * (CR.CONTACT_ROUNDS - 1), 0.6 + 0.01 * (CR.CONTACT_ROUNDS - 1))
    )


def test_a_stretch_end_extrapolates_only_from_two_rounds_read_on_one_mesh():
    """Moves of 1e-3 then 5e-4 (rate 0.5) put the end's fixed point two moves ahead, when both were
    read on one mesh; read on two meshes the moves need not share a rate (the estimate depends on
    the mesh), and the end takes its plain move. Moves that point at each other bracket the end on
    any meshes: the secant between them."""
    x0, q0, x, q = 0.500, 0.501, 0.501, 0.5015
    assert E.end_secant(x, q, x0, q0, True) == pytest.approx(0.502, abs=1e-12)
    assert E.end_secant(x, q, x0, q0, False) == q
    assert E.end_secant(0.501, 0.5004, 0.500, 0.5008, False) == pytest.approx(0.50057142857, abs=1e-9)


def test_a_round_stops_doubling_once_a_stretch_end_is_known_off_its_vertex():
    """An end's estimate 1e-3 from its vertex that changed by 1e-4 since the last mesh is off it;
    one that changed by 1e-3 (the estimate not yet resolved) or lies within the settling step is not."""
    stretch = [("stretch", 0.4, 0.6)]
    now = [((0.4, 0.601, 65), True)]
    assert E.known_off(stretch, now, [((0.4, 0.6009, 33), True)], 1e-6)
    assert not E.known_off(stretch, now, [((0.4, 0.6, 33), True)], 1e-6)
    assert not E.known_off(stretch, [((0.4, 0.6000005, 65), True)], [((0.4, 0.6, 33), True)], 1e-6)
    assert not E.known_off(stretch, now, None, 1e-6)
