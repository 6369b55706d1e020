"""Contacts active from the first load step (issue 31): a rod lying along a wall pressed on it by its
tip force, and a magnetised tube in a straight lumen just wider than it, on the meshes that stopped
Newton before and automatically.

Before, both stopped at load factor 0 with "Newton stagnated at corrections of 3e-4 (7e-4)": the
semismooth Newton of the penalty contact moves the edge of its active set by about one node per
iteration and its corrections level at ~3e-4 meanwhile, which the round-off test read as
stagnation. Newton now judges the round-off and divergence only between iterations on one active
set (matid.rod.newton.MAX_PIECEWISE_ITER).

The references are independent of matid's solver: the closed form of the rod pressed on the wall
(straight, the wall's reaction -F at the tip) and the shooting of tests/rod/contact_reference.py.
A magnetisation mu along d3 in a uniform field B puts a couple mu d3 x B = d/ds (mu r x B) on the
inextensible rod, so its moment balance M' + r' x (n + mu B) = 0 is that of a rod loaded by a tip
force mu B only: the reference is the tip on the lumen's wall under the tip force mu B (its
reaction the same). matid runs E_s L^2/E_b = E_e L^2/E_b = 1e9 (the models differ by ~1e-9).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from matid.rod.api import solve
from matid.rod.scenes import scene_from_dict

from . import contact_reference as cr
from .test_contact import EB, FLOOR, R_O, F, L, rod

WALL = [{"point": [R_O, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}]  # x <= 0: the rod lies along it


def _state_checked(sol, normals):
    """The returned state meets its walls within contact_tolerance and no reaction pulls."""
    for c in sol.extra["contacts"]:
        assert c["gap_min"] >= -sol.extra["contact_tolerance"], c
        assert float(np.dot(c["force"], normals[c["boundary"]](c["position"]))) > 0.0, c


@pytest.mark.parametrize("elements", [16, 64, None])
def test_a_rod_lying_along_a_wall_pressed_by_its_tip_force_stays_straight(elements):
    P = 2.0
    raw = {"rod": rod(), "tip": {"force": [P * F, 0, 0]}, "wall": WALL}
    sol = solve(scene_from_dict(raw), elements=elements)
    (c,) = sol.extra["contacts"]
    print(f"| along a wall | {sol.elements} | {sol.newton_iterations} | {c['force'][0] / F + P:.1e} |")
    assert np.abs(np.asarray(sol.tip["position"]) - [0.0, 0.0, L]).max() < 1e-9 * L
    assert np.abs(np.asarray(sol.position)[:, 0]).max() < 1e-9 * L  # straight
    assert c["force"][0] == pytest.approx(-P * F, rel=FLOOR)  # the closed form -F (the models: ~1e-9)
    assert abs(c["force"][2]) < 1e-9 * F
    assert c["s"][1] == pytest.approx(L, abs=1e-12)  # at the tip
    _state_checked(sol, {"wall 1": lambda r: np.array([-1.0, 0.0, 0.0])})


def _inward(r):
    """The lumen's normal towards the tube at a contact position r (axis z)."""
    return -np.array([r[0], r[1], 0.0]) / math.hypot(r[0], r[1])


@pytest.mark.parametrize("model", ["auto", "full"])
@pytest.mark.parametrize("elements", [16, None])
@pytest.mark.parametrize("gap", [1.01, 1.1])
def test_a_magnetised_tube_in_a_lumen_just_wider_is_the_planar_wall_solution_rotated(gap, elements, model):
    """q = 6.4 at 120 deg (the catalogue's magnetic cantilever) in a lumen of ``gap`` tube radii
    along the clamp's axis, in the plane at 35 deg about that axis: the tip on the wall x = rho - R_o
    of the reference under the tip force mu B, rotated."""
    q, psi, azimuth, B = 6.4, math.radians(120), math.radians(35), 0.04
    mu = q * EB / (B * L**2)
    rho = gap * R_O
    Bp = (B * math.sin(psi), B * math.cos(psi))
    ref = cr.solve_planar_contact(L, EB, R_O, [cr.lumen_wall(rho)], tip_force=(mu * Bp[0], mu * Bp[1]),
                                  contacts=[("tip", 0)])  # fmt: skip
    assert ref["converged"] and ref["admissible"] and cr.lumen_gap_min(ref, rho, R_O) >= -1e-12 * L
    tip3 = cr.rotate_about_axis(ref["tip"], azimuth)
    force3 = cr.rotate_about_axis(ref["contacts"][0]["force_vector"], azimuth)
    B3 = [Bp[0] * math.cos(azimuth), Bp[0] * math.sin(azimuth), Bp[1]]
    raw = {"rod": rod(), "field": {"B": B3}, "magnetization": [{"from": 0.0, "to": L, "per_length": mu}],
           "lumen": {"centreline": [[0, 0, -L], [0, 0, 2 * L]], "radius": rho}}  # fmt: skip
    sol = solve(scene_from_dict(raw), elements=elements, model=model)
    (c,) = sol.extra["contacts"]
    e_tip = float(np.abs(np.asarray(sol.tip["position"]) - tip3).max()) / L
    e_force = float(np.linalg.norm(np.asarray(c["force"]) - force3) / np.linalg.norm(force3))
    est = sol.discretization_error
    row = f"{sol.elements} | {sol.newton_iterations} | {e_tip:.1e} | {e_force:.1e} | {est:.1e}"
    print(f"| lumen {gap} R_o ({sol.model}) | {row} |")
    assert c["s"][0] == pytest.approx(L, abs=1e-12)  # the tip only
    assert e_tip < 1e-6 and e_force < 1e-4
    assert est >= (max(e_tip, e_force) - FLOOR) / 3
    _state_checked(sol, {"lumen": _inward})
