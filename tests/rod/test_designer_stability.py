"""Stable states only (contract section 9): with a dead tip moment the full model tests the
symmetrised tangent, so a saddle of the field's energy is never returned."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from matid.errors import ConvergenceError
from matid.rod.api import solve
from matid.rod.scenes import load_scene, scene_from_dict
from tests import ROOT

L, E_B, MOMENT, Q = 0.03, 6.5e-5, 0.0125, 5.8
PSI = math.radians(174.0)  # the field nearly antiparallel to the axis: the straight rod buckles


def _saddle_scene(twist: float) -> object:
    B = Q * E_B / (MOMENT * L)
    return scene_from_dict(
        {
            "rod": {"length": L, "E_b": E_B, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0},
            "magnet": [{"at": L, "moment": MOMENT}],
            "field": {"B": [B * math.sin(PSI), 0.0, B * math.cos(PSI)]},
            "tip": {"moment": [0.0, 0.0, twist]},
        }
    )


def test_a_tip_twist_no_longer_returns_the_saddle() -> None:
    """q = 5.8, field 174 deg off the axis, a 1e-6 N m twist: before, the full model skipped its
    stability test and returned the saddle with the tip at 7.3 deg; the stable state is the
    root of theta = q sin(psi - theta) near 147.5 deg (inextensible; shear moves it ~0.1 deg)."""
    sol = solve(_saddle_scene(1e-6))
    assert sol.model == "full"
    tilt = math.acos(np.clip(sol.tip["d3"][2], -1, 1))
    stable = brentq(lambda t: t - Q * math.sin(PSI - t), 2.0, PSI)
    saddle = -brentq(lambda t: t + Q * math.sin(PSI + t), 0.0, 0.5)
    assert abs(tilt - stable) < 0.01, math.degrees(tilt)
    assert abs(tilt - abs(saddle)) > 2.0


def test_the_twist_free_scene_reaches_the_same_state() -> None:
    """Without the twist the planar model runs (stability tested by Cholesky): the same tilt
    (the twist only turns the tip ~1e-3 about the axis)."""
    planar, full = solve(_saddle_scene(0.0)), solve(_saddle_scene(1e-6))
    assert planar.model == "planar"
    assert abs(planar.tip["d3"][2] - full.tip["d3"][2]) < 1e-5


def test_the_example_is_the_saddle_scene() -> None:
    """examples/scenes/tip_twist_stability.toml is the scene above: the same stable tip."""
    example = solve(load_scene(ROOT / "examples" / "scenes" / "tip_twist_stability.toml"))
    B = np.array(example.scene.loads.B)
    assert abs(np.linalg.norm(B) * MOMENT * L / E_B - Q) < 1e-12
    assert abs(math.atan2(B[0], B[2]) - PSI) < 1e-12
    tilt = math.acos(np.clip(example.tip["d3"][2], -1, 1))
    assert abs(tilt - brentq(lambda t: t - Q * math.sin(PSI - t), 2.0, PSI)) < 0.01


def _dead_moment_scene(factor: float):
    M = [c * factor * E_B / L for c in (1.0, 1.0, 0.5)]
    return scene_from_dict(
        {"rod": {"length": L, "E_b": E_B, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0}, "tip": {"moment": M}}
    )


def test_a_dead_3d_moment_with_positive_second_order_work_is_solved() -> None:
    """|M| = 1.5 E_b/L, twisting and bending: the symmetrised tangent is positive definite, the
    state agrees with the independent reference (tests/rod/reference.py)."""
    from tests.rod import reference

    scene = dataclasses.replace(_dead_moment_scene(1.0), tolerance=1e-8)
    sol, ref = solve(scene), reference.solve(scene, steps=16)
    assert np.max(np.abs(np.array(sol.tip["position"]) - ref["position"])) < 1e-6 * L
    assert np.max(np.abs(np.array(sol.tip["d3"]) - ref["d3"])) < 1e-6


def test_a_dead_3d_moment_beyond_positive_second_order_work_exits_naming_the_load_factor() -> None:
    """|M| = 3 E_b/L: stability is lost to the symmetrised test at load factor ~0.75; the error
    says so and names the load factor (stable states only, contract section 9)."""
    with pytest.raises(ConvergenceError, match=r"symmetrised tangent.*load factor 0\.75"):
        solve(_dead_moment_scene(2.0))
