"""[[sweep]]: parsing, the product of states, matid.rod.sweep and `matid solve` of a sweep."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import matid.rod as R
from matid.bench import scenes as S
from matid.errors import DataError
from matid.rod.sweeps import Axis, parse_sweep, states

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "sweeps" / "magnetic_workspace.toml"


def test_values_from_to_count_and_units():
    axes = parse_sweep(
        [
            {"key": "field.B", "values": [["10 mT", 0, 0], [0, 0, "0.02 T"]]},
            {"key": "rod.E_b", "from": "5e-5 N m^2", "to": "9e-5 N m^2", "count": 5},
            {"key": "magnetization.1.per_length", "values": ["2 A"]},
        ]
    )
    assert axes[0].values == ((0.01, 0.0, 0.0), (0.0, 0.0, 0.02))
    assert np.allclose(axes[1].values, [5e-5, 6e-5, 7e-5, 8e-5, 9e-5])
    assert axes[2].kind == "moment_per_length"


@pytest.mark.parametrize(
    "entry, message",
    [
        ({"key": "rod.colour", "values": [1]}, "not a sweepable key"),
        ({"key": "field.B", "from": 0, "to": 1, "count": 2}, "is a vector"),
        ({"key": "rod.E_b", "values": [1], "count": 2}, "not both"),
        ({"key": "rod.E_b", "from": 1, "to": 2, "count": 0}, "count"),
        ({"key": "rod.E_b", "values": ["3 furlong"]}, "sweep"),
    ],
)
def test_bad_entries_refused(entry, message):
    with pytest.raises(DataError, match=message):
        parse_sweep([entry])


def test_every_combination_last_fastest_and_bad_states_kept():
    scene = S.magnetic(2.0, 90.0)
    axes = parse_sweep({"rod.E_b": [1e-4, -1.0], "magnetization.1.per_length": [1.0, 2.0, 3.0]})
    made = states(scene, axes)
    assert [c for c, _ in made][:4] == [(1e-4, 1.0), (1e-4, 2.0), (1e-4, 3.0), (-1.0, 1.0)]
    assert made[2][1].rod.E_b == 1e-4 and made[2][1].loads.magnetization[0][2] == 3.0
    assert all(isinstance(s, DataError) for _, s in made[3:])  # E_b = -1: refused by the scene


def test_sweep_dataframe_matches_solve():
    scene = S.magnetic(4.0, 120.0)
    B = [list(scene.loads.B), [0.0, 0.0, -1.0 * np.linalg.norm(scene.loads.B) * 4]]
    df = R.sweep(scene, {"field.B": B, "rod.E_b": [scene.rod.E_b, 2 * scene.rod.E_b]})
    assert len(df) == 4 and df["converged"].tolist() == [True, True, False, False]
    assert "unstable" in df["reason"][2] and not df["stable"][2]
    want = R.solve(scene)
    tip = df.loc[0, ["tip_x [m]", "tip_y [m]", "tip_z [m]"]].to_numpy(float)
    assert np.max(np.abs(tip - want.tip["position"])) / scene.rod.length < 1e-9
    assert df.loc[0, "field.B_x [T]"] == scene.loads.B[0]


def test_matid_solve_sweep_writes_every_row_and_exits_1(tmp_path):
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "matid", "solve", str(EXAMPLE), "--out", str(out)]
    run = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, check=False)
    assert run.returncode == 1, run.stderr
    doc = json.loads((out / "sweep.json").read_text())
    assert doc["states"] == 36 and doc["failed"] == 3
    failed = [r for r in doc["rows"] if not r["converged"]]
    assert all(r["field.B_z [T]"] == -0.02 and "unstable" in r["reason"] for r in failed)
    lines = (out / "sweep.csv").read_text().splitlines()
    assert len(lines) == 37 and lines[0].startswith("rod.E_b [N m^2],field.B_x [T]")
    assert (out / "workspace.png").read_bytes()[:4] == b"\x89PNG"


def test_solve_without_sweep_imports_no_table_fit_or_report_stack(tmp_path):
    """Issue 32 item 5: `matid solve` of a scene without a sweep loads neither pandas nor the
    fit (lmfit) or report (reportlab, jinja2) stacks."""
    scene = ROOT / "examples" / "scenes" / "tip_force.toml"
    code = (
        "import sys; from matid.app.cli import main; "
        f"code = main(['solve', r'{scene}', '--out', r'{tmp_path / 'o'}']); "
        "loaded = [m for m in ('pandas', 'lmfit', 'reportlab', 'jinja2') if m in sys.modules]; "
        "assert not loaded, f'imported: {loaded}'; sys.exit(code)"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=False)
    assert run.returncode == 0, run.stderr


def test_a_swept_value_outside_the_scene_files_bounds_is_a_failed_state():
    """Fuzz (issue 30): a swept value is held to the bounds a scene file's value is (docs/scenes.md):
    B = 1e300 mT in a sweep was solved and returned 1e297 T where the scene file refuses it."""
    scene = S.magnetic(2.0, 90.0)
    axes = parse_sweep({"field.B": [[1e297, 0.0, 0.0], [0.02, 0.0, 0.0]], "rod.length": [1e-9, 0.03]})
    made = states(scene, axes)
    refused = [(c, str(s)) for c, s in made if isinstance(s, DataError)]
    big, small = (1e297, 0.0, 0.0), (0.02, 0.0, 0.0)
    assert [c for c, _ in refused] == [(big, 1e-9), (big, 0.03), (small, 1e-9)]
    assert "field.B: each component must be at most 100 T" in refused[1][1]
    assert "rod.length: must be in (1e-06, 100] m" in refused[2][1]
    assert made[3][1].loads.B == (0.02, 0.0, 0.0) and made[3][1].rod.length == 0.03


def test_tips_gathered_in_a_lumen_are_drawn_zoomed_and_a_free_workspace_is_not():
    """The 36 tips of the magnetic workspace in a bent 0.6 mm lumen spread over 0.2 mm, 29 mm from
    the clamp: drawn around the clamp (as before) they were one dot under 2.3 mm arrows."""
    from matid.rod.sweep_output import span_of, view

    rng = np.random.default_rng(0)
    lumen = np.array([4.53, 4.53, 28.6]) + rng.uniform(-0.1, 0.1, (36, 3))
    zoom, arrow = view(lumen, span_of(lumen))
    assert zoom and arrow == pytest.approx(0.16 * np.max(np.ptp(lumen, axis=0)))
    angle = np.linspace(0.0, 2.0 * np.pi, 12)
    free = np.column_stack([18.0 * np.sin(angle), np.zeros(12), 18.0 * np.cos(angle)])
    zoom, arrow = view(free, span_of(free))
    assert not zoom and arrow == pytest.approx(0.08 * 18.0)


def test_workspace_panels_hold_every_tip_and_arrow_end_after_drawing():
    """A zoomed sweep (tips spread over 0.2 mm, 28.6 mm from the clamp, as in a bent lumen): with an
    equal-aspect 'datalim' view the panels cut the rightmost tips and their d3 arrows. Every tip and
    arrow end is inside its panel once drawn."""
    from matid.rod.sweep_output import view, workspace_figure

    field = tuple((0.02 * np.cos(a), 0.0, 0.02 * np.sin(a)) for a in np.arange(12) * np.pi / 6)
    stiffness = Axis("rod.E_b", "bending_stiffness", False, (6e-5, 9e-5, 1.2e-4))
    axes = [stiffness, Axis("field.B", "field", True, field)]
    rng = np.random.default_rng(3)
    rows = []
    for _ in range(36):
        tip = np.array([4.43 + 0.21 * rng.random(), 4.44 + 0.17 * rng.random(), 28.55 + 0.09 * rng.random()])
        d3 = np.array([0.33, 0.31, 0.89]) / np.linalg.norm([0.33, 0.31, 0.89])
        rows.append({"converged": True, **{f"tip_{c} [m]": x * 1e-3 for c, x in zip("xyz", tip, strict=True)},
                     **{f"d3_{c}": x for c, x in zip("xyz", d3, strict=True)}})  # fmt: skip
    fig = workspace_figure(axes, rows)
    fig.canvas.draw()
    tip = np.array([[r[f"tip_{c} [m]"] * 1e3 for c in "xyz"] for r in rows])
    d3 = np.array([[r[f"d3_{c}"] for c in "xyz"] for r in rows])
    zoom, arrow = view(tip, float(np.abs(tip).max()))
    assert zoom
    for panel, c in zip(fig.axes[:2], (0, 1), strict=True):
        ends = np.vstack([tip[:, [c, 2]], tip[:, [c, 2]] + arrow * d3[:, [c, 2]]])
        (x0, x1), (y0, y1) = panel.get_xlim(), panel.get_ylim()
        lo, hi = ends.min(axis=0), ends.max(axis=0)
        assert x0 < lo[0] and hi[0] < x1 and y0 < lo[1] and hi[1] < y1, (x0, x1, y0, y1, lo, hi)
