"""matid bench: the quick run writes its outputs; every stability case class gives its stated outcome.

Each class of stability case has a fast representative here, asserting exactly the outcome its
catalogue entry states (ok, flagged, or a named ConvergenceError at a stated load factor and
reason); the classification itself is tested on stand-in results, so a bad answer can never be
called ok. The full bench (all cases, fine meshes) is not run here.
"""

import argparse
import dataclasses
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from matid.bench import stability
from matid.bench.case import FLAGGED, SOLVES, raises, refused
from matid.bench.catalogue import cases
from matid.bench.cli import SECTIONS, parse_sections, register, run_bench
from matid.errors import ConvergenceError

CATALOGUE = {case.name: case for case in cases(quick=False)}

#: One fast representative per case class (family).
REPRESENTATIVES = [
    "raw q, c_u = 1e+06",
    "normalised q, default c_u",
    "tip force, E_s = E_e = 1e+10",
    "magnetic cantilever, E_s = E_e = 1e+02",
    "soft shear, E_s = 1",
    "Kirchhoff limit, E_s = 1e12",
    "end moment, tip at 225 deg (auto)",
    "end moment, tip at 540 deg (auto)",
    "field 179.5 deg, q = 1.05 q_c",
    "field 180 deg, q = 0.9 q_c",
    "field 180 deg, q = 1.2 q_c",
    "to 20 % of the span (d = 2 mm)",
    "no field (planar)",
    "no load (full model)",
    "a single element",
    "rigid magnet body, E_s = E_e = 1e+04, 16 elements",
    "rigid magnet body, E_s = E_e = 1e+08, 16 elements",
    "a wall at the clamp (45 deg, touching the tube there)",
]

#: The contact cases whose right outcome matid does not reach yet: each a strict xfail naming the
#: defect (the catalogue states what is right physically: they solve).
CONTACT_DEFECTS: dict[str, str] = {}  # none left (issue 31: contact2, contact3)


def test_representatives_cover_every_case_class():
    covered = {CATALOGUE[name].family for name in REPRESENTATIVES} | {"three-point bend", "mesh extremes"}
    assert covered == {case.family for case in CATALOGUE.values()}


#: Every case run here, with the outcome its catalogue entry states: the representatives, the
#: slip-off (must raise SlipOffError), the raw penalty at c_u = 1e2 (must be flagged), every contact
#: case (the impossible scenes must be refused before solving; the defects are strict xfails).
CHECKED = [
    *REPRESENTATIVES,
    "until slip-off (specimen 10.5 mm on a 10 mm span)",
    "raw q, c_u = 1e+02",
    "a rigid tip body against a wall",
    "a wall the unloaded rod lies along, bent away from it",
    "a lumen 1 % wider than the tube",
    "a wall the unloaded rod lies along, pressed on it",
    "an advance whose contact changes sides (channel 8 mm, tilted 10 deg)",
    "a wall cutting the clamp",
    "a lumen narrower than the tube",
    "a lumen as wide as the tube",
    *(
        pytest.param(name, marks=pytest.mark.xfail(strict=True, reason=why))
        for name, why in CONTACT_DEFECTS.items()
    ),
]


@pytest.mark.parametrize("name", CHECKED)
def test_case_gives_the_outcome_its_catalogue_entry_states(name):
    """Exactly the stated outcome: a case that must solve fails on a ConvergenceError, a case that
    must raise fails when it solves or raises elsewhere (another error, load factor or reason)."""
    case = CATALOGUE[name]
    row = stability.run_case(case)
    assert case.expect.mismatch(row) is None, f"{name}: {case.expect.mismatch(row)}"


def test_every_contact_case_is_checked_and_states_a_physical_outcome():
    contact = [c for c in CATALOGUE.values() if c.family == "contact"]
    checked = {p if isinstance(p, str) else p.values[0] for p in CHECKED}
    assert {c.name for c in contact} <= checked
    assert {c.expect.outcome for c in contact} == {"ok", "refused"}  # right physically: solve, or refuse
    assert all(CATALOGUE[name].expect.outcome == "ok" for name in CONTACT_DEFECTS)


def test_impossible_contact_scenes_exit_2_before_solving(tmp_path):
    """`matid solve` of the refused catalogue scenes, written as scene files: exit 2, the reason named."""
    import subprocess
    import sys

    from tests import ROOT

    rod = '[rod]\nlength = "30 mm"\nE_b = 9e-5\nE_t = 9e-5\nE_s = 1e4\nE_e = 1e4\nouter_diameter = "1 mm"\n'
    lumen = '[lumen]\ncentreline = [["0 mm", "0 mm", "-30 mm"], ["0 mm", "0 mm", "60 mm"]]\n'
    scenes = {
        "cuts the clamp": '[[wall]]\npoint = ["0.25 mm", "0 mm", "0 mm"]\nnormal = [-1, 0, 0]\n',
        "narrower than the tube": lumen + 'radius = "0.45 mm"\n',
        "leaves the tube no room": lumen + 'radius = "0.5 mm"\n',
    }
    for says, table in scenes.items():
        path = tmp_path / "scene.toml"
        path.write_text(rod + '[tip]\nforce = ["1 mN", "0 N", "0 N"]\n' + table)
        command = [sys.executable, "-m", "matid", "solve", str(path), "--out", str(tmp_path / "out")]
        env = {"PYTHONPATH": str(ROOT), "PATH": ""}
        run = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, env=env)
        assert run.returncode == 2 and says in run.stderr, (run.returncode, run.stderr)
        assert not (tmp_path / "out" / "solution.json").exists()


def test_raw_penalty_at_small_c_u_is_flagged_within_its_bound():
    row = stability.run_case(CATALOGUE["raw q, c_u = 1e+02"])
    assert row["outcome"] == stability.INACCURATE
    assert row["tolerance"] < row["error"] <= row["penalty_bound"]


def test_every_case_that_must_raise_says_where_or_why():
    for case in CATALOGUE.values():
        if case.expect.outcome == "raises":
            assert case.expect.says, case.name


def test_expectation_rejects_a_failure_elsewhere():
    """A ConvergenceError at load factor 0 (e.g. a solver dead at entry) is not the buckling stop."""
    expect = raises(at=0.8333, says="unstable equilibrium")
    row = {"outcome": stability.RAISED, "raised": "ConvergenceError", "load_factor": 0.0, "error": None}
    assert expect.mismatch({**row, "message": "unstable equilibrium"}) is not None
    assert expect.mismatch({**row, "load_factor": 0.83334, "message": "dead"}) is not None
    assert expect.mismatch({**row, "load_factor": 0.83334, "message": "x: unstable equilibrium"}) is None
    assert SOLVES.mismatch({**row, "message": "no"}) is not None
    assert FLAGGED.mismatch({"outcome": stability.OK, "error": 1e-9}) is not None


def test_a_case_with_a_time_limit_runs_in_a_child_and_is_stopped_at_it():
    fast = stability.run_case(dataclasses.replace(CATALOGUE["a single element"], timeout_s=300.0))
    assert fast["outcome"] == stability.OK and fast["converged"]
    slow = dataclasses.replace(CATALOGUE["10^4 elements, E_s = E_e = 1e6"], timeout_s=0.5)
    row = stability.run_case(slow)
    assert row["outcome"] == stability.TIMED_OUT and row["message"] == "no answer within 0.5 s (stopped)"


# -- the classification, on stand-in results -----------------------------------------------------


def _case(**overrides) -> stability.Case:
    base = dict(
        family="test",
        name="stand-in",
        parameters={},
        solve=lambda: None,
        error=lambda r: r.err,
        reference="none",
        tolerance=1e-5,
    )
    return stability.Case(**{**base, **overrides})


def _result(err: float):
    return SimpleNamespace(err=err, newton_iterations=3, load_steps=1)


@pytest.mark.parametrize(
    ("err", "case", "outcome"),
    [
        (1e-7, {}, stability.OK),
        (1e-3, {}, stability.WRONG),
        (float("nan"), {}, stability.WRONG),
        (1e-3, {"penalty_c_u": 1e2, "tolerance": 1e-4}, stability.INACCURATE),
        (1.0, {"penalty_c_u": 1e2, "tolerance": 1e-4}, stability.WRONG),
        (1e-7, {"check": lambda r: {"stable": False}}, stability.WRONG),
        (1e-7, {"expect": raises("SlipOffError"), "error": None}, stability.WRONG),
        (1e-7, {"expect": refused(says="cuts the clamp"), "error": None}, stability.WRONG),
    ],
)
def test_classification_never_calls_a_bad_answer_ok(err, case, outcome):
    assert stability._judge(_case(**case), _result(err), 0.1, 1)["outcome"] == outcome


def test_other_exceptions_are_crashes_not_hidden():
    def boom():
        raise FloatingPointError("NaN in the tangent")

    assert stability.run_case(_case(solve=boom))["outcome"] == stability.CRASHED


def test_a_failing_reference_is_not_blamed_on_the_case():
    def no_reference(result):
        raise ConvergenceError("the fine mesh failed")

    assert stability.run_case(_case(solve=lambda: _result(0.0), error=no_reference))["outcome"] == (
        stability.UNVERIFIED
    )


def test_raised_convergence_error_is_recorded():
    def fail():
        raise ConvergenceError("no way", load_factor=0.5)

    row = stability.run_case(_case(solve=fail))
    assert row["outcome"] == stability.RAISED and row["load_factor"] == 0.5 and not row["converged"]


# -- command line and outputs -----------------------------------------------------------------------


def test_register_adds_bench_with_defaults():
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    args = parser.parse_args(["bench", "--quick"])
    assert (
        args.quick and args.out == Path("reports/bench") and parse_sections(args.sections) == list(SECTIONS)
    )


def test_unknown_section_is_named():
    with pytest.raises(ValueError, match="sections: unknown nope"):
        parse_sections("convergence,nope")


def test_a_failing_section_is_reported_not_faked(monkeypatch, tmp_path):
    """A section that raises is recorded as failed (exit 1); the other sections still run."""
    from matid.bench import vs3d

    def fail(quick):
        raise RuntimeError("no 3D today")

    monkeypatch.setattr(vs3d, "run", fail)
    assert run_bench(tmp_path, quick=True, sections="vs_3d,leave_out") == 1
    doc = json.loads((tmp_path / "bench.json").read_text())
    assert doc["sections"]["vs_3d"]["status"] == "failed: RuntimeError: no 3D today"
    assert doc["sections"]["leave_out"]["rows"]


def test_quick_bench_writes_json_html_and_plots(tmp_path):
    sections = ["convergence", "stability", "leave_out"]
    code = run_bench(tmp_path, quick=True, sections=sections)
    doc = json.loads((tmp_path / "bench.json").read_text())
    assert code == 0, doc["sections"]["stability"].get("not_acceptable")
    assert set(doc["sections"]) == set(sections)
    assert {"platform", "cpu", "cores", "python", "numpy", "scipy", "scikit-fem"} <= set(doc["machine"])
    for name in ("convergence_error_vs_time.png", "convergence_error_vs_elements.png"):
        assert (tmp_path / name).read_bytes().startswith(b"\x89PNG")
    html = (tmp_path / "bench.html").read_text()
    assert html.count("data:image/png;base64,") >= 2 and "Observed orders" in html
    rows = doc["sections"]["convergence"]["rows"]
    keys = {"scene", "model", "element", "quadrature", "elements", "runtime_s", "error", "reference"}
    assert all(keys <= set(r) for r in rows)
    orders = {
        (o["scene"], o["element"], o["quadrature"]): o["observed_order"]
        for o in doc["sections"]["convergence"]["orders"]
    }
    # with contact (a wall holding the tip; error against the elastica shot with the wall's reaction):
    # fourth order too, every level solved and timed
    assert orders[("tip on a wall", "P2", "2-point Gauss")] > 3.5
    wall = [r for r in rows if r["scene"] == "tip on a wall"]
    assert [r["elements"] for r in wall] == [2, 4, 8, 16] and all(r["runtime_s"] > 0 for r in wall)
    assert wall[-1]["error"] < 1e-6
    for scene in ("magnetic cantilever", "tip force", "circle"):
        assert orders[(scene, "P2", "2-point Gauss")] > 3.5  # fourth order at the tip (nodes for the circle)
        assert orders[(scene, "P1", "2-point Gauss")] < 1.0  # locked
    # the cubic Hermite: converging on the circle (nothing stiff; order 4 asymptotically, ~3 over the
    # quick levels 2-16) and side by side with P2 in error and run time
    assert orders[("circle", "Hermite", "3-point Gauss")] > 2.5
    pairs = doc["sections"]["convergence"]["p2_vs_hermite"]
    assert {r["scene"] for r in pairs} == {"magnetic cantilever", "tip force", "circle"}
    assert all(r["P2_runtime_s"] > 0 and r["Hermite_runtime_s"] > 0 for r in pairs)
    assert "P2 and the cubic Hermite" in html
    rows = doc["sections"]["stability"]["rows"]
    assert len(rows) >= 10
    assert all(
        {
            "case",
            "parameters",
            "converged",
            "newton_iterations",
            "load_steps",
            "runtime_s",
            "error",
            "outcome",
        }
        <= set(r)
        for r in rows
    )
    assert not [r["case"] for r in rows if CATALOGUE[r["case"]].expect.mismatch(r)]
    assert {r["model"] for r in doc["sections"]["leave_out"]["rows"]} == {"planar", "full"}


# -- peers ------------------------------------------------------------------------------------------


def test_solve_bvp_baseline_is_an_independent_answer_to_the_same_problems():
    """The baseline agrees with matid's solve() on all three peer problems (different methods:
    collocation of the strong form against FE of the energy), and with the printed benchmark."""
    from matid.bench import peers
    from matid.rod import solve

    for problem in peers.problems():
        reference = problem["baseline"].tip(tol=1e-8)
        matid_tip = np.asarray(solve(problem["scene"]).position[-1]) / problem["scene"].rod.length
        assert np.max(np.abs(matid_tip - reference)) < 3e-6, problem["label"]
    magnetic = peers.problems()[0]["baseline"].tip(tol=1e-8)
    assert abs(magnetic[0] - 0.83419) < 1e-5 and abs(magnetic[2] - 0.29063) < 1e-5  # printed digits


def test_peers_section_reports_ratios_and_errors(tmp_path):
    code = run_bench(tmp_path, quick=True, sections="peers")
    doc = json.loads((tmp_path / "bench.json").read_text())
    section = doc["sections"]["peers"]
    assert code == 0 and section["status"] == "ok" and len(section["rows"]) == 3
    for row in section["rows"]:
        assert row["speedup_vs_baseline"] == pytest.approx(row["baseline_s"] / row["matid_s"])
        assert row["matid_tip_error"] < 3e-6 and row["baseline_tip_error"] <= 1e-6
    assert "pyelastica" in section
