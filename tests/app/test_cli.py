"""End to end through ``matid.app.cli.main``: outputs, units, exit codes, error messages."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pytest

from matid import __version__
from matid.app import pipeline
from matid.app.cli import main
from matid.errors import ConvergenceError, FitError

DEMO = Path(str(resources.files("matid.example")))
OUTPUTS = {"report.html", "report.pdf", "stiffness.csv", "stiffness.json", "stiffness.xlsx"}
CSV_HEADER = "specimen,parameter,value,stderr,ci95_low,ci95_high,unit,n_points,method,warnings,status"
SI_UNITS = {
    "E_b": "N m^2",
    "E_t": "N m^2",
    "E_e": "N",
    "sls_k1": "N",
    "sls_k2": "N",
    "sls_eta": "N s",
    "E_s": "N",
    "E_s_torsion": "N",
}
CGS = {"N": ("dyn", 1e5), "N m^2": ("dyn cm^2", 1e9), "N s": ("dyn s", 1e5)}


def run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def copy_demo(folder: Path) -> Path:
    """The demo study's toml and CSV files (not its Python generator) in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for path in DEMO.iterdir():
        if path.suffix in {".toml", ".csv"}:
            shutil.copy(path, folder / path.name)
    return folder


def small_study(folder: Path) -> Path:
    """T1 of the demo without its three-point bend: quick to fit and render."""
    copy_demo(folder)
    toml = (folder / "study.toml").read_text()
    blocks = toml.split("[[test]]")
    keep = [b for b in blocks[1:] if 'specimen = "T1"' in b and "three_point_bend" not in b]
    head = blocks[0].split("[[specimen]]")
    (folder / "study.toml").write_text(
        head[0] + "[[specimen]]" + head[1] + "[[test]]" + "[[test]]".join(keep)
    )
    return folder


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    """``matid demo`` from an empty working folder (default --out reports/demo)."""
    cwd = tmp_path_factory.mktemp("cwd")
    before = Path.cwd()
    os.chdir(cwd)
    try:
        code, out, err = run(["demo"])
    finally:
        os.chdir(before)
    return code, out, err, cwd / "reports" / "demo"


@pytest.fixture(scope="module")
def cgs_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("cgs") / "out"
    code, stdout, err = run(["fit", str(DEMO / "study.toml"), "--out", str(out), "--units", "cgs", "--quiet"])
    assert err == ""  # --quiet: no progress lines
    return code, stdout, out


def read_json(folder: Path) -> dict:
    return json.loads((folder / "stiffness.json").read_text(encoding="utf-8"))


# -- the demo, end to end ------------------------------------------------------------------


def test_demo_writes_every_output_from_a_fresh_folder(demo_run):
    code, out, err, folder = demo_run
    assert code == 0, err
    assert {p.name for p in folder.iterdir()} == OUTPUTS
    assert (folder / "report.pdf").read_bytes().startswith(b"%PDF")
    html = (folder / "report.html").read_text(encoding="utf-8")
    assert "SYNTHETIC demo" in html
    assert not re.search(r"""(src|href)=["']https?://""", html)  # self-contained, offline


def test_demo_pdf_is_readable(demo_run):
    pypdf = pytest.importorskip("pypdf")
    reader = pypdf.PdfReader(demo_run[3] / "report.pdf")
    assert len(reader.pages) >= 1
    assert "SYNTHETIC demo" in reader.pages[0].extract_text()


def test_demo_prints_progress_summary_and_paths(demo_run):
    _, out, err, folder = demo_run
    assert "fitting extension T1" in err and re.search(r"\[\s*\d+\.\d s\]", err)
    # page 1's columns: status in words, value, 95 % interval, unit, method
    assert re.search(r"T1\s+E_b\s+use it\s+6\.\d+e-05\s+\S+ to \S+\s+N m\^2", out)
    assert re.search(r"T1\s+E_s\s+use it\s+2\d\.\d+\s+2\d\.\d+ to [23]\d\.\d+\s+N\s+cosserat-fe", out)
    assert re.search(r"T2\s+E_s\s+check it\s+19\.\d+\s+8\.\d+ to 1\d\d(\.\d)?\s+N\s+cosserat-fe", out)
    for name in OUTPUTS:
        assert str(Path("reports") / "demo" / name) in out


def test_json_follows_the_contract(demo_run):
    doc = read_json(demo_run[3])
    assert set(doc) >= {"matid_version", "unit_system", "study", "inputs", "specimens", "warnings"}
    assert (doc["matid_version"], doc["unit_system"]) == (__version__, "SI")
    assert doc["study"].startswith("SYNTHETIC demo")
    assert {i["file"] for i in doc["inputs"]} == {p.name for p in DEMO.glob("*.csv")}
    assert all(re.fullmatch(r"[0-9a-f]{64}", i["sha256"]) for i in doc["inputs"])
    assert set(doc["specimens"]) == {"T1", "T2"}
    for params in doc["specimens"].values():
        assert set(params) == set(SI_UNITS)
        fe = params["E_s"]["fe"]  # issue 5: how accurate the FE answer is and what it cost
        assert fe["element"] == "P2" and fe["elements"] >= 2 and fe["runtime_s"] > 0
        assert 0 < fe["discretization_error"] < 0.1 * params["E_s"]["stderr"] / params["E_s"]["value"]
        for name, item in params.items():
            assert set(item) >= {"value", "stderr", "ci95", "unit", "n_points", "method"}
            assert item["unit"] == SI_UNITS[name]
            low, high = item["ci95"]
            assert low < item["value"] < high and item["n_points"] > 0


def test_csv_follows_the_contract(demo_run):
    text = (demo_run[3] / "stiffness.csv").read_text(encoding="utf-8")
    assert text.splitlines()[0] == CSV_HEADER
    rows = list(csv.DictReader(io.StringIO(text)))
    assert {(r["specimen"], r["parameter"]) for r in rows} == {(s, p) for s in ("T1", "T2") for p in SI_UNITS}
    assert all(r["unit"] == SI_UNITS[r["parameter"]] for r in rows)


def test_demo_recovers_the_ground_truth(demo_run):
    fitted = read_json(demo_run[3])["specimens"]
    truth = json.loads((DEMO / "ground_truth.json").read_text())["specimens"]
    for sid, expected in truth.items():
        assert fitted[sid]["E_e"]["value"] == pytest.approx(expected["E_e"], rel=0.005)
        assert fitted[sid]["E_b"]["value"] == pytest.approx(expected["E_b"], rel=0.005)
        E_s = fitted[sid]["E_s"]
        low, high = E_s["ci95"]  # bend data from the shooting model (matid.example.bend_shooting)
        assert E_s["method"] == "cosserat-fe" and low < expected["E_s"] < high
        if sid == "T1":  # centreline data: the rod's own deflection
            assert E_s["value"] == pytest.approx(expected["E_s"], rel=0.01)
        else:  # nose travel with a real tube's contact travel: low, and said so first
            assert E_s["value"] < 0.7 * expected["E_s"]
            assert E_s["warnings"][0].startswith("E_s is likely too low")
        assert fitted[sid]["E_t"]["value"] == pytest.approx(expected["E_t"], rel=0.01)


def test_cgs_units(cgs_run, demo_run):
    code, stdout, folder = cgs_run
    assert code == 0
    doc, si = read_json(folder), read_json(demo_run[3])
    assert doc["unit_system"] == "cgs"
    for sid, params in doc["specimens"].items():
        for name, item in params.items():
            unit, factor = CGS[SI_UNITS[name]]
            assert item["unit"] == unit
            assert item["value"] == pytest.approx(si["specimens"][sid][name]["value"] * factor, rel=1e-9)
    rows = list(csv.DictReader(io.StringIO((folder / "stiffness.csv").read_text())))
    assert {r["unit"] for r in rows} == {"dyn", "dyn cm^2", "dyn s"}
    assert "dyn cm^2" in stdout


# -- exit codes and messages ---------------------------------------------------------------


def test_version_and_help(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"matid {__version__}"
    for command in (["--help"], ["fit", "--help"], ["demo", "--help"]):
        assert main(command) == 0
        assert "--units" in capsys.readouterr().out or command == ["--help"]
    assert main([]) == 2
    assert main(["fit"]) == 2  # PATH is required


def test_units_option_without_pint():
    """--units lists the systems of matid.units; the parser loads pint only for a --units given."""
    from matid.app.options import UNITS_METAVAR
    from matid.units import UNIT_SYSTEMS

    assert UNITS_METAVAR == "{" + ",".join(sorted(UNIT_SYSTEMS)) + "}"
    code = (
        "import sys; from matid.app.cli import build_parser; "
        "p = build_parser(['demo']); p.format_help(); p.parse_args(['demo']); a = 'pint' in sys.modules; "
        "b = p.parse_args(['demo', '--units', 'cgs']).units; print(a, b, 'pint' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split() == ["False", "cgs", "True"]
    with pytest.raises(SystemExit):
        from matid.app.cli import build_parser

        build_parser(["demo"]).parse_args(["demo", "--units", "imperial"])


def test_python_dash_m_matid(tmp_path):
    # From another folder: in the repository root, -m would import the source tree, which
    # lacks matid.example (it ships from data/example only when installed).
    done = subprocess.run(
        [sys.executable, "-m", "matid", "--version"],
        capture_output=True, text=True, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert (done.returncode, done.stdout.strip()) == (0, f"matid {__version__}")


def _replace(path: Path, old: str, new: str, count: int = 1) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text, f"{old!r} not in {path.name}"
    path.write_text(text.replace(old, new, count), encoding="utf-8")


def _missing_file(d: Path) -> tuple[str, ...]:
    (d / "torsion_T1_L26.csv").unlink()
    return ("torsion_T1_L26.csv", "not found")


def _missing_column(d: Path) -> tuple[str, ...]:
    _replace(d / "torsion_T1_L60.csv", "torque [mN mm]", "moment [mN mm]")
    return ("torsion_T1_L60.csv", "torque")


def _bad_unit(d: Path) -> tuple[str, ...]:
    _replace(d / "bending_T1_L60.csv", "torque [mN m]", "torque [furlong]")
    return ("bending_T1_L60.csv", "furlong", "torque")


def _non_numeric(d: Path) -> tuple[str, ...]:
    _replace(d / "torsion_T2_L26.csv", "\n7.500,", "\nseven,")
    return ("torsion_T2_L26.csv", "row 6", "seven")


def _unknown_specimen(d: Path) -> tuple[str, ...]:
    _replace(
        d / "study.toml",
        'specimen = "T2"\nfile = "torsion_T2_L60.csv"',
        'specimen = "T9"\nfile = "torsion_T2_L60.csv"',
    )
    return ("study.toml", "T9")


@pytest.mark.parametrize(
    "breaker", [_missing_file, _missing_column, _bad_unit, _non_numeric, _unknown_specimen]
)
def test_bad_input_exits_2_naming_the_file_and_writes_nothing(tmp_path, breaker):
    study = copy_demo(tmp_path / "study")
    expected = breaker(study)
    out = tmp_path / "out"
    code, stdout, err = run(["fit", str(study), "--out", str(out)])
    assert code == 2
    message = err.strip().splitlines()[-1]
    assert message.startswith("matid: error: ")
    for word in expected:
        assert word in message
    assert "Traceback" not in err and stdout == ""
    assert not out.exists()


def test_missing_study_exits_2(tmp_path):
    code, _, err = run(["fit", str(tmp_path / "nowhere"), "--out", str(tmp_path / "out")])
    assert code == 2 and "nowhere" in err and "Traceback" not in err


def test_debug_shows_the_traceback(tmp_path):
    study = copy_demo(tmp_path / "study")
    _missing_column(study)
    code, _, err = run(["fit", str(study), "--out", str(tmp_path / "out"), "--debug"])
    assert code == 2 and "Traceback" in err and "matid: error:" in err


def test_bad_input_leaves_an_old_report_intact(tmp_path):
    study = copy_demo(tmp_path / "study")
    _bad_unit(study)
    out = tmp_path / "out"
    out.mkdir()
    for name in OUTPUTS:
        (out / name).write_text(f"old {name}")
    assert run(["fit", str(study), "--out", str(out), "--quiet"])[0] == 2
    assert {p.name: p.read_text() for p in out.iterdir()} == {n: f"old {n}" for n in OUTPUTS}


def test_failed_fit_exits_1_and_writes_the_rest(tmp_path):
    """A T1 extension run too short to fit (4 rows): E_e fails, E_b and E_t are written."""
    study = small_study(tmp_path / "study")
    rows = "\n".join(f"{t},{0.5 * t},{0.01 * t}" for t in range(4))
    (study / "extension_T1_r1.csv").write_text(f"time [s],force [N],elongation [mm]\n{rows}\n")
    out = tmp_path / "out"
    out.mkdir()
    for name in OUTPUTS:
        (out / name).write_text(f"old {name}")
    code, stdout, err = run(["fit", str(study / "study.toml"), "--out", str(out), "--quiet"])
    assert code == 1
    assert "matid: fit failed: T1 E_e (extension)" in err and "only 4 samples" in err
    assert "T1 E_e (extension): could not be fitted" in stdout
    assert all(not p.read_text(errors="replace").startswith("old") for p in out.iterdir())
    assert {p.name for p in out.iterdir()} == OUTPUTS  # fully replaced, no temporary files left
    doc = read_json(out)
    assert set(doc["specimens"]["T1"]) == {"E_b", "E_t", "E_s_torsion"}
    assert any("only 4 samples" in w for w in doc["warnings"])


def test_render_crash_exits_3_and_keeps_the_old_report(tmp_path, monkeypatch):
    def broken(result, *, units):
        raise RuntimeError("renderer crashed")

    monkeypatch.setattr(pipeline, "render_report", broken)
    monkeypatch.setitem(pipeline.FITTERS, "extension", _raise(FitError("skipped")))
    study = small_study(tmp_path / "study")
    out = tmp_path / "out"
    out.mkdir()
    for name in OUTPUTS:
        (out / name).write_text(f"old {name}")
    code, _, err = run(["fit", str(study), "--out", str(out), "--quiet"])
    assert code == 3
    assert "internal error: RuntimeError: renderer crashed" in err and "--debug" in err
    assert "Traceback" not in err
    assert {p.name: p.read_text() for p in out.iterdir()} == {n: f"old {n}" for n in OUTPUTS}


def test_internal_error_with_debug_shows_the_traceback(tmp_path, monkeypatch):
    def bug(study, *, progress=None):
        raise ZeroDivisionError("oops")

    monkeypatch.setattr("matid.app.pipeline.run_study", bug)
    code, _, err = run(["fit", str(DEMO), "--out", str(tmp_path / "out"), "--debug"])
    assert code == 3 and "Traceback" in err and "ZeroDivisionError: oops" in err


def test_fit_defaults_to_reports_study_folder(tmp_path, monkeypatch):
    study = small_study(tmp_path / "tube_lot_7")
    monkeypatch.setattr(pipeline, "render_report", lambda result, *, units: {"report.html": b"<html/>"})
    monkeypatch.chdir(tmp_path)
    code, stdout, _ = run(["fit", str(study / "study.toml"), "--quiet"])
    assert code == 0
    assert (tmp_path / "reports" / "tube_lot_7" / "stiffness.json").is_file()
    assert str(Path("reports") / "tube_lot_7" / "stiffness.csv") in stdout


def test_other_matid_errors_exit_1(tmp_path, monkeypatch):
    def diverge(study, *, progress=None):
        raise ConvergenceError("Newton stalled", load_factor=0.25)

    monkeypatch.setattr("matid.app.pipeline.run_study", diverge)
    code, _, err = run(["fit", str(DEMO), "--out", str(tmp_path / "out")])
    assert code == 1 and "matid: error: Newton stalled" in err and "0.25" in err
    assert not (tmp_path / "out").exists()


def _raise(exc: BaseException):
    def fit(measurements, *, specimen, fixed, known):
        raise exc

    return fit


def test_e_s_reports_error_against_run_time(demo_run):
    """Issue 5: every FE answer says how accurate it is and what it cost, per mesh level."""
    fe = read_json(demo_run[3])["specimens"]["T1"]["E_s"]["fe"]
    levels = fe["levels"]
    assert len(levels) >= 2 and levels[-1]["elements"] == fe["elements"]
    coarse, fine = levels[-2], levels[-1]
    assert coarse["elements"] < fine["elements"]
    assert coarse["discretization_error"] > fine["discretization_error"] > 0
    assert all(level["runtime_s"] > 0 for level in levels)
    html = (demo_run[3] / "report.html").read_text(encoding="utf-8")
    assert html.count("Error against run time") >= 2  # one figure per specimen


def test_console_script_is_run_which_exits_with_mains_code(monkeypatch):
    from importlib import metadata

    import matid.app.cli as cli

    (script,) = [e for e in metadata.entry_points(group="console_scripts") if e.name == "matid"]
    assert script.value == "matid.app.cli:run"
    monkeypatch.setattr(cli, "main", lambda: 3)
    with pytest.raises(SystemExit) as exc:
        cli.run()
    assert exc.value.code == 3


def test_demo_runs_without_a_stdout_in_one_process(tmp_path, monkeypatch):
    # Python sets sys.stdout to None when it starts with the descriptor closed (`matid demo >&-`,
    # some daemons): print writes nothing, and the outputs are still written. No other process
    # renders anything (a SIGTERM to matid leaves nothing behind)
    def refuse(*args, **kwargs):
        raise AssertionError("matid demo started another process")

    monkeypatch.setattr(os, "fork", refuse)
    monkeypatch.setattr(subprocess.Popen, "__init__", refuse)
    monkeypatch.setattr("multiprocessing.process.BaseProcess.start", refuse)
    monkeypatch.setattr(sys, "stdout", None)
    assert main(["demo", "--quiet", "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "report.pdf").is_file()


SLIT_STUDY = """
[[specimen]]
id = "{sid}"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"
slit = true

[[test]]
kind = "torsion"
specimen = "{sid}"
file = "t.csv"
length = "60 mm"
"""


def _slit_study(folder: Path, sid: str = "T1") -> Path:
    """An open tube twisted: E_t is fitted, E_s_torsion is not identifiable (withheld), no warning."""
    folder.mkdir(parents=True)
    shutil.copy(resources.files("matid.example") / "torsion_T1_L60.csv", folder / "t.csv")
    (folder / "study.toml").write_text(SLIT_STUDY.format(sid=sid))
    return folder


def test_strict_exits_1_on_a_value_that_is_not_identifiable(tmp_path):
    """Before: a not-identifiable value without a warning gave exit 0 under --strict (alone and in a
    batch). After: exit 1; without --strict still 0."""
    study = str(_slit_study(tmp_path / "a"))
    code, out, err = run(["fit", study, "--out", str(tmp_path / "out"), "--quiet"])
    assert code == 0, err
    assert re.search(r"E_s_torsion\s+not identifiable", out) and "warnings: none" in out
    code, _, err = run(["fit", study, "--out", str(tmp_path / "out"), "--quiet", "--strict"])
    assert code == 1, err
    other = str(_slit_study(tmp_path / "b"))
    code, _, err = run(
        ["fit", study, other, "--out", str(tmp_path / "many"), "--jobs", "1", "--quiet", "--strict"]
    )
    assert code == 1, err
