"""``matid solve`` on the designer scenes (contract section 9): field, aim and warnings in
solution.json, warnings on the terminal, an unreachable aim exits 1 naming the closest direction."""

from __future__ import annotations

import json
import math

from tests import ROOT
from tests.app.test_solve_cli import run

EXAMPLES = ROOT / "examples" / "scenes"


def test_aim_writes_the_field_and_its_error(tmp_path) -> None:
    code, out, err = run(["solve", str(EXAMPLES / "aim.toml"), "--out", str(tmp_path)])
    assert code == 0, err
    doc = json.loads((tmp_path / "solution.json").read_text())
    B = doc["field"]["B"]
    assert abs(math.hypot(*B) - 0.16) < 1e-12
    assert doc["aim"]["tip_direction_error_rad"] < 1e-4 and doc["aim"]["forward_solves"] >= 1
    assert doc["warnings"] == []
    assert "aimed: B = (" in out


def test_an_unreachable_aim_exits_1_with_the_closest_direction(tmp_path) -> None:
    scene = tmp_path / "aim.toml"
    scene.write_text((EXAMPLES / "aim.toml").read_text().replace('"160 mT"', '"80 mT"'))
    code, _, err = run(["solve", str(scene), "--out", str(tmp_path / "out")])
    assert code == 1
    assert "closest direction reached is d3 = (0.4453" in err  # (sin q, 0, cos q), q = 0.4615
    assert not (tmp_path / "out" / "solution.json").exists()


def test_a_strain_warning_reaches_json_and_terminal(tmp_path) -> None:
    code, _, err = run(["solve", str(EXAMPLES / "soft_shear.toml"), "--out", str(tmp_path)])
    assert code == 0, err
    doc = json.loads((tmp_path / "solution.json").read_text())
    assert len(doc["warnings"]) >= 1 and "|nu - e3|" in doc["warnings"][0]
    assert "warning: strain outside the linear law's range" in err
    assert doc["field"] == {"B": [0.0, 0.0, 0.0]}


def test_the_saddle_scene_exits_0_at_the_stable_state(tmp_path) -> None:
    code, _, err = run(["solve", str(EXAMPLES / "tip_twist_stability.toml"), "--out", str(tmp_path)])
    assert code == 0, err
    d3 = json.loads((tmp_path / "solution.json").read_text())["tip"]["d3"]
    assert math.degrees(math.acos(d3[2])) > 140  # not the saddle at 7.3 deg
