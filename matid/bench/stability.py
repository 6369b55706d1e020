"""Stability: stiff and extreme cases, each with a reference and a stated tolerance.

Every case runs one solve (timed best of 3) and gets one outcome:

- ``ok``: converged, error <= tolerance, and (planar cantilevers) the returned
  state is a stable equilibrium (:mod:`matid.bench.checks`);
- ``raised ConvergenceError``: matid said it could not solve (the subclass is
  named: ``SlipOffError`` is the expected answer of the slip-off case). An
  honest failure, never a wrong number;
- ``refused before solving (DataError, exit 2)``: the scene is impossible (a wall
  cutting the clamp, a lumen narrower than the tube) and the scene reader said so;
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

import multiprocessing
import signal
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import TimeoutError as FutureTimeout
from concurrent.futures.process import BrokenProcessPool

from matid.bench.case import (
    ACCEPTABLE,
    CRASHED,
    INACCURATE,
    OK,
    PENALTY_C,
    RAISED,
    REFUSED,
    TIMED_OUT,
    UNVERIFIED,
    WRONG,
    Case,
)
from matid.bench.catalogue import cases
from matid.bench.common import REPEATS, best_of
from matid.errors import ConvergenceError, DataError

#: Seconds the parent waits beyond a case's limit (the child's start-up and its own stop).
GRACE_S = 60.0

# -- running and classifying --------------------------------------------------------------------


def run(quick: bool = False) -> dict:
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
    except DataError as exc:  # an impossible scene, refused by the scene reader
        return {
            "runtime_s": time.perf_counter() - t0,
            "outcome": REFUSED,
            "raised": "DataError",
            "message": str(exc),
        }
    except Exception as exc:  # noqa: BLE001 - see the docstring
        return {"outcome": CRASHED, "message": f"{type(exc).__name__}: {exc}"}


def _raised(case: Case, exc: ConvergenceError, runtime: float) -> dict:
    name = type(exc).__name__
    expected = case.expect.error
    note = "" if expected in (None, name) else f" (expected {expected})"
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
    if case.expect.outcome in ("raises", "refused"):
        return {**out, "outcome": WRONG, "message": f"converged, but {case.expect.error} was expected"}
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
    """Run the case once in a fresh (spawned) process that stops itself at ``case.timeout_s``
    (a deadline raised between Python statements of the solve); the parent waits for the
    answer with ``concurrent.futures``, and gives up ``GRACE_S`` later if the child cannot
    stop (a solve stuck inside one compiled call): it then ends when that call returns."""
    t0 = time.perf_counter()
    pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
    try:
        row = pool.submit(_attempt_by_name, case.name, case.timeout_s).result(case.timeout_s + GRACE_S)
    except FutureTimeout:
        row = None
    except BrokenProcessPool as exc:  # the child died without a word
        return {"outcome": TIMED_OUT, "message": f"the child process ended: {exc}"}
    except Exception as exc:  # noqa: BLE001 - the bench failed in the child: recorded, never hidden
        return {"outcome": CRASHED, "message": f"{type(exc).__name__}: {exc}"}
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
    if row is None:
        return {
            "runtime_s": time.perf_counter() - t0,
            "outcome": TIMED_OUT,
            "message": f"no answer within {case.timeout_s:g} s (stopped)",
        }
    return row


class _Deadline(BaseException):
    """Raised in the child at its time limit; a BaseException, so no ``except Exception`` of the
    solver or of :func:`_attempt` can take it for a failure of the case."""


def _attempt_by_name(name: str, timeout_s: float) -> dict:
    """In the child: the catalogue case ``name``, once, stopped at ``timeout_s``."""
    (case,) = [c for c in cases() if c.name == name]

    def stop(signum, frame):
        raise _Deadline

    t0 = time.perf_counter()
    signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    try:
        return _attempt(case, 1)
    except _Deadline:
        return {
            "runtime_s": time.perf_counter() - t0,
            "outcome": TIMED_OUT,
            "message": f"no answer within {timeout_s:g} s (stopped)",
        }
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
