"""Newton's method with adaptive load continuation (paper: "pure Newton's method
in a continuity scheme").

A system exposes ``evaluate(x, lam) -> (R, K)`` for the residual R(x; lam) and
its tangent K = dR/dx at load factor lam. :func:`newton` solves R = 0 from a
guess; :func:`follow` walks lam from its current value to each target in turn,
predicting each step from the tangent dx/dlam at the last converged state
(one back-substitution with its factorised tangent), halving the step when
Newton fails and doubling it when Newton converges in a few iterations (with
``definite_start``, the first step is halved beforehand while the start's tangent is not
positive definite at its load: one factorisation instead of a failed Newton). A state
is returned only when converged and admissible (``system.reject``); when the
step falls below MIN_STEP, Newton stagnates at round-off, or the work budget
is spent, a ConvergenceError names the last load factor reached. NaN is a
failure, never a value.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import scipy.sparse.linalg as spla

from matid.errors import ConvergenceError


class System(Protocol):
    def evaluate(self, x: np.ndarray, lam: float, *, tangent: bool = True) -> tuple[np.ndarray, object]: ...


@dataclass
class NewtonInfo:
    iterations: int = 0  # total Newton iterations
    steps: int = 0  # accepted load steps
    rejected: int = 0  # load steps halved after a Newton failure
    lu: object | None = field(default=None, repr=False)  # factorised tangent at the last solution
    confirmed: bool = True  # False: the last Newton ended on ``accept`` without its confirming evaluation
    #: that accepted correction when ``lu`` is the consistent tangent one correction before (else inf)
    last: float = float("inf")


class NewtonFailure(Exception):
    pass


class RoundoffStagnation(NewtonFailure):
    """Newton corrections stopped shrinking above the attainable precision: a smaller
    load step cannot help (the floor is set by the stiffness spread and the mesh)."""


#: Newton: converged below this correction, capped at MAX_STEP, at most MAX_ITER iterations.
XTOL, MAX_STEP, MAX_ITER = 1e-10, 0.5, 16
#: Iterations in all when the residual is piecewise smooth (``system.branch``: a contact's active
#: set): MAX_ITER on each piece, the round-off and divergence tests within one piece only. A
#: semismooth Newton on a penalty contact moves the contact's edge by about one node per
#: iteration, its corrections level at ~3e-4 meanwhile (measured: a rod lying along a wall pressed
#: on it by its tip force, 16 elements, 17 iterations with 10 active-set changes; a tube in a lumen
#: 1 % wider, 20): the round-off test read that level as stagnation (issue 31).
MAX_PIECEWISE_ITER = 4 * MAX_ITER
#: Continuation: smallest and largest load step; a step of at most FAST (2 FAST) iterations grows x2 (x1.5).
MIN_STEP, MAX_LOAD_STEP, FAST = 1e-6, 1.0, 4
#: No correction larger than this is ever accepted as "at the round-off floor".
FLOOR_CAP = 1e-7
#: The round-off floor per unit of the largest scaled stiffness (eps with a margin): :func:`roundoff_floor`.
ROUNDOFF = 1e-15
#: Continuation effort before it gives up: Newton iterations x unknowns (and at least
#: MIN_ITERATIONS iterations). Measured: the Kirchhoff-limit case (E_s L^2/E_b = 1e12,
#: 99 unknowns) needs 1598 iterations in 253 steps (budget 1e5); 10^4 elements at
#: E L^2/E_b = 1e8 crawl at steps of 5e-4 for minutes against round-off, which this
#: bound (166 iterations there) turns into a ConvergenceError after ~11 s.
WORK_BUDGET = 1e7
MIN_ITERATIONS = 200


#: Corrections above this use the mixed-integration-point tangent (systems that offer it);
#: below, the consistent tangent: quadratic convergence, and the last factorisation is the
#: true tangent that the stability test reads. (1e-3 let the switch trip the round-off
#: stagnation test on a stiff (1e8) rod in the full model: found by matid bench leave_out.)
MIXED_ABOVE = 1e-4
#: After a correction above this and not capped by MAX_STEP, Newton hands the state to
#: ``system.project`` (systems that offer it: the normalised full model puts each node's q back on
#: |q| = 1, its gauge). Measured on the bench's 45-degree 3D bend, 4 elements from the unloaded arc:
#: 7 evaluations without, 5 with any threshold from 1e-3 to 2e-2, 6 at 1e-4, 17 at every step (near
#: the root the penalty's |q| is not 1: the projection moves it off by up to 6e-6 and costs the
#: quadratic convergence). On benchmarks/gauge_projection.py's 960 full-model scenes (seed 11),
#: evaluations 29927 without, 18308 after every correction above it (78 scenes took more than
#: without), 16832 not after capped ones (23 took more).
PROJECT_ABOVE = 1e-2
#: :func:`confirm_by_residual` only after an accepted correction at most this large.
CHORD_LAST = 1e-7


def roundoff_floor(stiffest):
    """Smallest Newton correction distinguishable from round-off (a system's ``roundoff``): ROUNDOFF
    times the largest scaled stiffness, at least 1; ``stiffest`` a number or one per scene."""
    return ROUNDOFF * np.maximum(stiffest, 1.0)


def newton(
    system: System,
    x0: np.ndarray,
    lam: float,
    *,
    first: tuple[np.ndarray, object] | None = None,
    accept: float = 0.0,
    info: NewtonInfo | None = None,
) -> tuple[np.ndarray, int, object]:
    """Solve R(x; lam) = 0 from x0 by pure Newton. Returns (x, iterations, factorised tangent).

    ``first``: (R, factorised tangent) at (x0, lam) already evaluated (a stability probe of
    :func:`definite`): the first iteration uses them instead of evaluating again.
    ``accept``: stop without the confirming evaluation once the quadratic model of the last two
    corrections (s^3 / s_prev^2) puts the next one below ``accept`` and this one is below
    MIXED_ABOVE (the next iteration would use the consistent tangent); then ``info.confirmed`` is
    set False and the factor returned is the one a correction (<= MIXED_ABOVE) before the root.

    Converged when the Newton correction is below XTOL (scaled unknowns are
    O(1)), or below the system's round-off floor (``system.roundoff``, eps times
    the stiffness spread) once it stops shrinking. Corrections are capped at
    MAX_STEP (a trust region). No line search, on purpose: on a slender rod
    the first Newton step from a straight state stretches the stiff axis by
    theta^2/2 and raises both the potential and |R| by orders of magnitude, yet
    the next step repairs it (measured: 3 iterations with pure Newton, 24 with an
    Armijo search on the potential). Divergence is caught early instead and the
    load step is halved by :func:`follow`.
    """
    floor = min(max(XTOL, float(getattr(system, "roundoff", 0.0))), FLOOR_CAP)
    measure = getattr(system, "step_size", None) or _max_abs
    x = x0.copy()
    sizes: list[float] = []  # the corrections since the residual's piece last changed
    mixed, project = getattr(system, "mixed_update", None), getattr(system, "project", None)
    if mixed is not None:
        system.mixed_begin()
    branch, piece = getattr(system, "branch", None), None
    for it in range(1, MAX_PIECEWISE_ITER + 1):
        if first is not None and it == 1:
            R, lu = first
        else:
            R, K = system.evaluate(x, lam)
            if not _finite(R):
                raise NewtonFailure("residual is not finite")
            lu = _factor(K)
        if branch is not None:  # a contact's active set changed: a new smooth piece, judged afresh
            now = branch()
            if it > 1 and now != piece:
                sizes = []
            piece = now
        dx = lu.solve(-R)
        if not _finite(dx):
            raise NewtonFailure("Newton correction is not finite")
        size = measure(dx)
        if size <= XTOL or (size <= floor and sizes and size > 0.1 * sizes[-1]):
            return x + dx, it, lu
        if sizes and size**3 <= accept * sizes[-1] ** 2 and size <= MIXED_ABOVE:
            if info is not None:  # the tangent factorised here is consistent after a small correction
                info.confirmed = False
                info.last = size if mixed is None or sizes[-1] <= MIXED_ABOVE else float("inf")
            getattr(system, "settle_stress", lambda d: None)(dx)
            return x + dx, it, lu
        if len(sizes) >= 3 and size > sizes[-1] and size > sizes[-3]:
            if size < 1e-3 and max(sizes[-3:]) < 10 * min(sizes[-3:]) and size < 1e-2 * sizes[0]:
                raise RoundoffStagnation(
                    f"Newton stagnated at corrections of {size:.2g} (scaled) after converging from "
                    f"{sizes[0]:.2g}: the precision double arithmetic allows for this mesh and stiffness "
                    "spread; use fewer elements or a less extreme stiffness ratio"
                )
            raise NewtonFailure(f"diverging: correction {size:.3g} at iteration {it}")
        sizes.append(size)
        if len(sizes) >= MAX_ITER:
            break
        alpha = min(1.0, MAX_STEP / size)
        if mixed is not None:  # mixed tangent far from the root, the consistent one near it
            mixed(dx, alpha) if size > MIXED_ABOVE else system.mixed_reset()
        x = x + dx * alpha
        if project is not None and PROJECT_ABOVE < size <= MAX_STEP:
            x = project(x)
    raise NewtonFailure(f"no convergence in {it} iterations (correction {size:.3g})")


def confirm_by_residual(system: System, x: np.ndarray, lam: float, info: NewtonInfo) -> np.ndarray | None:
    """x plus Newton's confirming correction taken from the residual at x and the factor of the
    iteration before (``info.lu``, after :func:`newton` stopped on ``accept`` with ``info.last`` at
    most CHORD_LAST), or None when that does not apply or the correction is above XTOL (then the
    caller confirms by a full iteration).

    The test of convergence is the same (a correction below XTOL); the tangent is one correction
    (<= CHORD_LAST) before x, so the stability test reads a consistent tangent that far from the
    root instead of ~XTOL: their inertia can differ where an eigenvalue is within O(CHORD_LAST
    times the largest scaled stiffness) of zero (a stiff rod's axial force moves by E_e times the
    strain of a correction). Measured (benchmarks/warm_chord_safety.py --audit, ~37,000 verdicts,
    each also taken with the consistent tangent at the state): 2 disagreements here against 3 with
    the full iteration's factor, all at a bifurcation or fold. Costs a residual and a
    back-substitution instead of an assembled tangent and its factorisation (the bench's peers:
    P1 / P2 ~5 % of a solve)."""
    if info.lu is None or info.last > CHORD_LAST:
        return None
    R = system.evaluate(x, lam, tangent=False)[0]
    if not _finite(R):
        return None
    dx = info.lu.solve(-R)
    if not _finite(dx) or (getattr(system, "step_size", None) or _max_abs)(dx) > XTOL:
        return None
    return x + dx  # the point stresses stay those settled at x: off by C dx, dx <= XTOL


def _max_abs(d: np.ndarray) -> float:
    return float(np.abs(d).max()) if d.size else 0.0


def _finite(v: np.ndarray) -> bool:
    """No NaN or infinity in v (one dot product: any NaN, infinity or overflow makes it non-finite;
    math.isfinite on the scalar: np.isfinite's ufunc call costs ~0.5 us more, 14 times a solve)."""
    return math.isfinite(v @ v)


def _factor(K) -> object:
    if hasattr(K, "factor"):  # band.Banded: LAPACK banded Cholesky, or LU when not positive definite
        try:
            return K.factor()
        except np.linalg.LinAlgError as exc:
            raise NewtonFailure(str(exc)) from exc
    try:
        return spla.splu(K.tocsc())
    except RuntimeError as exc:  # exactly singular tangent
        raise NewtonFailure(f"singular tangent: {exc}") from exc


def tangent(system: System, x: np.ndarray, lam: float, lu: object) -> np.ndarray:
    """dx/dlam on the equilibrium path: K dx/dlam = -dR/dlam, where dR/dlam = R(x, 1) - R(x, 0)
    exactly (every load of the rod scenes is linear in lam)."""
    dR = system.evaluate(x, 1.0, tangent=False)[0] - system.evaluate(x, 0.0, tangent=False)[0]
    return lu.solve(-dR)


def check_admissible(system: System, x: np.ndarray, lam: float, factor: object = None) -> None:
    """Reject a converged state the system says is no answer (``system.reject(x, lam)`` -> reason or None).

    Newton converges to any root: from the straight rod in a field beyond the
    buckling load it can land on the unstable branch (a saddle of the
    potential), and a contact held by |r - c| = rho can jump to the far side of
    a small cylinder (a pulling contact). Rejected, the step is halved, so the
    continuation follows the admissible branch, or fails where there is none.
    """
    reject = getattr(system, "reject", None)
    reason = reject(x, lam, factor) if reject is not None else None
    if reason:
        raise NewtonFailure(reason)


#: At most this many halvings of the first step by :func:`definite_step` (each one assembly and
#: factorisation; 2^-10 of the load is far below any step Newton needs from a stable start).
MAX_DEFINITE_HALVINGS = 10


def definite(system: System, x: np.ndarray, lam: float) -> bool | None:
    """Whether the tangent at (x, lam) is positive definite (its banded Cholesky succeeds), as
    the first Newton iteration there factorises it; None when the system cannot tell
    (unsymmetric or unbanded tangent, non-finite residual)."""
    return _probe(system, x, lam)[0]


def _probe(system: System, x: np.ndarray, lam: float) -> tuple[bool | None, tuple | None]:
    """(:func:`definite`, (R, factorised tangent) when it has them: Newton's first iteration)."""
    getattr(system, "mixed_begin", lambda: None)()
    R, K = system.evaluate(x, lam)
    if not hasattr(K, "factor") or not _finite(R):
        return None, None
    try:
        factor = K.factor()
    except np.linalg.LinAlgError:  # an exactly singular tangent
        return False, None
    return factor.positive_definite, (R, factor)


def definite_step(
    system: System, x: np.ndarray, lam0: float, target: float, step: float, min_step: float
) -> float:
    """The first load step of a continuation from x at lam0: ``step``, halved while the tangent at x
    is not positive definite at the step's load.

    Where the start is itself no stable state under the step's load (the straight rod in a
    field beyond its buckling load, e.g. the q = 6.4 magnetic cantilever at 120 deg beyond
    lam ~0.75), Newton heads for the nearest root of the gradient, a saddle as well as a
    minimum, and the step is halved after a failure anyway (measured there: 8 iterations
    lost at lam = 1, then 7 + 5 from lam = 0.5). One factorisation per halving finds the
    same step without them.
    """
    return _definite_step(system, x, lam0, target, step, min_step)[0]


def _definite_step(system, x, lam0, target, step, min_step) -> tuple[float, tuple | None]:
    """(:func:`definite_step`, (lam, R, factor) of its last probe when Newton may start from it)."""
    for _ in range(MAX_DEFINITE_HALVINGS):
        if step < 2.0 * min_step:
            break
        lam_try = target if abs(target - lam0) <= step else lam0 + np.sign(target - lam0) * step
        if lam_try == lam0:
            break
        ok, first = _probe(system, x, lam_try)
        if ok is not False:
            return step, None if first is None else (lam_try, *first)
        step *= 0.5
    return step, None


def follow(
    system: System,
    x: np.ndarray,
    targets: Sequence[float],
    *,
    lam0: float = 0.0,
    first_step: float = 1.0,
    info: NewtonInfo | None = None,
    definite_start: bool = False,
    provisional: bool = False,
) -> tuple[np.ndarray, NewtonInfo]:
    """Continue from (x, lam0) through each load factor in ``targets`` (increasing or not).

    ``provisional``: each Newton stops once the next correction is forecast below XTOL, without
    the evaluation that would confirm it (see :func:`newton`'s ``accept``): a load step short of
    the last target is only the next one's start, and the last one's is left to the caller to
    confirm (``info.confirmed`` False; :meth:`cantilever.Equilibrium.confirmed`).

    ``definite_start``: the first step is halved (before any Newton) until the tangent at the
    start x is positive definite at its load (see :func:`definite_step`).
    """
    info = info or NewtonInfo()
    budget = max(MIN_ITERATIONS, int(WORK_BUDGET / max(x.size, 1)))
    lam, step, probe = lam0, first_step, None
    if definite_start and len(targets):
        step, probe = _definite_step(system, x, lam0, targets[0], step, MIN_STEP)
    slope: np.ndarray | None = None  # dx/dlam at the last converged state (tangent predictor)
    for target in targets:
        while lam != target:
            direction = 1.0 if target > lam else -1.0
            lam_try = target if abs(target - lam) <= step else lam + direction * step
            guess = x if slope is None else x + slope * (lam_try - lam)
            first = probe[1:] if probe is not None and probe[0] == lam_try and slope is None else None
            probe = None  # the probe was at the start: only the first attempt may use it
            accept = XTOL if provisional else 0.0
            info.confirmed, info.last = True, float("inf")
            try:
                x_new, its, lu = newton(system, guess, lam_try, first=first, accept=accept, info=info)
                check_admissible(system, x_new, lam_try, lu)
            except RoundoffStagnation as exc:
                raise ConvergenceError(str(exc), load_factor=lam) from exc
            except NewtonFailure as exc:
                info.rejected += 1
                step *= 0.5
                if step < MIN_STEP:
                    raise ConvergenceError(
                        f"Newton failed at load factor {lam_try:.6g} ({exc})", load_factor=lam
                    ) from exc
                continue
            info.iterations += its
            info.steps += 1
            info.lu = lu
            if info.iterations > budget:
                raise ConvergenceError(
                    f"continuation gave up after {info.iterations} Newton iterations in {info.steps} "
                    f"load steps (steps down to {step:.2g}): too little progress for the effort",
                    load_factor=lam_try,
                )
            lam, x = lam_try, x_new
            # the next step's first mixed tangent starts from these stresses
            getattr(system, "hold_stress", lambda: None)()
            slope = tangent(system, x, lam, lu) if lam != targets[-1] else None
            effort = its + (not info.confirmed)  # a skipped confirmation counts: the same steps
            if effort <= 2 * FAST:  # grow with the observed effort: x2 when easy, x1.5 when moderate
                step = min((2.0 if effort <= FAST else 1.5) * step, MAX_LOAD_STEP)
    return x, info
