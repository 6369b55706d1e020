"""Scene files are validated at the edge: each bad input is a DataError (exit 2) naming file and key."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from matid.app.cli import main
from matid.errors import DataError
from matid.rod.scene_values import MAX_FILE_BYTES
from matid.rod.scenes import MAX_SCENE_ELEMENTS, load_scene

ROD = """
[rod]
length = "30 mm"
E_b = "6.5e-5 N m^2"
E_t = "4.4e-5 N m^2"
E_s = "21 N"
E_e = "120 N"
"""


def scene(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def stiffness_scene(tmp_path: Path, ref: str) -> Path:
    return scene(tmp_path, f'[rod]\nlength = "30 mm"\nstiffness = {ref}\n')


def good_json(tmp_path: Path) -> Path:
    doc = {"unit_system": "SI", "specimens": {"T1": {k: {"value": v} for k, v in
           {"E_b": 6.5e-5, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0}.items()}}}  # fmt: skip
    path = tmp_path / "stiffness.json"
    path.write_text(json.dumps(doc))
    return path


def test_stiffness_from_a_matid_table_is_read(tmp_path):
    good_json(tmp_path)
    rod = load_scene(stiffness_scene(tmp_path, '{ from = "stiffness.json", specimen = "T1" }')).rod
    assert (rod.E_b, rod.E_t, rod.E_s, rod.E_e) == (6.5e-5, 4.4e-5, 21.0, 120.0)


@pytest.mark.parametrize(
    ("ref", "content", "message", "names"),
    [
        ('{ from = "nope.json", specimen = "T1" }', None, "stiffness file not found", "nope.json"),
        ('{ from = "nope.json" }', None, "rod.stiffness.specimen: expected a non-empty string", "scene.toml"),
        ('{ from = "sub", specimen = "T1" }', None, "is a folder, not a file", "sub"),
        ('{ from = "/dev/zero", specimen = "T1", allow_outside = true }', None, "not a regular file", "/dev/zero"),
        ('{ from = "s.json", specimen = "T1" }', "{", "not valid JSON", "s.json"),
        ('{ from = "s.json", specimen = "T1" }', "[]", "no 'specimens' table", "s.json"),
        ('{ from = "s.json", specimen = "T1" }', "\xff\xfe", "not UTF-8 text", "s.json"),
        ('{ from = "s.json", specimen = "T9" }', '{"specimens": {"T1": {}}}', "no specimen 'T9'", "s.json"),
        ('{ from = "s.json", specimen = "T1" }', '{"specimens": {"T1": {"E_b": {"value": "x"}}}}',
         "E_b.value: expected a finite number", "s.json"),
        ('{ from = "s.json", specimen = "T1" }', '{"unit_system": "cgs", "specimens": {}}',
         "--units SI", "s.json"),
        ('"s.json"', None, "rod.stiffness: expected a table", "scene.toml"),
        ('{ from = "s.json", specimen = "T1", x = 1 }', None, "unknown key 'x'", "scene.toml"),
    ],
)  # fmt: skip
def test_a_bad_stiffness_reference_is_a_data_error_naming_the_file(tmp_path, ref, content, message, names):
    (tmp_path / "sub").mkdir()
    if content is not None:
        (tmp_path / "s.json").write_text(content, encoding="latin-1")
    with pytest.raises(DataError, match=message) as info:
        load_scene(stiffness_scene(tmp_path, ref))
    assert names in str(info.value)


def test_a_huge_stiffness_file_is_refused_unread(tmp_path):
    with open(tmp_path / "s.json", "wb") as handle:
        handle.truncate(MAX_FILE_BYTES + 1)  # sparse: no memory, no time
    with pytest.raises(DataError, match="more than"):
        load_scene(stiffness_scene(tmp_path, '{ from = "s.json", specimen = "T1" }'))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (f"elements = 100000000\n{ROD}", f"elements must be between 1 and {MAX_SCENE_ELEMENTS}"),
        (f"elements = 0\n{ROD}", "elements must be between"),
        (f"tolerance = 1e-300\n{ROD}", "tolerance must be in"),
        (f'tolerance = "small"\n{ROD}', "tolerance must be a number"),
        (ROD.replace('E_s = "21 N"\n', ""), "rod: missing 'E_s'$"),
        (f'{ROD}\n[[segment]]\nfrom = "0 mm"\nto = "1 mm"\nrigid = "false"\n',
         "rigid: expected true or false"),
        (f"segment = 3\n{ROD}", r"\[\[segment\]\]: expected an array of tables"),
        (f"magnet = [1]\n{ROD}", r"\[\[magnet\]\] #1: expected a table"),
        (f"tip = 3\n{ROD}", r"\[tip\]: expected a table"),
        ("rod = 5\n", r"\[rod\]: expected a table"),
        (ROD + "E_S = 1\n", r"\[rod\]: unknown key 'E_S'"),
        (ROD + '[tip]\nforse = ["1 N", "0 N", "0 N"]\n', r"\[tip\]: unknown key 'forse'"),
        (ROD + '[[magnet]]\nat = "30 mm"\nmoment = "1 A m^2"\nx = 1\n',
         r"\[\[magnet\]\] #1: unknown key 'x'"),
        ('scene = "three_point_bend"\n' + ROD + '[three_point_bend]\nspan = "10 mm"\n'
         'support_radius = "2 mm"\nnose_radius = "2 mm"\n'
         'deflection = ' + str(["0.1 mm"] * 1001) + "\n", "at most 1000"),
        # the fuzz (2026-11-28): a wall without its point was a KeyError, exit 3
        (ROD + "[[wall]]\nnormal = [-1, 0, 0]\n", r"\[\[wall\]\] #1: missing 'point'"),
    ],
)  # fmt: skip
def test_a_bad_scene_value_is_a_data_error_naming_the_key(tmp_path, text, message):
    path = scene(tmp_path, text)
    with pytest.raises(DataError, match=message) as info:
        load_scene(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("target", ["/dev/zero", "folder", "missing.toml"])
def test_a_scene_path_that_is_not_a_small_regular_file_exits_2(tmp_path, capsys, target):
    (tmp_path / "folder").mkdir()
    path = target if target.startswith("/") else str(tmp_path / target)
    assert main(["solve", path, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert path in err and "internal error" not in err


def test_too_many_elements_on_the_command_line_exit_2_before_solving(tmp_path, capsys):
    path = scene(tmp_path, ROD + '\n[tip]\nforce = ["0.1 N", "0 N", "0 N"]\n')
    assert main(["solve", str(path), "--elements", "100000000", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "elements: at most" in err and str(path) in err
