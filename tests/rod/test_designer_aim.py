"""[aim] (contract section 9): the field direction that turns the tip to a target."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from matid.errors import ConvergenceError
from matid.rod.aim import aim, angle
from matid.rod.api import solve
from matid.rod.scenes import Aim, load_scene
from tests import ROOT

EXAMPLES = ROOT / "examples" / "scenes"


def _forward(scene, B):
    """A plain forward solve of the scene in the field B (no [aim])."""
    return solve(dataclasses.replace(scene, aim=None, loads=dataclasses.replace(scene.loads, B=tuple(B))))


def test_aim_example_is_the_planar_closed_form() -> None:
    """psi = theta + asin(theta / q) for a tip magnet (a pure end couple: exact for any E_s, E_e)."""
    scene = load_scene(EXAMPLES / "aim.toml")
    sol = solve(scene)
    rod, (_, m) = scene.rod, scene.loads.magnets[0]
    q = m * scene.aim.field_magnitude * rod.length / rod.E_b
    theta = math.atan2(scene.aim.tip_direction[0], scene.aim.tip_direction[2])
    B = np.array(sol.scene.loads.B)
    assert abs(np.linalg.norm(B) - scene.aim.field_magnitude) < 1e-12
    assert abs(math.atan2(B[0], B[2]) - (theta + math.asin(theta / q))) < 1e-7
    assert sol.extra["aim"]["tip_direction_error_rad"] < 1e-8
    forward = _forward(scene, B)  # the field returned, put into a forward solve
    assert angle(forward.tip["d3"], scene.aim.tip_direction) < 1e-4


@pytest.mark.parametrize("name", ["point_load", "curved_tip", "magnet_direction"])
def test_aim_in_3d_reaches_the_target_in_a_forward_solve(name: str) -> None:
    """A 3D target on 3D scenes, reachable by construction (the tip in a field B0 that aim is not
    told); the field found, solved forward, points the tip there."""
    scene = load_scene(EXAMPLES / f"{name}.toml")
    if not scene.loads.magnets:
        scene = dataclasses.replace(
            scene, loads=dataclasses.replace(scene.loads, magnets=((scene.rod.length, 0.0125),))
        )
    B0 = 0.15 * np.array([-0.5, -0.6, 0.4]) / np.linalg.norm([-0.5, -0.6, 0.4])
    target = np.array(_forward(scene, B0).tip["d3"])
    assert angle(target, [0, 0, 1]) > 0.2  # a target off the unloaded tip's direction
    scene = dataclasses.replace(scene, aim=Aim(tuple(target), 0.15))
    found = aim(scene)
    assert found.error_rad < 1e-8
    assert abs(np.linalg.norm(found.B) - 0.15) < 1e-12
    forward = _forward(scene, found.B)
    assert angle(forward.tip["d3"], target) < 1e-4


def test_an_unreachable_aim_names_the_closest_direction() -> None:
    """|B| = 80 mT: q = 0.46 < 30 deg, the tip turns at most q rad (field at q + 90 deg)."""
    scene = load_scene(EXAMPLES / "aim.toml")
    scene = dataclasses.replace(scene, aim=Aim(scene.aim.tip_direction, 0.08))
    q = 0.0125 * 0.08 * scene.rod.length / scene.rod.E_b
    with pytest.raises(ConvergenceError, match="closest direction reached") as info:
        solve(scene)
    closest = info.value.info["closest"]
    assert angle(closest.tip_direction, [math.sin(q), 0.0, math.cos(q)]) < 1e-6
    assert closest.error_rad > 0.05
