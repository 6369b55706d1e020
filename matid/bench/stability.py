"""Stability: stiff and extreme cases, each with a reference and a stated tolerance.

Every case runs one solve (timed best of 3) and gets one outcome:

- ``ok``: converged, error <= tolerance, and (planar cantilevers) the returned
  state is a stable equilibrium (:mod:`matid.bench.checks`);
- ``raised ConvergenceError``: matid said it could not solve (the subclass is
  named: ``SlipOffError`` is the expected answer of the slip-off case). An
  honest failure, never a wrong number;
- ``inaccurate (penalty error ~1/c_u)``: the paper's raw-quaternion variant
  converged, its error exceeds the tolerance, but stays within the error its
  penalty allows by construction (``PENALTY_C / c_u``): flagged, not hidden;
- ``wrong``: converged, and the error exceeds the tolerance (or the state is
  an unstable equilibrium, or the case should have raised). Must not occur;
- ``timed out``: no answer within the case's time limit (run in a child process);
- ``crashed``: another exception than ConvergenceError (a solver or bench bug);
- ``unverified (the reference failed)``: converged, but the reference could not
  be computed (e.g. a fine-mesh reference raised): no claim either way.

Tolerances are relative to the rod length (tip positions) or to the force
(bend); each row states its basis. P2 with two-point Gauss at 16 elements
has tip errors of 1e-6 or less on these scenes (convergence section), so
1e-5 leaves a factor of ten for the harder cases; rotations by whole turns get
1e-4 (the error grows with the turning, (turns)^4).
"""

from __future__ import annotations

import math
import multiprocessing
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

from matid.bench.common import REPEATS, best_of
from matid.errors import ConvergenceError

OK, RAISED, INACCURATE, WRONG, TIMED_OUT, CRASHED, UNVERIFIED = (
    "ok",
    "raised ConvergenceError",
    "inaccurate (penalty error ~1/c_u)",
    "wrong",
    "timed out",
    "crashed",
    "unverified (the reference failed)",
)
ACCEPTABLE = (OK, RAISED, INACCURATE)
Q_CRIT = math.pi**2 / 4  # buckling q of a cantilever with magnetisation against the field
PENALTY_C = 10.0  # raw variant: error <= PENALTY_C / c_u is the penalty's own (measured C ~ 1.4)
TOL = 1e-5
TOL_BASIS = "P2 at 16 elements: tip error <= 1e-6 on these scenes (convergence section); factor 10"


@dataclass(frozen=True)
class Case:
    """One stability case (the catalogue is :mod:`matid.bench.catalogue`).

    ``solve()`` returns a Solution or BendPath or raises; ``error(result)`` is its
    error against ``reference``; ``check(result)`` an optional state check
    (residual, stability); ``expect`` the name of the error it should raise, if any.
    """

    family: str
    name: str
    parameters: dict
    solve: Callable[[], object]
    error: Callable[[object], float] | None
    reference: str
    tolerance: float | None = TOL
    basis: str = TOL_BASIS
    expect: str = OK  # or "SlipOffError": the case should raise it
    penalty_c_u: float | None = None  # raw variant: c_u, for the 1/c_u bound
    check: Callable[[object], dict] | None = None
    quick: bool = False
    timeout_s: float | None = None


# -- running and classifying --------------------------------------------------------------------


def run(quick: bool = False) -> dict:
    from matid.bench.catalogue import cases  # the catalogue builds on Case: import it here, not at the top

    rows = [run_case(case) for case in cases(quick)]
    return {
        "rows": rows,
        "outcomes": dict(Counter(row["outcome"] for row in rows)),
        "wrong": [r["case"] for r in rows if r["outcome"] == WRONG],
        "not_acceptable": [r["case"] for r in rows if r["outcome"] not in ACCEPTABLE],
        "outcome_rules": __doc__.split("Tolerances")[0].split("one outcome:")[1].strip(),
    }


def run_case(case: Case) -> dict:
    """One row: case, parameters, converged, newton_iterations, load_steps, runtime_s, error, outcome, ..."""
    row = {
        "family": case.family,
        "case": case.name,
        "parameters": case.parameters,
        "reference": case.reference,
        "tolerance": case.tolerance,
        "tolerance_basis": case.basis,
        "converged": False,
        "newton_iterations": None,
        "load_steps": None,
        "runtime_s": None,
        "error": None,
    }
    return {**row, **(_attempt(case) if case.timeout_s is None else _limited(case))}


def _attempt(case: Case, repeats: int = REPEATS) -> dict:
    """Solve (best of ``repeats``) and judge; a ConvergenceError is recorded, any other exception
    is a crash: recorded, never hidden."""
    t0 = time.perf_counter()
    try:
        result, runtime, runs = best_of(case.solve, repeats)
        return _judge(case, result, runtime, runs)
    except ConvergenceError as exc:
        return _raised(case, exc, time.perf_counter() - t0)
    except Exception as exc:  # noqa: BLE001 - see the docstring
        return {"outcome": CRASHED, "message": f"{type(exc).__name__}: {exc}"}


def _raised(case: Case, exc: ConvergenceError, runtime: float) -> dict:
    name = type(exc).__name__
    note = "" if case.expect in (OK, name) else f" (expected {case.expect})"
    return {
        "runtime_s": runtime,
        "outcome": RAISED,
        "raised": name,
        "message": str(exc) + note,
        "load_factor": exc.load_factor,
    }


def _judge(case: Case, result, runtime: float, runs: int) -> dict:
    out = {
        "converged": True,
        "runtime_s": runtime,
        "runs": runs,
        "newton_iterations": result.newton_iterations,
        "load_steps": result.load_steps,
    }
    if case.expect != OK:
        return {**out, "outcome": WRONG, "message": f"converged, but {case.expect} was expected"}
    try:
        out["error"] = error = case.error(result)
    except Exception as exc:  # noqa: BLE001 - the reference, not the case, failed
        return {**out, "outcome": UNVERIFIED, "message": f"{type(exc).__name__}: {exc}"}
    state = case.check(result) if case.check is not None else {}
    out["state_check"] = state
    if state.get("stable") is False:
        return {**out, "outcome": WRONG, "message": "the returned state is an unstable equilibrium"}
    if not error <= case.tolerance:  # also catches NaN
        bound = None if case.penalty_c_u is None else PENALTY_C / case.penalty_c_u
        if bound is not None and error <= bound:
            return {**out, "outcome": INACCURATE, "penalty_bound": bound}
        return {**out, "outcome": WRONG, "message": f"error {error:.3g} > tolerance {case.tolerance:g}"}
    return {**out, "outcome": OK}


def _limited(case: Case) -> dict:
    """Run the case once in a child process; stop it (by its pid) after ``case.timeout_s``."""
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=lambda: queue.put(_attempt(case, 1)), daemon=True)
    t0 = time.perf_counter()
    child.start()
    child.join(case.timeout_s)
    if child.is_alive():
        child.terminate()
        child.join()
        return {
            "runtime_s": time.perf_counter() - t0,
            "outcome": TIMED_OUT,
            "message": f"no answer within {case.timeout_s:g} s (stopped)",
        }
    try:
        return queue.get(timeout=5.0)
    except Exception:  # noqa: BLE001 - the child died without a word
        return {"outcome": TIMED_OUT, "message": f"the child process ended with code {child.exitcode}"}
