"""Scenes in, solutions out: loading and validation, model choice, the bend's whole tube, the outputs."""

import re
from pathlib import Path

import numpy as np
import pytest

from matid.errors import DataError
from matid.rod import load_scene, solve
from matid.rod.api import resolve_model
from matid.rod.output import shape_png, solution_json
from matid.rod.scenes import scene_from_dict
from tests import ROOT

EXAMPLES = ROOT / "examples" / "scenes"
ROD = """
[rod]
length = "30 mm"
E_b = "6.5e-5 N m^2"
E_t = "4.4e-5 N m^2"
E_s = "21 N"
E_e = "120 N"
outer_diameter = "2.4 mm"
"""
BEND = """
[three_point_bend]
span = "10 mm"
support_radius = "2 mm"
nose_radius = "2 mm"
deflection = ["0.1 mm", "0.5 mm", "1 mm"]
"""
CONTRACT_KEYS = {
    "scene",
    "converged",
    "model",
    "elements",
    "newton_iterations",
    "runtime_s",
    "s",
    "position",
    "d1",
    "d3",
    "tip",
}


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(text, encoding="utf-8")
    return path


# -- bad input: a DataError naming the file and the key ------------------------------


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('scene = "cantilever"\n[tip]\nforce = ["1 N", "0 N", "0 N"]\n', r"missing \[rod\]"),
        (ROD.replace('"21 N"', '"21 parsec"'), r"rod\.E_s: 'parsec' is not a unit of force"),
        (ROD + '[[magnet]]\nat = "31 mm"\nmoment = "0.01 A m^2"\n', r"\[\[magnet\]\] at 0\.031 m is not on"),
        (
            'scene = "three_point_bend"\n'
            + ROD
            + BEND.replace('deflection = ["0.1 mm", "0.5 mm", "1 mm"]', ""),
            r"three_point_bend\.deflection",
        ),
        (ROD.replace('"6.5e-5 N m^2"', '"-6.5e-5 N m^2"'), r"rod.E_b: must be in \[1e-15"),
        ('scene = "three_point_bend"\n' + ROD, r"needs a \[three_point_bend\] table"),
        ("[rod\nlength = 1", "not valid TOML"),
    ],
)
def test_malformed_scene_is_a_data_error_naming_the_file(tmp_path, text, match):
    path = write(tmp_path, text)
    with pytest.raises(DataError, match=match) as info:
        load_scene(path)
    assert info.value.file == str(path) and str(path) in str(info.value)


def test_missing_scene_file_is_a_data_error(tmp_path):
    with pytest.raises(DataError, match="not found"):
        load_scene(tmp_path / "nope.toml")


@pytest.mark.parametrize(
    ("table", "name"),
    [
        ('[field]\nB = ["10 mT", "0 mT", "0 mT"]\n', "[field]"),
        ('[[point_load]]\nat = "10 mm"\nforce = ["0 N", "0 N", "-1e-3 N"]\n', "[[point_load]]"),
    ],
)
def test_bend_scene_with_loads_it_cannot_model_is_refused(tmp_path, table, name):
    """The bend half model has no field and no point loads: a scene giving them is refused, not solved
    without them (a point load was silently left out before)."""
    scene = load_scene(write(tmp_path, 'scene = "three_point_bend"\n' + ROD + BEND + table))
    with pytest.raises(DataError, match=re.escape(name) + " not supported"):
        solve(scene)


def test_model_option_is_checked_against_the_scene(tmp_path):
    planar = load_scene(write(tmp_path, ROD + '[tip]\nforce = ["0.01 N", "0 N", "0 N"]\n'))
    twisted = scene_from_dict(
        {
            "rod": {"length": 0.03, "E_b": 6.5e-5, "E_t": 4.4e-5, "E_s": 21, "E_e": 120},
            "tip": {"moment": [0.0, 0.0, 1e-4]},
        }
    )
    assert resolve_model(planar) == "planar" and resolve_model(planar, "full") == "full"
    assert resolve_model(twisted) == "full"
    with pytest.raises(ValueError, match="not planar"):
        resolve_model(twisted, "planar")
    with pytest.raises(ValueError, match="model must be one of"):
        resolve_model(planar, "shell")
    with pytest.raises(ValueError, match="planar half model only"):
        resolve_model(load_scene(write(tmp_path, 'scene = "three_point_bend"\n' + ROD + BEND)), "full")


# -- model choice ----------------------------------------------------------------------


def test_field_out_of_the_plane_of_a_tip_force_runs_the_full_model():
    rod = {"length": 0.03, "E_b": 6.5e-5, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0}
    loads = {"rod": rod, "tip": {"force": [0.01, 0, 0]}, "magnet": [{"at": 0.03, "moment": 0.01}]}
    in_plane = scene_from_dict({**loads, "field": {"B": [0.0, 0.0, 0.02]}})
    out_of_plane = scene_from_dict({**loads, "field": {"B": [0.0, 0.02, 0.0]}})
    assert solve(in_plane, elements=8).model == "planar"
    sol = solve(out_of_plane, elements=8)
    assert sol.model == "full" and sol.converged
    assert sol.position[-1][0] > 1e-3 and sol.position[-1][1] > 1e-3  # pushed along x, turned towards y


def test_planar_scene_in_a_tilted_plane_comes_back_in_the_lab_frame():
    """A tip force along (1, 1, 0)/sqrt 2: planar in that plane, the same tip as the full model."""
    rod = {"length": 0.03, "E_b": 6.5e-5, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0}
    scene = scene_from_dict({"rod": rod, "tip": {"force": [0.05, 0.05, 0.0]}})
    planar, full = solve(scene, elements=16), solve(scene, elements=16, model="full")
    assert planar.model == "planar"
    assert planar.position[-1][0] == pytest.approx(planar.position[-1][1], rel=1e-12)
    assert np.max(np.abs(planar.position - full.position)) < 1e-7 * 0.03
    assert np.max(np.abs(planar.d1 - full.d1)) < 1e-6


# -- the three-point bend as a whole tube ----------------------------------------------


def test_bend_solution_is_the_whole_tube_in_the_lab_frame(tmp_path):
    scene = load_scene(write(tmp_path, 'scene = "three_point_bend"\n' + ROD + BEND))
    sol = solve(scene)
    L, d = 0.03, 1e-3
    assert sol.model == "planar" and sol.terms[-1] == "contact"
    assert sol.s[0] == 0 and sol.s[-1] == pytest.approx(L) and np.all(np.diff(sol.s) > 0)
    mid = np.argmin(np.abs(sol.s - L / 2))
    assert sol.position[mid] == pytest.approx([-d, 0.0, L / 2], abs=1e-12)  # the nose pushes down (-x)
    # mirror symmetric about mid-span: x(s) = x(L - s), z(s) = L - z(L - s)
    assert sol.position[:, 0] == pytest.approx(sol.position[::-1, 0], abs=1e-15)
    assert sol.position[:, 2] == pytest.approx(L - sol.position[::-1, 2], abs=1e-15)
    # shear angle (t x d3).e2: F / (2 E_s) between support and nose, none on the unloaded overhangs
    table = sol.three_point_bend
    tangent = np.gradient(sol.position, sol.s, axis=0)
    shear = np.cross(tangent / np.linalg.norm(tangent, axis=1)[:, None], sol.d3)[:, 1]
    overhang = np.abs(sol.s - L / 2) > table["support_contact_s"][-1] + 1e-3
    between = np.abs(np.abs(sol.s - L / 2) - 2.5e-3) < 1e-3
    assert np.max(np.abs(shear[overhang])) < 1e-9
    assert np.abs(shear[between]) == pytest.approx(table["force"][-1] / (2 * 21.0), rel=0.03)
    assert np.all(sol.d3[:, 2] > 0) and np.max(np.abs(np.sum(sol.d1 * sol.d3, axis=1))) < 1e-14
    assert table["deflection"] == pytest.approx([1e-4, 5e-4, 1e-3])
    assert np.all(np.diff(table["force"]) > 0) and len(table["support_contact_s"]) == 3


def test_decreasing_deflections_are_refused(tmp_path):
    scene = load_scene(
        write(
            tmp_path,
            'scene = "three_point_bend"\n'
            + ROD
            + BEND.replace('"0.1 mm", "0.5 mm", "1 mm"', '"1 mm", "0.5 mm"'),
        )
    )
    with pytest.raises(DataError, match="increasing order"):
        solve(scene)


# -- outputs ---------------------------------------------------------------------------


def test_solution_json_has_the_contract_keys(tmp_path):
    sol = solve(load_scene(write(tmp_path, ROD + '[tip]\nforce = ["0.01 N", "0 N", "0 N"]\n')), elements=4)
    doc = solution_json(sol)
    assert CONTRACT_KEYS <= set(doc) and {"element", "load_steps", "terms"} <= set(doc)
    assert "three_point_bend" not in doc
    assert doc["converged"] is True and doc["model"] == "planar" and doc["elements"] == 4
    assert len(doc["s"]) == len(doc["position"]) == len(doc["d1"]) == len(doc["d3"]) == 9  # P2: 2n + 1
    assert doc["tip"]["position"] == doc["position"][-1] and doc["position"][0] == [0.0, 0.0, 0.0]
    assert doc["d1"][0] == [1.0, 0.0, 0.0] and doc["d3"][0] == [0.0, 0.0, 1.0]  # the clamp
    assert "bending" in doc["terms"]
    assert shape_png(sol)[:8] == b"\x89PNG\r\n\x1a\n"


# -- the shipped example scenes --------------------------------------------------------


def test_example_magnetic_cantilever_is_the_benchmark():
    sol = solve(load_scene(EXAMPLES / "magnetic_cantilever.toml"))
    x, _, z = sol.position[-1] / 0.03
    assert sol.model == "planar" and sol.elements == 20
    assert (round(x, 5), round(z, 5)) == (0.83419, 0.29063)
    assert np.degrees(np.arctan2(sol.d3[-1][0], sol.d3[-1][2])) == pytest.approx(98.636, abs=5e-4)


# Every example scene against an independent reference: tests/test_examples.py (it replaces the
# check that three of them converged with finite values and |d3| = 1).


def test_an_unloaded_scene_beside_an_oblique_wall_has_a_finite_plane():
    """With no load the scale of plane_of is 1e-300: its wall direction (0.6, 0.8) times it
    underflowed np.linalg.norm to 0, and the plane was NaN (the pulling-reaction check's scene)."""
    from matid.rod.scenes import plane_of

    scene = scene_from_dict({
        "rod": {"length": 0.03, "E_b": 6.5e-5, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0, "outer_diameter": 1e-3},
        "wall": [{"point": [0.006, 0.008, 0.0], "normal": [-0.6, -0.8, 0.0]}],
    })  # fmt: skip
    assert plane_of(scene) == pytest.approx((-0.6, -0.8, 0.0), rel=1e-15)  # along the normal
