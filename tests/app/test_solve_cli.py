"""``matid solve SCENE.toml --out DIR``: outputs, summary line, exit codes (data-contract sections 5-6)."""

from __future__ import annotations

import contextlib
import io
import json
import re
import shutil
import subprocess
import sys

import pytest

from matid.app.cli import main
from tests import ROOT

EXAMPLES = ROOT / "examples" / "scenes"
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
PNG = b"\x89PNG\r\n\x1a\n"


def run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_cantilever_writes_solution_and_shape(tmp_path):
    scene = str(EXAMPLES / "tip_force.toml")
    code, out, err = run(["solve", scene, "--out", str(tmp_path), "--elements", "8"])
    assert code == 0, err
    doc = json.loads((tmp_path / "solution.json").read_text())
    assert CONTRACT_KEYS <= set(doc) and "three_point_bend" not in doc
    assert doc["scene"] == "cantilever" and doc["model"] == "planar" and doc["elements"] == 8
    assert doc["converged"] is True and doc["tip"]["position"] == doc["position"][-1]
    assert (tmp_path / "shape.png").read_bytes()[:8] == PNG
    summary = out.splitlines()[0]
    assert "planar model, 8 P2 elements" in summary and "tip at (" in summary
    assert "Newton iterations" in summary
    assert sorted(p.name for p in tmp_path.iterdir()) == ["shape.png", "solution.json"]  # no temporaries


def test_three_point_bend_writes_the_force_curve(tmp_path):
    code, out, err = run(["solve", str(EXAMPLES / "three_point_bend.toml"), "--out", str(tmp_path)])
    assert code == 0, err
    doc = json.loads((tmp_path / "solution.json").read_text())
    assert CONTRACT_KEYS <= set(doc) and doc["model"] == "planar"
    bend = doc["three_point_bend"]
    assert bend["deflection"] == pytest.approx([1e-4, 5e-4, 1e-3]) and len(bend["force"]) == 3
    assert doc["s"][-1] == pytest.approx(0.03)  # the whole tube, not the half model
    assert "nose force" in out and "at 1 mm" in out
    assert (tmp_path / "shape.png").read_bytes()[:8] == PNG


def test_malformed_scene_exits_2_naming_file_and_key(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text((EXAMPLES / "tip_force.toml").read_text().replace('"21 N"', '"21 furlong"'))
    code, out, err = run(["solve", str(scene), "--out", str(tmp_path / "out")])
    assert code == 2
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 2
    assert str(scene) in err and "rod.E_s" in err and "furlong" in err
    assert not (tmp_path / "out").exists()


def test_model_that_does_not_fit_the_scene_exits_2(tmp_path):
    scene = str(EXAMPLES / "three_point_bend.toml")
    code, _, err = run(["solve", scene, "--out", str(tmp_path), "--model", "full"])
    assert code == 2 and "--model full" in err and "three_point_bend.toml" in err
    code, _, err = run(["solve", scene, "--out", str(tmp_path), "--elements", "1"])
    assert code == 2 and "half model needs at least 2" in err and "Traceback" not in err
    assert not (tmp_path / "solution.json").exists()


def test_unstable_scene_exits_1_with_the_load_factor_and_writes_nothing(tmp_path):
    """A magnet against an antiparallel field at twice its buckling load: no stable state."""
    scene = tmp_path / "buckles.toml"
    scene.write_text("""
[rod]
length = "30 mm"
E_b = "6.5e-5 N m^2"
E_t = "4.4e-5 N m^2"
E_s = "21 N"
E_e = "120 N"
[[magnet]]
at = "30 mm"
moment = "0.1 A m^2"
[field]
B = ["0 mT", "0 mT", "-43.3333333 mT"]   # m B L / E_b = 2
""")
    out_dir = tmp_path / "out"
    code, out, err = run(["solve", str(scene), "--out", str(out_dir), "--elements", "4"])
    assert code == 1 and "Traceback" not in err
    reached = re.search(r"last converged load factor ([0-9.e-]+)", err)
    assert "unstable equilibrium" in err and float(reached.group(1)) == pytest.approx(0.5, abs=1e-4)
    assert not (out_dir / "solution.json").exists() and not (out_dir / "shape.png").exists()


def test_slip_off_exits_1_with_the_deflection(tmp_path):
    scene = tmp_path / "short.toml"
    text = (EXAMPLES / "three_point_bend.toml").read_text()
    text = text.replace('length = "30 mm"', 'length = "10.2 mm"').replace('"2 mm"', '"0 mm"')
    scene.write_text(text.replace('["0.1 mm", "0.5 mm", "1 mm"]', '["1 mm", "4 mm"]'))
    code, out, err = run(["solve", str(scene), "--out", str(tmp_path / "out"), "--elements", "8"])
    assert code == 1 and "slips off at nose deflection 0.0027" in err
    assert not (tmp_path / "out" / "solution.json").exists()


def test_console_script_runs(tmp_path):
    exe = shutil.which("matid")
    argv = [exe] if exe else [sys.executable, "-m", "matid"]
    scene = str(EXAMPLES / "magnetic_cantilever.toml")
    proc = subprocess.run(
        argv + ["solve", scene, "--out", str(tmp_path)], capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert "tip at (25.0256, 0, 8.71892) mm" in proc.stdout
    assert json.loads((tmp_path / "solution.json").read_text())["elements"] == 20


# -- the outputs are published like `matid fit`'s (issue 30, item 3) ---------------------------------

FAST = [str(EXAMPLES / "tip_force.toml"), "--elements", "8"]


def _read_only_folder(tmp_path):
    """A folder this process cannot write into (a read-only tmpfs as root), or None."""
    import os

    ro = tmp_path / "ro"
    ro.mkdir()
    if os.geteuid() != 0:
        ro.chmod(0o555)
        return ro
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(ro)], capture_output=True
    )
    return ro if done.returncode == 0 else None


@pytest.mark.parametrize("where", ["a file", "under a file", "read-only", "foreign files"])
def test_an_unusable_out_exits_2_before_solving(tmp_path, where):
    """Before: exit 3 (FileExistsError, NotADirectoryError, PermissionError) or files written beside
    the user's own. After: exit 2 naming --out, nothing written."""
    out = tmp_path / "out"
    if where == "a file":
        out.write_text("mine")
    elif where == "under a file":
        (tmp_path / "f").write_text("mine")
        out = tmp_path / "f" / "out"
    elif where == "foreign files":
        out.mkdir()
        (out / "notes.txt").write_text("mine")
    else:
        ro = _read_only_folder(tmp_path)
        if ro is None:
            pytest.skip("root without a tmpfs mount: cannot make a read-only folder")
        out = ro / "out"
    try:
        code, stdout, err = run(["solve", *FAST, "--out", str(out)])
    finally:
        if where == "read-only":
            subprocess.run(["umount", "-l", str(tmp_path / "ro")], check=False)
            (tmp_path / "ro").chmod(0o755)
    assert code == 2, err
    assert "--out" in err and str(out) in err and "internal error" not in err
    assert stdout == ""  # refused before the solve: no summary line
    if where == "foreign files":
        assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


def test_a_full_disk_exits_4_and_leaves_the_previous_outputs_whole(tmp_path, monkeypatch):
    """Before: a full disk between solution.json and shape.png gave exit 3 and left the new
    solution.json beside the old shape.png. After: exit 4, both old files unchanged, no temporaries."""
    import os

    out = tmp_path / "out"
    code, _, err = run(["solve", str(EXAMPLES / "tip_force.toml"), "--elements", "4", "--out", str(out)])
    assert code == 0, err
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    calls = []
    real_fsync = os.fsync

    def full(fd):
        calls.append(fd)
        if len(calls) > 1:  # the first file got through, the second finds the disk full
            raise OSError(28, "No space left on device")
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", full)
    code, _, err = run(["solve", *FAST, "--out", str(out)])
    monkeypatch.undo()
    assert code == 4, err
    assert "No space left on device" in err and "unchanged" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert [p.name for p in tmp_path.iterdir() if ".matid-new-" in p.name or ".matid-old-" in p.name] == []


HOLDER = """
import sys, time
from matid.io.publish import claim_output
claim = claim_output(sys.argv[1])
print("locked", flush=True)
time.sleep(60)
"""


def test_a_second_run_into_the_same_folder_is_refused(tmp_path):
    """Before: two solves into one folder could interleave their files (no lock). After: while one
    matid run holds the folder, a solve into it exits 2 and writes nothing."""
    import os

    out = tmp_path / "out"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(out)],
        stdout=subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    try:
        assert holder.stdout.readline().strip() == b"locked"
        code, _, err = run(["solve", *FAST, "--out", str(out)])
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
    assert code == 2 and "another matid run" in err
    assert not out.exists()
