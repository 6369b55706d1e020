"""What `matid solve` writes says its units and shows its loads (issue 22, docs/contract.md section 6)."""

from __future__ import annotations

import numbers

import numpy as np
import pytest

from matid.rod import load_scene, solve
from matid.rod.output import _lumen_view, shape_png, shape_title, solution_json
from tests import ROOT

EXAMPLES = ROOT / "examples" / "scenes"


def numeric_keys(doc: dict, prefix: str = "") -> set[str]:
    """Dotted keys of every number or list of numbers in the document (not the unit table)."""
    keys = set()
    for key, value in doc.items():
        name = f"{prefix}{key}"
        if key == "units" or isinstance(value, bool):
            continue
        if isinstance(value, dict):
            keys |= numeric_keys(value, name + ".")
        elif isinstance(value, numbers.Real) or (
            isinstance(value, list) and value and not isinstance(value[0], str)
        ):
            keys.add(name)
    return keys


COUNTS = {"elements", "newton_iterations", "load_steps", "aim.forward_solves"}  # counts: no unit
ERROR_ESTIMATE = "error_estimate."  # the estimate's own table: levels and orders, dimensionless


@pytest.mark.parametrize("name", ["point_load", "aim", "three_point_bend", "magnet_direction"])
def test_every_number_of_solution_json_has_its_unit(name):
    doc = solution_json(solve(load_scene(EXAMPLES / f"{name}.toml")))
    missing = {k for k in numeric_keys(doc) - COUNTS if not k.startswith(ERROR_ESTIMATE)} - set(doc["units"])
    assert not missing, missing
    assert doc["units"]["position"] == "m" and doc["units"]["field.B"] == "T"


def test_the_picture_names_the_scene_and_its_field_and_draws_the_loads():
    sol = solve(load_scene(EXAMPLES / "point_load.toml"))
    title = shape_title(sol, "point_load")
    assert title.startswith("point_load: cantilever") and "|B| = 5 mT" in title
    assert shape_png(sol, dpi=30, name="point_load")[:4] == b"\x89PNG"


def test_lumen_walls_are_drawn_a_radius_from_the_centreline_around_a_bend():
    """shape.png's lumen outline (examples/scenes/advance_lumen.toml, a 90 degree bend): every drawn
    wall point is the radius from the centreline (once drawn as the centreline shifted along x, the
    walls closed up where the vessel turns)."""
    scene = load_scene(ROOT / "examples" / "scenes" / "advance_lumen.toml")
    line, radius = scene.lumen.line(), scene.lumen.radius
    pieces = _lumen_view(scene.lumen, 0, scene.rod.length)
    assert len(pieces) == 3
    for _, walls in pieces:
        for w in walls:
            r = np.column_stack([w[:, 1], 0 * w[:, 0], w[:, 0]]) / 1e3  # (x, y, z) in m
            c, _ = line.closest(r)
            assert np.allclose(np.linalg.norm(r - c, axis=1), radius, rtol=1e-3)
