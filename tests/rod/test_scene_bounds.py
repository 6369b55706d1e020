"""Issue 30: every scene number bounded, every range inside the rod, stiffness files inside the scene's
folder, entry counts limited, element counts the model can use, bend geometry checked. Each test
failed on 04689c2 (a scene solved, silently changed, or crashed) and is a DataError (exit 2) now."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from matid.app.cli import main
from matid.errors import DataError
from matid.rod.scenes import load_scene
from tests.rod.test_scenes import ROD  # the same uniform tube

BEND = """
[three_point_bend]
span = "10 mm"
support_radius = "2 mm"
nose_radius = "2 mm"
deflection = ["0.1 mm", "0.5 mm"]
"""


def scene(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def refused(tmp_path: Path, text: str, *words: str) -> str:
    with pytest.raises(DataError) as caught:
        load_scene(scene(tmp_path, text))
    message = str(caught.value)
    for word in words:
        assert word in message, message
    return message


@pytest.mark.parametrize(
    "text, key",
    [
        ('[load]\ndistributed_force = ["1e300 N/m", "0 N/m", "0 N/m"]', "distributed_force"),
        ('[field]\nB = [1e308, 1e308, 0]\n[[magnet]]\nat = "30 mm"\nmoment = "0.01 A m^2"', "B"),
        ('[tip]\nforce = ["1e200 N", "0 N", "0 N"]', "force"),
        ('[[magnet]]\nat = "30 mm"\nmoment = "1e300 A m^2"', "moment"),
        ('[[point_load]]\nat = "10 mm"\nmoment = ["1e160 N m", "0 N m", "0 N m"]', "moment"),
    ],
)
def test_a_load_too_large_for_the_solver_is_refused(tmp_path, text, key):
    refused(tmp_path, ROD + text, key)


@pytest.mark.parametrize(
    "old, new, key",
    [
        ('length = "30 mm"', 'length = "1e300 m"', "length"),
        ('outer_diameter = "2.4 mm"', 'outer_diameter = "-2.4 mm"', "outer_diameter"),
        ('outer_diameter = "2.4 mm"', 'outer_diameter = "0 mm"', "outer_diameter"),
        ('E_b = "6.5e-5 N m^2"', "E_b = 1e-300", "E_b"),
        ('E_s = "21 N"', "E_s = 1e300", "E_s"),
    ],
)
def test_a_rod_size_or_stiffness_out_of_bounds_is_refused(tmp_path, old, new, key):
    refused(tmp_path, ROD.replace(old, new), key)


@pytest.mark.parametrize("far", ['"1e300 mm"', '"101 m"', "1e10"])
def test_a_lumen_centreline_point_too_far_for_its_gaps_is_refused(tmp_path, far):
    """The scene fuzz (wall_tip.toml with a lumen from z = -1e300 to 1e300 mm and [advance]) ran past
    300 s: the gaps to a segment 2e297 m long carry a round-off of ~1e281 m. Lumen points are bounded
    as wall points are (100 m per component)."""
    line = f'[["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", {far}]]'
    lumen = f'[lumen]\ncentreline = {line}\nradius = "3 mm"\n'
    refused(tmp_path, ROD + lumen, "[lumen].centreline", "100 m")


def test_a_tiny_span_is_refused_not_a_crash(tmp_path, capsys):
    path = scene(tmp_path, 'scene = "three_point_bend"\n' + ROD + BEND.replace('span = "10 mm"', 'span = "1e-300 m"'))
    assert main(["solve", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    assert "span" in capsys.readouterr().err


@pytest.mark.parametrize(
    "range_, what",
    [
        ('from = "40 mm"\nto = "50 mm"', "off the rod"),
        ('from = "20 mm"\nto = "10 mm"', "from > to"),
        ('from = "20 mm"\nto = "40 mm"', "partly off"),
    ],
)
def test_a_magnetisation_range_not_inside_the_rod_is_refused(tmp_path, range_, what):
    refused(tmp_path, ROD + f'[[magnetization]]\n{range_}\nper_length = "0.4 A"\n', "magnetization")


def test_overlapping_segments_are_refused(tmp_path):
    segments = '[[segment]]\nfrom = "0 mm"\nto = "20 mm"\nE_b = "1e-4 N m^2"\n'
    segments += '[[segment]]\nfrom = "10 mm"\nto = "30 mm"\nE_b = "2e-4 N m^2"\n'
    refused(tmp_path, ROD + segments, "overlap")


def test_segments_that_touch_are_fine(tmp_path):
    segments = '[[segment]]\nfrom = "0 mm"\nto = "20 mm"\nE_b = "1e-4 N m^2"\n'
    segments += '[[segment]]\nfrom = "20 mm"\nto = "30 mm"\nE_b = "2e-4 N m^2"\n'
    assert len(load_scene(scene(tmp_path, ROD + segments)).rod.segments) == 2


def stiffness_json(folder: Path) -> Path:
    doc = {"unit_system": "SI", "specimens": {"T1": {k: {"value": v} for k, v in
           {"E_b": 9.9e-5, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0}.items()}}}  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "stiffness.json"
    path.write_text(json.dumps(doc))
    return path


def test_a_stiffness_file_outside_the_scene_folder_is_refused_unless_allowed(tmp_path):
    outside = stiffness_json(tmp_path / "elsewhere")
    folder = tmp_path / "scenes"
    folder.mkdir()
    text = f'[rod]\nlength = "30 mm"\nstiffness = {{ from = "{outside}", specimen = "T1" }}\n'
    refused(folder, text, "allow_outside")
    relative = text.replace(str(outside), "../elsewhere/stiffness.json")
    refused(folder, relative, "allow_outside")
    (folder / "link.json").symlink_to(outside)
    refused(folder, text.replace(str(outside), "link.json"), "allow_outside")
    allowed = text.replace("specimen = ", "allow_outside = true, specimen = ")
    assert load_scene(scene(folder, allowed)).rod.E_b == pytest.approx(9.9e-5)


def test_a_stiffness_file_clashing_with_an_explicit_value_is_refused(tmp_path):
    stiffness_json(tmp_path)
    text = '[rod]\nlength = "30 mm"\nE_b = "6.5e-5 N m^2"\nstiffness = { from = "stiffness.json", specimen = "T1" }\n'
    refused(tmp_path, text, "E_b")


def test_too_many_point_loads_are_refused_quickly(tmp_path):
    loads = '[[point_load]]\nat = "10 mm"\nforce = [0, 0, 1e-6]\n' * 16000
    clock = time.perf_counter()
    refused(tmp_path, ROD + loads, "point_load", "at most")
    assert time.perf_counter() - clock < 10


@pytest.mark.parametrize("elements", ["1", "2", "3"])
def test_a_full_model_scene_solves_on_a_mesh_narrower_than_the_band(tmp_path, elements):
    """04689c2: `--elements 3` on a full-model scene was exit 3 (band.tocsr: offset out of bounds, in the
    stability test of a dead moment): the full model can use any element count from 1. The moment
    acts at the tip: an interior point would add a mesh vertex there (rod.fem.graded_vertices)."""
    text = ROD + '[[point_load]]\nat = "30 mm"\nmoment = ["8e-4 N m", "0 N m", "4e-4 N m"]\n'
    path = scene(tmp_path, text)
    assert main(["solve", str(path), "--out", str(tmp_path / "out"), "--quiet", "--elements", elements]) == 0
    doc = json.loads((tmp_path / "out" / "solution.json").read_text())
    assert doc["model"] == "full" and doc["elements"] == int(elements)


@pytest.mark.parametrize(
    "old, new, key",
    [
        ('nose_radius = "2 mm"', 'nose_radius = "1e300 m"', "nose_radius"),
        ('support_radius = "2 mm"', 'support_radius = "1 m"', "support_radius"),
        ('support_radius = "2 mm"', 'support_radius = "5 mm"', "support_radius"),
    ],
)
def test_bend_radii_too_large_for_the_span_are_refused(tmp_path, old, new, key):
    refused(tmp_path, 'scene = "three_point_bend"\n' + ROD + BEND.replace(old, new), key)


def test_a_small_twist_beside_a_field_with_no_magnet_stays_in_the_energy(tmp_path):
    """Found by the solver fuzz: the planar test compared a moment (N m) with a field (T) in SI, so a
    twist 1e-12 times smaller than |B| in those units was dropped (planar model, no twist), though no
    magnet makes the field a load at all. Compared in scaled units, the twist is the only load."""
    T = 1e-13  # N m: twist angle T L / E_t = 6.8e-11 rad, far above round-off in d1
    text = ROD + f'[field]\nB = ["1 T", "0 T", "0 T"]\n[tip]\nmoment = [0, 0, {T}]\n'
    from matid.rod.api import solve

    sol = solve(load_scene(scene(tmp_path, text)), elements=4)
    assert sol.model == "full"
    d1 = sol.d1[-1]
    assert np.arctan2(d1[1], d1[0]) == pytest.approx(T * 0.03 / 4.4e-5, rel=1e-6)


@pytest.mark.parametrize("value", ["[1e300, 1e300, 0]", "[1e-320, 0, 1e-320]"])
def test_a_direction_of_huge_or_tiny_numbers_is_that_direction(tmp_path, value):
    """Found by the solver fuzz: the norm of [1e300, 1e300, 0] overflowed and the direction was refused
    as 'not finite'; a subnormal one underflowed to 'zero'."""
    text = ROD + f'[[magnet]]\nat = "30 mm"\nmoment = "0.01 A m^2"\ndirection = {value}\n'
    a = load_scene(scene(tmp_path, text)).loads.magnet_directions[0]
    expected = (1.0, 1.0, 0.0) if "300" in value else (1.0, 0.0, 1.0)
    assert np.allclose(a, np.array(expected) / np.sqrt(2), rtol=0, atol=1e-15)


def test_an_aim_in_a_vanishing_field_reports_a_finite_closest_field():
    """Found by the solver fuzz: |B| = 1.6e-301 T made the closest field B/|B| = nan (|B|^2 underflows)."""
    import dataclasses

    from matid.errors import ConvergenceError
    from matid.rod.aim import aim
    from matid.rod.scenes import Aim
    from tests import ROOT

    scene = load_scene(ROOT / "examples" / "scenes" / "aim.toml")
    with pytest.raises(ConvergenceError) as caught:
        aim(dataclasses.replace(scene, aim=Aim((0.5, 0.0, 0.8660254037844386), 1.6e-301)), seconds=5)
    closest = caught.value.info["closest"]
    assert np.isfinite(closest.B).all() and np.linalg.norm(closest.B / 1.6e-301) == pytest.approx(1.0)
