"""Examples as tests (scikit-fem's habit): every scene in examples/scenes and the demo study,
each against a number from a source other than matid's solver, never matid's output pasted in.

- Cantilever scenes: tests/rod/reference.py, the strong form of the Cosserat rod integrated by
  shooting (it shares no code with matid's finite elements): tip position and directors.
- [aim]: the field matid found, put into the reference: its tip must point at the target.
- tip_twist_stability: solved (not refused), to the stable state, the reference's branch; the
  saddle the old full model returned is 2 rad away (tests/rod/test_designer_stability.py).
- The three-point bend: matid.example.bend_shooting, a strong-form shooting model of the bend.
- The demo study: its ground truth (matid/example/ground_truth.json), each fitted value's
  interval covering it, the one nose-travel E_s warned as biased low.

A new example scene fails test_every_example_has_a_reference until it gets a line in CASES.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from matid.app.api import fit
from matid.example.bend_shooting import bend_path
from matid.rod.api import bend_force_scale, solve
from matid.rod.scenes import load_scene
from tests import ROOT
from tests.rod import reference

EXAMPLES = ROOT / "examples" / "scenes"
DEMO = ROOT / "matid" / "example"

#: scene -> (matid's model, tolerance on the tip position / L and on d1, d3; aim: on the tip
#: direction, rad); "aim", "bend" and "stability" have their own checks. The tolerance is the
#: scenes' own (1e-6, matid's default); measured: 2.6e-9 to 4.7e-7 (the table in issue 29's note).
CASES = {
    "tip_force": ("planar", 1e-6),
    "soft_shear": ("planar", 1e-6),
    "point_load": ("full", 1e-6),
    "curved_tip": ("full", 1e-6),
    "magnet_direction": ("full", 1e-6),
    "magnetization_direction": ("full", 1e-6),
    "magnetic_cantilever": ("planar", 1e-6),
    "precurved_3d": ("full", 1e-6),
    "aim": ("aim", 1e-6),
    "three_point_bend": ("bend", 1e-6),
    "tip_twist_stability": ("stability", 1e-6),
}


#: Contact examples, each checked against tests/rod/contact_reference.py (the independent shooting
#: solver of walls and contact points) by the test named here.
CONTACT = {
    "wall_tip": "tests.rod.test_contact:test_example_wall_tip_against_the_reference",
    "advance_channel": "tests.rod.test_advance:test_example_advance_channel_against_the_reference",
    "advance_lumen": "tests.rod.test_advance:test_example_advance_lumen_against_the_reference",
}


def test_every_example_has_a_reference():
    assert sorted(p.stem for p in EXAMPLES.glob("*.toml")) == sorted({**CASES, **CONTACT})


@pytest.mark.parametrize("name", sorted(CONTACT))
def test_each_contact_example_is_checked_against_the_contact_reference(name):
    module, function = CONTACT[name].split(":")
    check = getattr(importlib.import_module(module), function)
    assert f"{name}.toml" in inspect.getsource(check)  # that test reads this very example


def _tip_errors(sol, ref, L: float) -> tuple[float, float]:
    position = np.max(np.abs(np.array(sol.tip["position"]) - ref["position"])) / L
    directors = max(np.max(np.abs(np.array(sol.tip[k]) - ref[k])) for k in ("d1", "d3"))
    return float(position), float(directors)


@pytest.mark.parametrize("name", [n for n, (kind, _) in CASES.items() if kind in ("planar", "full")])
def test_cantilever_example_is_the_shooting_reference(name):
    model, tol = CASES[name]
    scene = load_scene(EXAMPLES / f"{name}.toml")
    sol = solve(scene)
    ref = reference.solve(scene, steps=16)
    assert sol.model == model and sol.converged
    position, directors = _tip_errors(sol, ref, scene.rod.length)
    assert position < tol and directors < tol, (position, directors)
    L = scene.rod.length  # the scene moves the tip (soft_shear: by shear, d3 hardly turns)
    assert max(np.max(np.abs(ref["position"] - [0, 0, L])) / L, np.max(np.abs(ref["d3"] - [0, 0, 1]))) > 0.03


def test_aim_example_field_points_the_reference_tip_at_the_target():
    scene = load_scene(EXAMPLES / "aim.toml")
    sol = solve(scene)
    B = np.array(sol.scene.loads.B)
    assert abs(np.linalg.norm(B) - scene.aim.field_magnitude) < 1e-12 * scene.aim.field_magnitude
    ref = reference.solve(dataclasses.replace(scene, aim=None), B=B, steps=16)
    target = np.array(scene.aim.tip_direction) / np.linalg.norm(scene.aim.tip_direction)
    miss = math.acos(min(1.0, float(np.dot(ref["d3"], target))))
    assert miss < CASES["aim"][1], miss  # rad


def _bend_reference(scene) -> tuple[np.ndarray, np.ndarray]:
    bend, rod = scene.bend, scene.rod
    force, _, support_s = bend_path(
        np.r_[0.0, bend.deflections], E_b=rod.E_b, E_s=rod.E_s, E_e=rod.E_e, span=bend.span,
        specimen_length=rod.length, support_radius=bend.support_radius,
        nose_radius=bend.nose_radius, outer_diameter=rod.outer_diameter,
    )  # fmt: skip
    return force[1:], support_s[1:]


def test_three_point_bend_example_is_the_shooting_bend_at_a_nested_mesh():
    """On 24 elements (and 12 for its estimate: the support on vertices 8 and 4, nested) matid's
    nose force is the shooting model's within matid's own error estimate (relative to the force
    scale of matid.rod.api.bend_force_scale) and the tolerance: measured 2.4e-7 against 2.4e-7."""
    scene = load_scene(EXAMPLES / "three_point_bend.toml")
    sol = solve(scene, elements=24)
    force, support_s = _bend_reference(scene)
    error = np.max(np.abs(np.asarray(sol.three_point_bend["force"]) - force)) / bend_force_scale(scene)
    assert sol.model == "planar" and sol.three_point_bend["deflection"] == pytest.approx([1e-4, 5e-4, 1e-3])
    assert error < min(2 * sol.discretization_error, CASES["three_point_bend"][1]), (
        error,
        sol.discretization_error,
    )
    assert (
        np.max(np.abs(np.asarray(sol.three_point_bend["support_contact_s"]) - support_s))
        < 1e-6 * scene.bend.span
    )


def test_three_point_bend_example_as_shipped_meets_its_tolerance():
    """The shipped scene on its automatic meshes, against the shooting model. Its meshes 4, 8, 16
    did not nest (support vertex round(n/3): 1, 3, 5): estimate 7.1e-7, error 1.6e-6 of the force
    scale. With rod.bend.support_vertex (1, 2, 4, 8): meshes 4-32, estimate 2.6e-7, error 2.5e-7."""
    scene = load_scene(EXAMPLES / "three_point_bend.toml")
    sol = solve(scene)
    force, _ = _bend_reference(scene)
    scale = bend_force_scale(scene)  # matid's error is relative to it
    error = np.max(np.abs(np.asarray(sol.three_point_bend["force"]) - force)) / scale
    assert error < scene.tolerance, (error, sol.elements, sol.discretization_error)


def test_tip_twist_stability_example_is_solved_to_the_stable_state():
    """Expected: solved, not refused; the tip at the stable root of theta = q sin(psi - theta)
    near 147.5 deg (the reference's branch, reached by raising the load from the straight rod),
    not at the saddle near -7.3 deg."""
    scene = load_scene(EXAMPLES / "tip_twist_stability.toml")
    sol = solve(scene)
    ref = reference.solve(scene, steps=32)
    assert sol.model == "full" and sol.converged
    position, directors = _tip_errors(sol, ref, scene.rod.length)
    assert position < CASES["tip_twist_stability"][1] and directors < CASES["tip_twist_stability"][1]
    B = np.array(scene.loads.B)
    (_, m), rod = scene.loads.magnets[0], scene.rod
    q, psi = m * np.linalg.norm(B) * rod.length / rod.E_b, math.atan2(B[0], B[2])
    stable = brentq(lambda t: t - q * math.sin(psi - t), 2.0, psi)  # inextensible: shear moves it ~0.1 deg
    assert abs(math.acos(ref["d3"][2]) - stable) < 0.01


@pytest.fixture(scope="module")
def demo():
    return fit(DEMO), json.loads((DEMO / "ground_truth.json").read_text())["specimens"]


def test_demo_study_intervals_cover_the_ground_truth(demo):
    result, truth = demo
    assert result.ok, result.failures
    estimates = result.study_result.estimates()
    seen = 0
    for sid, params in truth.items():
        for name, value in params.items():
            if name == "sls_k1":  # reported as E_e (physics.md section 1)
                continue
            est = estimates[sid][name]
            assert est.ci95[0] < value < est.ci95[1], (sid, name, est.value, est.ci95, value)
            seen += 1
        torsion = estimates[sid]["E_s_torsion"]  # k(nu) A E_t / J: the same E_s
        assert torsion.ci95[0] < params["E_s"] < torsion.ci95[1]
    assert seen == 12


def test_demo_study_values_are_the_ground_truth_within_their_stated_accuracy(demo):
    """Each value within 3 standard errors of the truth, except T2's E_s from nose travel,
    which the contact travel in the data biases low, and says so first."""
    result, truth = demo
    estimates = result.study_result.estimates()
    for sid, params in truth.items():
        for name, value in params.items():
            if name == "sls_k1":
                continue
            est = estimates[sid][name]
            if (sid, name) == ("T2", "E_s"):
                assert est.value < 0.7 * value and est.warnings[0].startswith("E_s is likely too low")
                continue
            assert abs(est.value - value) < 3 * est.stderr, (sid, name, est.value, est.stderr, value)
