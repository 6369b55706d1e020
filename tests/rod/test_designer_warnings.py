"""Strain-range warnings (contract section 9) and the raw variant's penalty error."""

from __future__ import annotations

import dataclasses

import numpy as np

from matid.rod.api import solve
from matid.rod.checks import LINEAR_RANGE
from matid.rod.output import shape_png, shape_title, solution_json
from matid.rod.scenes import load_scene, scene_from_dict
from tests import ROOT

EXAMPLES = ROOT / "examples" / "scenes"


def _shear_scene(E_s: float):
    return scene_from_dict(
        {
            "rod": {"length": 0.03, "E_b": 6.5e-5, "E_t": 4.4e-5, "E_s": E_s, "E_e": 120.0},
            "tip": {"force": [1e-3, 0.0, 0.0]},
            "elements": 8,
        }
    )


def test_a_huge_shear_strain_is_a_warning() -> None:
    """E_s = 1e-5 N under 1e-3 N: nu1 ~ 100 (tip far off); before, it passed silently."""
    sol = solve(_shear_scene(1e-5))
    warnings = solution_json(sol)["warnings"]
    assert any("|nu - e3|" in w for w in warnings), warnings
    assert "WARNING: strain outside" in shape_title(sol)
    assert shape_png(sol, dpi=30)[:4] == b"\x89PNG"
    quiet = solve(_shear_scene(21.0))  # the same scene with a real tube's E_s: no warning
    assert solution_json(quiet)["warnings"] == [] and "WARNING" not in shape_title(quiet)


def test_a_tight_bend_of_a_thick_tube_is_a_warning() -> None:
    """The curved tip (80 1/m) of a 2.4 mm tube: |kappa| R_o ~ 0.1 there, but kappa_ref is
    the reference: no warning; a straight rod bent as much is warned."""
    scene = load_scene(EXAMPLES / "curved_tip.toml")
    assert solve(scene).extra["warnings"] == []
    segments = tuple(dataclasses.replace(s, precurvature=None) for s in scene.rod.segments)
    M = 6.5e-5 * 2 * LINEAR_RANGE / 2.4e-3  # a tip moment giving |kappa| R_o = 2 x the range
    straight = dataclasses.replace(
        scene,
        rod=dataclasses.replace(scene.rod, segments=segments),
        loads=dataclasses.replace(scene.loads, tip_force=(0.0, 0.0, 0.0), tip_moment=(0.0, M, 0.0)),
    )
    warnings = solve(straight).extra["warnings"]
    assert any("kappa" in w for w in warnings), warnings


def test_the_raw_variant_estimate_includes_the_penalty_error() -> None:
    """The paper's raw variant: its estimate covers its true error (against the normalised
    variant on a fine mesh); before it left out the penalty (3.7e-6 true vs 1.1e-8)."""
    scene = load_scene(EXAMPLES / "precurved_3d.toml")
    raw = solve(scene, model="full", variant="raw")
    fine = solve(scene, model="full", elements=256)
    true = np.max(np.abs(np.array(raw.tip["position"]) - fine.tip["position"])) / scene.rod.length
    assert raw.discretization_error >= true
    assert raw.extra["error_estimate"]["penalty_error"] > 0
