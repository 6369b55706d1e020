"""A stability case and the outcome it must give (the catalogue is :mod:`matid.bench.catalogue`,
the runner :mod:`matid.bench.stability`).

Every case states its expected outcome (:class:`Expect`): ``ok``, ``flagged`` (the raw
penalty's own error, within ``PENALTY_C / c_u``) or ``raises`` a named ConvergenceError,
at a stated load factor and with a stated reason where the physics fixes them (a buckling
load, a half turn). The tests check exactly that outcome, so a solver that fails at entry
cannot pass for a case that should have solved, nor for one that should have failed later.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

OK, RAISED, REFUSED, INACCURATE, WRONG, TIMED_OUT, CRASHED, UNVERIFIED = (
    "ok",
    "raised ConvergenceError",
    "refused before solving (DataError, exit 2)",
    "inaccurate (penalty error ~1/c_u)",
    "wrong",
    "timed out",
    "crashed",
    "unverified (the reference failed)",
)
ACCEPTABLE = (OK, RAISED, REFUSED, INACCURATE)
Q_CRIT = math.pi**2 / 4  # buckling q of a cantilever with magnetisation against the field
PENALTY_C = 10.0  # raw variant: error <= PENALTY_C / c_u is the penalty's own (measured C ~ 1.4)
TOL = 1e-5
TOL_BASIS = "P2 at 16 elements: tip error <= 1e-6 on these scenes (convergence section); factor 10"
#: How close a ConvergenceError's last converged load factor must be to the expected one
#: (the continuation's smallest step is 1e-6; the measured ones are within 4e-6).
AT_TOL = 1e-4


@dataclass(frozen=True)
class Expect:
    """The outcome a case must give.

    ``outcome``: "ok", "flagged" (the row's outcome is :data:`INACCURATE`), "raises" or
    "refused" (an impossible scene: a DataError before any solve, ``matid solve`` exits 2);
    for "raises": ``error`` the exact ConvergenceError subclass name, ``at`` the last
    converged load factor it reports (None: the error names none), ``says`` words its
    message must contain (for "refused" too).
    """

    outcome: str = "ok"
    error: str | None = None
    at: float | None = None
    says: str | None = None

    def __post_init__(self) -> None:
        if self.outcome not in ("ok", "flagged", "raises", "refused") or (
            self.outcome in ("raises", "refused")
        ) != bool(self.error):
            raise ValueError(f"bad expectation {self!r}: ok, flagged, raises or refused (with an error name)")

    def __str__(self) -> str:
        if self.outcome == "refused":
            return f"refused ({self.error}) saying {self.says!r}"
        if self.outcome != "raises":
            return self.outcome
        at = "" if self.at is None else f" at load factor {self.at:.6g}"
        says = "" if self.says is None else f" saying {self.says!r}"
        return f"raises {self.error}{at}{says}"

    def mismatch(self, row: dict) -> str | None:
        """Why ``row`` (a stability row) is not this outcome; None when it is."""
        got = f"{row['outcome']} ({row.get('raised') or row.get('message') or 'error ' + str(row['error'])})"
        if self.outcome == "refused":
            ok = row["outcome"] == REFUSED and self.says in row.get("message", "")
            return None if ok else f"expected {self}, got {got}: {row.get('message')}"
        if self.outcome != "raises":
            want = OK if self.outcome == "ok" else INACCURATE
            return None if row["outcome"] == want else f"expected {self}, got {got}"
        if row["outcome"] != RAISED or row.get("raised") != self.error:
            return f"expected {self}, got {got}"
        lf = row.get("load_factor")
        if (self.at is None) != (lf is None) or (lf is not None and abs(lf - self.at) > AT_TOL):
            return f"expected {self}, got {self.error} at load factor {lf}"
        if self.says is not None and self.says not in row.get("message", ""):
            return f"expected {self}, got the message {row.get('message')!r}"
        return None


def raises(error: str = "ConvergenceError", *, at: float | None = None, says: str | None = None) -> Expect:
    return Expect("raises", error, at, says)


def refused(*, says: str) -> Expect:
    """An impossible scene: the scene reader's DataError (exit 2) before any solve."""
    return Expect("refused", "DataError", None, says)


SOLVES, FLAGGED = Expect("ok"), Expect("flagged")


@dataclass(frozen=True)
class Case:
    """One stability case.

    ``solve()`` returns a Solution or BendPath or raises; ``error(result)`` is its
    error against ``reference``; ``check(result)`` an optional state check
    (residual, stability); ``expect`` the outcome it must give.
    """

    family: str
    name: str
    parameters: dict
    solve: Callable[[], object]
    error: Callable[[object], float] | None
    reference: str
    tolerance: float | None = TOL
    basis: str = TOL_BASIS
    expect: Expect = SOLVES
    penalty_c_u: float | None = None  # raw variant: c_u, for the 1/c_u bound
    check: Callable[[object], dict] | None = None
    quick: bool = False
    timeout_s: float | None = None
