"""Contact over a stretch (issue 31): a cantilever lying along a wall through its clamp, pressed onto
it by a uniform load q and pulled off near its tip by a tip force P, against the closed forms of
equilibrium (the wall carries q L - P: the rod lies straight on the wall over [0, a] with no moment
and no shear, so the clamp carries nothing) and the independent shooting of its free piece
(tests/rod/contact_reference.lying_on_a_wall: where it leaves the wall and its tip); and the check
every returned contact state passes (matid.rod.contact_rounds.check).

Before, every case here exited 1: "the walls are not met within 1e-09 L after 30 multiplier
updates" (Uzawa's rate ~1 - k sigma_min on a stretch, sigma_min ~ h^3); once settled, the clamp
node's share of the load (q h / 6) went to the clamp, not the wall, and the estimate with the
observed order was up to 6x below the true tip error.

Measured (q L^3/E_b, P L^2/E_b; elements; tip error / L; resultant rel. error; where it leaves
the wall, error / L; reported estimate):
    (1, 0)     8     1.4e-16  2.0e-14  0        1.2e-12
    (10, 2)   512    4.3e-08  3.1e-15  1.4e-05  7.5e-07
    (10, 4)   512    2.8e-08  6.3e-10  2.3e-06  9.1e-07
    (3, 1)    512    8.7e-08  4.5e-09  1.9e-06  4.7e-07
"""

from __future__ import annotations

import numpy as np
import pytest

from matid.rod import cantilever
from matid.rod.api import solve
from matid.rod.contact_rounds import ContactStateError, check
from matid.rod.scenes import scene_from_dict
from matid.rod.system import RodSystem
from matid.rod.terms import contact as C

from . import contact_reference as cr
from .test_contact import EB, ES, FLOOR, R_O, F, L

WALL = [{"point": [R_O, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}]  # x <= 0: the rod lies along it


def lying(q, P, **extra):
    """The scene: a uniform load q L^3/E_b towards the wall (+x), a tip force P L^2/E_b off it."""
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": ES, "E_e": ES, "outer_diameter": 2 * R_O}
    raw = {"rod": rod, "load": {"distributed_force": [q * F / L, 0, 0]}, "wall": WALL, **extra}
    if P:
        raw["tip"] = {"force": [-P * F, 0, 0]}
    return scene_from_dict(raw)


def test_the_reference_leaves_the_wall_where_beam_theory_says_in_the_small_deflection_limit():
    """lying_on_a_wall against the small-deflection closed form ell = L - a = 2 P / q (M(a) = 0 with
    M(s) = P (L - s) - q (L - s)^2 / 2 on the free piece): the relative difference falls as P^2."""
    errors = []
    for P in (0.2, 0.1, 0.05):
        out = cr.lying_on_a_wall(L, EB, P * 5 * F / L, P * F)
        errors.append(abs((L - out["a"]) / (2 * L / 5) - 1))
    order = np.diff(np.log(errors)) / np.diff(np.log([0.2, 0.1, 0.05]))
    assert np.all(np.abs(order - 2) < 0.05), (errors, order)
    assert errors[-1] < 1e-4


def test_a_rod_lying_on_a_wall_under_a_load_carries_it_all_into_the_wall():
    sol = solve(lying(1.0, 0.0))
    (c,) = sol.extra["contacts"]
    assert c["boundary"] == "wall 1"
    assert c["s"] == [0.0, pytest.approx(L, abs=1e-12)]
    assert c["force"][0] == pytest.approx(-1.0 * F, rel=1e-9)  # q L: the closed form of equilibrium
    assert abs(c["force"][2]) < 1e-9 * F
    assert c["gap_min"] >= -sol.extra["contact_tolerance"]
    assert np.abs(np.asarray(sol.tip["position"]) - [0, 0, L]).max() < 1e-9 * L


@pytest.mark.parametrize(("q", "P"), [(10.0, 2.0), (10.0, 4.0), (3.0, 1.0)])
def test_a_rod_pressed_on_a_wall_and_pulled_off_at_its_tip(q, P):
    sol = solve(lying(q, P))
    ref = cr.lying_on_a_wall(L, EB, q * F / L, P * F)
    tip = np.asarray(sol.tip["position"])[[0, 2]]
    e_tip = float(np.abs(tip - ref["tip"]).max()) / L
    (c,) = sol.extra["contacts"]  # one stretch, from the clamp to where the rod leaves the wall
    e_force = abs(-c["force"][0] - ref["reaction"]) / ref["reaction"]
    e_a = abs(c["s"][1] - ref["a"]) / L
    est = sol.discretization_error
    print(f"| ({q:g}, {P:g}) | {sol.elements} | {e_tip:.1e} | {e_force:.1e} | {e_a:.1e} | {est:.1e} |")
    assert c["s"][0] == 0.0
    assert e_tip < 1e-6 and e_force < 1e-6 and e_a < 1e-4
    assert c["gap_min"] >= -sol.extra["contact_tolerance"]
    assert est >= (e_tip - FLOOR) / 3


def _system(raw, elements=8):
    """A bound RodSystem of a scene (the mesh and terms equilibrium would build) and its straight state."""
    scene = scene_from_dict(raw)
    chosen, e_a, rod, loads, at = cantilever.prepare_scene(scene, "auto")
    disc = cantilever.mesh(elements, at, 3 if chosen == "planar" else 7, "P2", 2)
    system = RodSystem(disc, rod, loads, model=chosen, banded=True, mixed=True, c_u=1.0)
    return system, system.reduce(system.reference())


def test_check_names_a_state_crossing_a_wall():
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": ES, "E_e": ES, "outer_diameter": 2 * R_O}
    wall = [{"point": [0.0, 0.0, 0.5 * L], "normal": [0.0, 0.0, -1.0]}]  # across the rod at L/2
    system, X = _system({"rod": rod, "wall": wall})
    with pytest.raises(ContactStateError, match="crosses a wall"):
        check(system, X)


def test_check_names_a_pulling_reaction(monkeypatch):
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": ES, "E_e": ES, "outer_diameter": 2 * R_O}
    system, X = _system({"rod": rod, "wall": WALL})
    check(system, X)  # the straight rod along the wall: no force, no crossing, stable

    def pulling(self, prep, U):
        f, gaps = original(self, prep, U)
        f[0, 1] = -1.0
        return f, gaps

    original = C.Contact.forces
    monkeypatch.setattr(C.Contact, "forces", pulling)
    with pytest.raises(ContactStateError, match="pulls"):
        check(system, X)


def test_check_names_an_unstable_state():
    """The straight rod under an axial tip load beyond Euler's pi^2/4 E_b/L^2 is an equilibrium, not
    a stable one; a wall far away does not hold it."""
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": ES, "E_e": ES, "outer_diameter": 2 * R_O}
    far = [{"point": [0.5 * L, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}]
    system, X = _system({"rod": rod, "tip": {"force": [0, 0, -3.0 * F]}, "wall": far}, elements=8)
    from matid.rod.newton import newton

    X, _, lu = newton(system, X, 1.0)
    with pytest.raises(ContactStateError, match="unstable"):
        check(system, X, lu)


def test_check_names_a_small_reaction_across_an_open_gap(monkeypatch):
    """A wall 0.5 L away: every gap is open, so no reaction may act; one of 0.5 E_b/L^2 (below
    1 in those units) is named as not complementary."""
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": ES, "E_e": ES, "outer_diameter": 2 * R_O}
    far = [{"point": [0.5 * L, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}]
    system, X = _system({"rod": rod, "wall": far})
    check(system, X)  # the straight rod, far from the wall: nothing to name

    def pushing(self, prep, U):
        f, gaps = original(self, prep, U)
        f[0, 1] = 0.5
        return f, gaps

    original = C.Contact.forces
    monkeypatch.setattr(C.Contact, "forces", pushing)
    with pytest.raises(ContactStateError, match="across an open gap"):
        check(system, X)


@pytest.mark.parametrize(
    ("stretch", "order"),
    [
        ((0.0, 0.6), "stretch"),  # from the root, leaving the wall at 0.6 L: inside the rod
        ((0.4, 1.0), "stretch"),  # from inside the rod to the tip
        ((0.0, 1.0), "p2"),  # the whole rod on the wall: no end inside
        ((0.5, 0.5), "p2"),  # a point contact, not a stretch
    ],
)
def test_a_stretch_that_leaves_its_wall_inside_the_rod_caps_the_estimate_s_order(stretch, order):
    """contact_ends.stretch_order on hand-made results (8 elements on [0, 1]): an end of a
    stretch inside the rod hops between nodes as the mesh doubles, so the order is capped."""
    from types import SimpleNamespace

    from matid.rod.accuracy import P2_ORDER
    from matid.rod.contact_ends import STRETCH_ORDER, stretch_order

    result = SimpleNamespace(
        contact=([{"s": stretch}],), disc=SimpleNamespace(vertices=np.linspace(0.0, 1.0, 9))
    )
    assert stretch_order(result) == {"stretch": STRETCH_ORDER, "p2": P2_ORDER}[order]
