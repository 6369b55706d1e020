"""matid against an independent reference (tests/rod/reference.py: strong form, shooting) on
3D scenes with the keys of contract section 9; the reference itself against closed forms."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from matid.rod.api import solve
from matid.rod.scenes import load_scene, scene_from_dict
from tests import ROOT
from tests.rod import reference

EXAMPLES = ROOT / "examples" / "scenes"
ROD = {
    "length": "30 mm",
    "E_b": "6.5e-5 N m^2",
    "E_t": "4.4e-5 N m^2",
    "E_s": "21 N",
    "E_e": "120 N",
    "outer_diameter": "2.4 mm",
}
INEXTENSIBLE = {"E_s": math.inf, "E_e": math.inf}
#: Scenes beyond the examples: a point force at mid-length, and every new key at once.
SCENES = {
    "point_force": {
        "rod": ROD,
        "point_load": [{"at": "15 mm", "force": ["0 N", "-4e-2 N", "0 N"]}],
        "tip": {"force": ["5e-3 N", "0 N", "0 N"]},
    },
    "everything": {
        "rod": ROD,
        "segment": [
            {"from": "0 mm", "to": "10 mm", "E_b": "1.2e-4 N m^2"},
            {"from": "22 mm", "to": "30 mm", "precurvature": ["20 1/m", "40 1/m", "5 1/m"]},
        ],
        "magnet": [{"at": "26 mm", "moment": "0.006 A m^2", "direction": [0, 1, 0]}],
        "magnetization": [{"from": "0 mm", "to": "30 mm", "per_length": "0.2 A", "direction": [1, 0, 1]}],
        "point_load": [
            {"at": "18 mm", "force": ["1e-3 N", "1e-3 N", "0 N"], "moment": ["0 N m", "0 N m", "2e-5 N m"]}
        ],
        "load": {"distributed_force": ["0 N/m", "-0.05 N/m", "0 N/m"]},
        "field": {"B": ["0 mT", "-15 mT", "15 mT"]},
    },
}


def _tip_angle(d3: np.ndarray) -> float:
    return math.atan2(d3[0], d3[2])


def test_reference_transverse_tip_magnet_is_the_closed_form() -> None:
    """theta = q sin(psi - theta) at psi = 90 deg (physics.md section 5), inextensible rod."""
    L, E_b, m, q = 0.03, 6.5e-5, 0.0125, 2.0
    scene = scene_from_dict(
        {"rod": ROD, "magnet": [{"at": L, "moment": m}], "field": {"B": [q * E_b / (m * L), 0, 0]}}
    )
    out = reference.solve(scene, base=INEXTENSIBLE)
    theta = brentq(lambda t: t - q * math.cos(t), 0.0, math.pi / 2)
    assert abs(_tip_angle(out["d3"]) - theta) < 1e-10
    assert abs(out["position"][1]) < 1e-14 and abs(out["d1"][1]) < 1e-12


def test_reference_point_force_is_beam_theory_with_shear() -> None:
    """A small force P at a: tip deflection P a^2 (3L - a)/(6 E_b) + P a/E_s (linear theory)."""
    L, a, E_b, E_s, P = 0.03, 0.015, 6.5e-5, 21.0, 1e-7
    scene = scene_from_dict({"rod": ROD, "point_load": [{"at": a, "force": [P, 0, 0]}]})
    out = reference.solve(scene, steps=1, base={"E_e": math.inf})
    expected = P * a**2 * (3 * L - a) / (6 * E_b) + P * a / E_s
    assert abs(out["position"][0] - expected) < 1e-6 * expected  # geometric nonlinearity ~(x/L)^2
    bending_only = P * a**2 * (3 * L - a) / (6 * E_b)
    assert abs(out["position"][0] - bending_only) > 1e-3 * expected  # the shear term is seen


def _designer_scenes() -> list:
    """A list, not a generator: a generator is used up by the first collection (tests/test_parametrize.py)."""
    examples = ("magnet_direction", "magnetization_direction", "curved_tip", "point_load")
    return [pytest.param(load_scene(EXAMPLES / f"{name}.toml"), id=name) for name in examples] + [
        pytest.param(dataclasses.replace(scene_from_dict(raw), tolerance=1e-8), id=name)
        for name, raw in SCENES.items()
    ]


@pytest.mark.parametrize("scene", _designer_scenes())
def test_matid_agrees_with_the_reference_in_3d(scene) -> None:
    """Tip position and directors within 1e-6 of L (measured: 2e-11 to 3e-10)."""
    sol = solve(scene)
    ref = reference.solve(scene)
    assert sol.model == "full"
    L = scene.rod.length
    assert np.max(np.abs(np.array(sol.tip["position"]) - ref["position"])) < 1e-6 * L
    for key in ("d1", "d3"):
        assert np.max(np.abs(np.array(sol.tip[key]) - ref[key])) < 1e-6
    assert np.max(np.abs(ref["d3"] - [0, 0, 1])) > 0.03  # a scene that moves the tip


def test_planar_designer_scene_runs_the_planar_model_and_agrees() -> None:
    """In-plane point load, an in-plane curved tip and a magnet along -d3 stay planar: the planar
    model, the full model and the reference agree (the -d3 magnet is the +d3 one in -B)."""
    raw = {
        "rod": ROD,
        "segment": [{"from": "20 mm", "to": "30 mm", "precurvature": ["0 1/m", "-30 1/m", "0 1/m"]}],
        "point_load": [{"at": "10 mm", "force": ["2e-3 N", "0 N", "-1e-3 N"], "moment": [0, "1e-4 N m", 0]}],
        "magnet": [{"at": "30 mm", "moment": "0.0125 A m^2", "direction": [0, 0, -1]}],
        "field": {"B": ["60 mT", "0 mT", "-20 mT"]},
        "tolerance": 1e-9,
    }
    scene = scene_from_dict(raw)
    planar, full = solve(scene), solve(scene, model="full")
    flipped = dict(
        raw, magnet=[{"at": "30 mm", "moment": "0.0125 A m^2"}], field={"B": ["-60 mT", "0 mT", "20 mT"]}
    )
    plus = solve(scene_from_dict(flipped))
    ref = reference.solve(scene)
    assert planar.model == "planar" and full.model == "full"
    L = scene.rod.length
    for sol in (planar, full, plus):
        assert np.max(np.abs(np.array(sol.tip["position"]) - ref["position"])) < 1e-6 * L
        assert np.max(np.abs(np.array(sol.tip["d3"]) - ref["d3"])) < 1e-6
    assert np.max(np.abs(ref["d3"] - [0, 0, 1])) > 0.1
