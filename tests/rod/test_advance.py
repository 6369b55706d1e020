"""[advance] (contract section 12, matid/rod/advance.py): a tube pushed out of a sheath into a
channel, step by step, against the independent shooting reference's ``advance`` (each step's active
set found from the last one's, tests/rod/contact_reference.py, no matid code).

Targets: every step meets the contact targets (tip 1e-6 L, force 1e-4 relative, interior contact
positions 1e-4 L, L the step's free length). Interior contacts used to land on a mesh node (issue 31,
measured at 60 / 80 / 100 mm: tip 3.4e-5 / 1.5e-4 / 3.3e-5 L, force 5.4e-2 / 3.2e-2 / 1.2e-2, contact
s 1.4e-2 / 1.4e-2 / 3.3e-3 L, estimate blind ~1e-8); a mesh vertex now sits at each
(matid.rod.contact_rounds: 2.2e-10 / 1.9e-10 / 9.1e-10 L, 2.2e-7 / 1.3e-7 / 1.4e-7, 1.7e-8 /
2.1e-8 / 4.5e-9 L, estimate 2.8e-7 / 9.5e-8 / 1.3e-7).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from matid.errors import ConvergenceError
from matid.rod import advance as A
from matid.rod.api import solve
from matid.rod.output import solution_json
from matid.rod.scenes import load_scene, scene_from_dict

from . import contact_reference as cr
from .test_contact import CHANNEL, MAG, channel_field, rod, walls

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "advance_channel.toml"


def reference_of(scene):
    """The reference's advance of a planar (x-z) scene with a tip magnet."""
    (at, m), B = scene.loads.magnets[0], scene.loads.B
    assert at == scene.rod.length
    ws = [((w.point[0], w.point[2]), (w.normal[0], w.normal[2])) for w in scene.walls]
    return cr.advance(list(scene.advance), scene.rod.E_b, scene.rod.outer_diameter / 2, walls=ws,
                      B=(B[0], B[2]), m=m, tube_length=scene.rod.length)  # fmt: skip


def errors(step, ref):
    """(contact set, tip error / free length, max force rel. error, max contact s error / free length)."""
    free = step["free_length"]
    tip = np.asarray(step["tip"]["position"])[[0, 2]]
    mine = {c["boundary"]: c for c in step["contacts"]}
    theirs = {f"wall {c['wall'] + 1}": c for c in ref["contacts"]}
    assert sorted(mine) == sorted(theirs), (step["contacts"], ref["contacts"])
    e_force = e_s = 0.0
    for name, c in theirs.items():
        F = np.asarray(mine[name]["force"])[[0, 2]]
        e_force = max(e_force, float(np.linalg.norm(F - c["force_vector"]) / np.linalg.norm(c["force_vector"])))
        e_s = max(e_s, abs(mine[name]["s"][0] - c["s"]) / free)
    return sorted(mine), float(np.abs(tip - ref["tip"]).max()) / free, e_force, e_s


def compare(scene):
    sol = solve(scene)
    doc = json.loads(json.dumps(solution_json(sol)))  # the steps as written to solution.json
    refs = reference_of(scene)
    assert all(r["admissible"] for r in refs)
    assert [s["free_length"] for s in doc["steps"]] == list(scene.advance)
    assert doc["tip"] == doc["steps"][-1]["tip"] and doc["free_length"] == scene.advance[-1]
    rows = [errors(step, ref) for step, ref in zip(doc["steps"], refs, strict=True)]
    for step, (names, e_tip, e_force, e_s) in zip(doc["steps"], rows, strict=True):
        print(f"| {step['free_length'] * 1e3:g} mm | {','.join(names) or '-'} | {e_tip:.2e} | {e_force:.2e} "
              f"| {e_s:.2e} | {step['discretization_error']:.2e} |")  # fmt: skip
    return doc, rows


def test_example_advance_channel_against_the_reference():
    """examples/scenes/advance_channel.toml: free at 20 and 30 mm, then the tip on wall 2 (40-60 mm),
    each step from the last; every tip-contact step meets the targets."""
    scene = load_scene(EXAMPLE)
    doc, rows = compare(scene)
    assert [names for names, *_ in rows] == [[], [], ["wall 2"], ["wall 2"], ["wall 2"]]
    for step, (_, e_tip, e_force, _) in zip(doc["steps"], rows, strict=True):
        assert step["converged"] and e_tip < 1e-6 and e_force < 1e-4
        assert all(c["gap_min"] >= -doc["contact_tolerance"] for c in step["contacts"])


def channel_advance():
    B = channel_field(0.1)
    raw = {"rod": rod(0.1), "field": {"B": [B[0], 0, B[1]]}, "magnet": [{"at": 0.1, "moment": MAG}],
           "wall": walls(CHANNEL), "advance": {"free_lengths": [0.02, 0.04, 0.06, 0.08, 0.1]}}  # fmt: skip
    return scene_from_dict(raw)


def test_channel_advance_finds_the_interior_contact_in_order():
    """The test_contact channel (6 mT) pushed out: free, free, then wall 1 inside the tube at ~40 mm."""
    _, rows = compare(channel_advance())
    assert [names for names, *_ in rows] == [[], [], ["wall 1"], ["wall 1"], ["wall 1"]]
    assert all(e_tip < 1e-6 for _, e_tip, _, _ in rows[:2])  # the free steps meet the tip target


def test_channel_advance_interior_contacts_meet_the_targets():
    _, rows = compare(channel_advance())
    assert all(e_tip < 1e-6 and e_force < 1e-4 and e_s < 1e-4 for _, e_tip, e_force, e_s in rows)


def test_step_scene_keeps_positions_on_the_tube():
    raw = {"rod": rod(0.1), "segment": [{"from": 0.0, "to": 0.05, "E_b": 2e-5},
                                         {"from": 0.05, "to": 0.1, "E_b": 3e-5}],  # fmt: skip
           "magnet": [{"at": 0.03, "moment": 1e-3}, {"at": 0.1, "moment": 1e-3}],
           "point_load": [{"at": 0.07, "force": [1e-4, 0, 0]}], "advance": {"free_lengths": [0.04]}}  # fmt: skip
    step = A.step_scene(scene_from_dict(raw), 0.04)
    assert step.rod.length == 0.04 and step.advance is None
    assert [(s.start, s.end) for s in step.rod.segments] == [(0.0, pytest.approx(0.04))]
    assert step.rod.segments[0].overrides["E_b"] == 3e-5
    assert [at for at, _ in step.loads.magnets] == [pytest.approx(0.04)]
    assert [at for at, _, _ in step.loads.point_loads] == [pytest.approx(0.01)]


def test_a_step_that_cannot_be_reached_is_named():
    """Past 50 mm nothing solves: step 3 (40 to 60 mm) is bisected, reaches 50 mm and stops there,
    naming the step, the free length reached and the solver's load factor."""
    scene = channel_advance()

    def failing(step, start):
        if step.rod.length > 0.05:
            raise ConvergenceError("Newton failed", load_factor=0.25)
        return solve(step), None

    says = r"step 3 \(free length 60 mm, reached 50 mm\).*load factor 0.25"
    with pytest.raises(ConvergenceError, match=says):
        A.solve_steps(scene, failing)


def test_a_step_that_fails_is_reached_through_halved_increments():
    """A solver that fails on increments longer than 12 mm: each step is halved (the first from the
    sheath, free length 0), each sub-step from the last one reached, and only the listed steps are
    returned, each with its sub-steps counted."""
    scene = dataclasses.replace(channel_advance(), advance=(0.02, 0.04, 0.05))
    asked, reached = [], [0.0]

    def short_steps(step, start):
        free = step.rod.length
        asked.append(round(free * 1e3, 6))
        if free - reached[-1] > 0.012:
            raise ConvergenceError("Newton failed", load_factor=0.5)
        reached.append(free)
        return f"solution at {free}", None

    steps = A.solve_steps(scene, short_steps)
    assert asked == [20, 10, 20, 40, 30, 40, 50]
    assert [(s.free, s.solution, s.substeps) for s in steps] == [
        (0.02, "solution at 0.02", 1),
        (0.04, "solution at 0.04", 1),
        (0.05, "solution at 0.05", 0),
    ]


def test_the_shortest_sub_step_is_a_fraction_of_the_free_length():
    """Halving stops at MIN_SUBSTEP of the step's free length: a solver that fails on every increment
    of more than 0.1 mm is refused at 20 mm, after halving down to 20 mm x MIN_SUBSTEP."""
    scene = dataclasses.replace(channel_advance(), advance=(0.02,))
    asked = []

    def tiny_steps(step, start):
        asked.append(step.rod.length)
        if step.rod.length > 1e-4:
            raise ConvergenceError("Newton failed", load_factor=0.0)
        return "solved", None

    with pytest.raises(ConvergenceError, match=r"step 1 \(free length 20 mm\)"):
        A.solve_steps(scene, tiny_steps)
    assert min(asked) == pytest.approx(0.02 * A.MIN_SUBSTEP) and min(asked) > 1e-4


def test_the_warm_start_continues_the_last_shape_along_its_tip():
    """The last centreline stays where it is (scaled by the new length) and the new length continues
    beyond its tip along the tip's tangent."""
    vertices = np.linspace(0.0, 1.0, 3)
    theta = np.linspace(0.0, 0.4, 5)
    values = np.column_stack([0.1 * theta, np.linspace(0, 1, 5), theta])
    v, U = A.pushed((vertices, values), "planar", 0.02, 0.04)
    assert np.allclose(v, [0.0, 0.25, 0.5, 1.0])
    assert np.allclose(U[:5, :2], values[:, :2] / 2) and np.allclose(U[:5, 2], theta)
    tangent = np.array([math.sin(0.4), math.cos(0.4)])
    assert np.allclose(U[5:, :2], U[4, :2] + np.outer([0.25, 0.5], tangent)) and np.allclose(U[5:, 2], 0.4)
    assert A.pushed((vertices, values), "planar", 0.04, 0.04) is None


def test_the_warm_start_is_moved_onto_the_allowed_side_of_the_walls():
    """A tip pointing at a wall (x = 3 mm; the tube's radius 0.5 mm): the continued piece would cross
    it; every node of the start is on the allowed side (gap >= 0) and the nodes short of the wall
    are where they were."""
    raw = {"rod": rod(0.04), "magnet": [{"at": 0.04, "moment": MAG}], "field": {"B": [5e-3, 0, 0]},
           "wall": [{"point": [3e-3, 0, 0], "normal": [-1, 0, 0]}]}  # fmt: skip
    keep = A.keep_out_of(scene_from_dict(raw), (1.0, 0.0))
    vertices = np.linspace(0.0, 1.0, 3)
    s = np.linspace(0.0, 1.0, 5)
    values = np.column_stack([0.1 * s**2, s, 0.2 * s])  # 10 mm, its tip 1 mm from the axis, at 11.5 deg
    free = 0.04
    v, U = A.pushed((vertices, values), "planar", 0.01, free, keep)
    free_pushed = A.pushed((vertices, values), "planar", 0.01, free)[1]
    assert free_pushed[:, 0].max() * free > 2.5e-3 + 1e-4  # without the projection it crosses
    assert U[:, 0].max() * free == pytest.approx(2.5e-3, rel=1e-12)
    inside = free_pushed[:, 0] * free < 2.5e-3
    assert np.allclose(U[inside], free_pushed[inside], rtol=0, atol=1e-15) and not inside.all()


def test_a_step_whose_model_changes_starts_from_the_straight_tube():
    """Fuzz (issue 30): a point load whose moment leaves the plane is in the sheath at the first step
    (a planar step) and out at the second (a full step). The planar state is no warm start for the
    full model (an IndexError, exit 3, before): the second step solves from the straight tube and
    equals the solve of its scene alone."""
    raw = {"rod": {**rod(0.03), "outer_diameter": 2.4e-3},
           "point_load": [{"at": 0.012, "force": [0, 0, -1e-3], "moment": [8e-4, 0, 4e-4]}],
           "magnet": [{"at": 0.03, "moment": 0.0125}], "field": {"B": [5e-3, 0, 0]},
           "advance": {"free_lengths": [0.01, 0.03]}}  # fmt: skip
    scene = scene_from_dict(raw)
    sol = solve(scene, elements=4)
    assert [s["free_length"] for s in sol.extra["steps"]] == [0.01, 0.03] and sol.model == "full"
    alone = solve(A.step_scene(scene, 0.03), elements=4)
    assert np.allclose(sol.tip["position"], alone.tip["position"], rtol=0, atol=1e-9 * 0.03)


LUMEN_EXAMPLE = EXAMPLE.parent / "advance_lumen.toml"


def test_example_advance_lumen_against_the_reference():
    """examples/scenes/advance_lumen.toml (a 90 degree vessel bend at the sheath's exit): free at 5 mm,
    then the tip on the bend's outer wall, sliding along it (10-25 mm, 72 degrees into the bend at
    25 mm), against the reference's tip in a bent lumen (cr.advance_in_bend: shooting, the reaction
    along the wall's normal). Measured: tip <= 1.9e-8 L (estimates 2.7e-11 to 4.4e-7). The steps to
    22.5 and 25 mm failed before the warm start was kept inside the lumen and a failed increment
    bisected (the start translated along the sheath's axis put the tip 2.1 mm beyond the outer wall);
    past 25 mm the reference's tip-alone state crosses the inner wall (a second contact: 27.5 mm)."""
    scene = load_scene(LUMEN_EXAMPLE)
    assert lumen_steps_against_the_reference(scene) == [0, 1, 1, 1, 1, 1, 1]


def lumen_steps_against_the_reference(scene) -> list[int]:
    """Every step of an [advance] through the example's bend against cr.advance_in_bend (tip 1e-6 of
    the free length, force 1e-4, the contact at the tip, within the contact tolerance); the reference's
    number of contacts per step."""
    (a, b, c), lu = scene.lumen.centreline, scene.lumen
    assert a[:2] == b[:2] == (0, 0) and a[2] < 0 and c[2] == b[2]  # the bend of the reference
    lumen = cr.BendLumen(lu.radius, lu.corner_radius, math.pi / 2)
    assert b[2] == pytest.approx(lu.corner_radius)  # the arc starts at the clamp
    (_, m), B = scene.loads.magnets[0], scene.loads.B
    refs = cr.advance_in_bend(list(scene.advance), scene.rod.E_b, scene.rod.outer_diameter / 2, lumen,
                              B=(B[0], B[2]), m=m)  # fmt: skip
    assert all(r["admissible"] for r in refs)
    doc = json.loads(json.dumps(solution_json(solve(scene))))
    for step, ref in zip(doc["steps"], refs, strict=True):
        free = step["free_length"]
        tip = np.asarray(step["tip"]["position"])[[0, 2]]
        assert step["converged"] and np.abs(tip - ref["tip"]).max() < 1e-6 * free
        assert [c["boundary"] for c in step["contacts"]] == ["lumen"] * len(ref["contacts"])
        for mine, theirs in zip(step["contacts"], ref["contacts"], strict=True):
            F = np.asarray(mine["force"])[[0, 2]]
            assert np.linalg.norm(F - theirs["force_vector"]) < 1e-4 * theirs["force"]
            assert mine["s"][0] > free * (1 - 1e-3) and mine["gap_min"] >= -doc["contact_tolerance"]
        e_tip = np.abs(tip - ref["tip"]).max() / free
        print(f"| {free * 1e3:g} mm | {e_tip:.2e} | {step['discretization_error']:.2e} |")
    return [len(r["contacts"]) for r in refs]


def test_the_documented_shortest_sub_step_is_the_code_s():
    contract = (Path(__file__).resolve().parents[2] / "docs" / "contract.md").read_text()
    assert A.MIN_SUBSTEP == 1 / 64 and "down to 1/64 of the step's free length" in " ".join(contract.split())
