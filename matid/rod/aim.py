"""Aim: the field direction that turns the tip's d3 to a target (contract section 9, physics.md section 8).

Given the target t (unit, lab frame) and |B|, the unknown is the field direction b on the
unit sphere, charted around a centre c with p1, p2 orthonormal to it:

    b(u) = (c + u1 p1 + u2 p2) / |c + u1 p1 + u2 p2|,   r(u) = d3(L; |B| b(u)) - t,

three equations in two unknowns, solved in the least-squares sense (scipy's
``least_squares``, trust region of radius MAX_TURN/2 at first): r = 0 where t is reachable,
the closest direction reached where it is not. Each residual is a forward solve warm-started
from the state of the last accepted iterate; the Jacobian comes from the forward tangent K
at the converged state X:

    dX/dB_k = -K^-1 dR/dB_k,   dR/dB_k = R(X; B = e_k) - R(X; B = 0)   (R is linear in B),

one back-substitution per field component, then dd3/dB = dd3/dq_tip dq_tip/dB. The target is
approached by continuation along the great circle from the tip direction at b = t, in steps of
at most MAX_TURN, each stage started from the last field (and from its state: not solved again).

Where that misses, the CANDIDATES are solved cold, as one stacked system when the scene's terms
stack (:mod:`matid.rod.batch_full`: the full model's 7 x 7 blocks on the same chain, Newton and
continuation as the planar batch), each with its own answer and failure (the same tips, to 1e-10,
and the same failures as one by one: tests/rod/test_batch_full.py). Measured (16 elements, 26
candidates, 2 cores at load 11, best of 5 interleaved): stacked / one by one 0.77-1.58, about 1.0,
on four targets; the starts are 2-15 % of an aim. Not faster because the full model's iteration is
compute, not per-call overhead as the planar one's: a stacked iteration costs 0.6-0.7 ms per scene
at 20-26 scenes against 0.5-0.7 ms for RodSystem's (its 7 x 7 cyclic reduction ~0.26 ms per scene
against a LAPACK band Cholesky's ~0.03 ms), and after the first load step only the few candidates
near the unstable direction stay in the stack (at 1 T: 61 of 119 iterations with one scene left).
Kept: the same answers at the same cost, and the stack the issue asks [aim] to use (STACKED_STARTS =
False: one by one).

The trial points of the least-squares fit are not stacked: each is the trust-region step from the
last accepted one, warm-started from its state, so scipy's ``least_squares`` asks for them one at
a time (the Jacobian needs no forward solve: one back-substitution per field component).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from matid.errors import ConvergenceError
from matid.physics import kinematics as kin
from matid.physics.jet import Jet
from matid.rod import batch
from matid.rod.batch_full import FullStack, stackable
from matid.rod.cantilever import (
    INTORDER,
    Equilibrium,
    default_penalty,
    equilibrium,
    mesh,
    prepare_scene,
)
from matid.rod.models import FULL
from matid.rod.scenes import Scene
from matid.rod.system import RodSystem
from matid.rod.terms import Scale, loads_of

#: Largest turn of the target per continuation stage (rad).
MAX_TURN = 0.35
#: A target is reached when the tip is within this angle of it (rad); the contract asks 1e-4.
AIM_TOL = 1e-8
DEFAULT_ELEMENTS = 16
#: Wall-clock seconds an aim may search (docs/limits.md): then the closest direction reached so far is
#: the answer (a ConvergenceError naming it when it misses). Checked before each forward solve.
AIM_SECONDS = 15.0


class OutOfTime(Exception):
    """The aim's time is up (raised before a forward solve; caught by :func:`aim`)."""


@dataclass(frozen=True)
class AimResult:
    B: np.ndarray  # the field (T, lab frame)
    tip_direction: np.ndarray  # d3 at the tip it gives (on the aim's mesh)
    error_rad: float  # angle between that d3 and the target
    forward_solves: int
    runtime_s: float
    elements: int


def angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle between unit vectors, accurate near 0 and pi: 2 asin(|a - b|/2)."""
    return float(2.0 * np.arcsin(min(1.0, 0.5 * np.linalg.norm(np.asarray(a) - np.asarray(b)))))


def slerp(a: np.ndarray, b: np.ndarray, f: float) -> np.ndarray:
    """The unit vector a fraction f of the way from a to b along their great circle."""
    w = angle(a, b)
    if w < 1e-12:
        return np.asarray(b, float)
    if abs(np.pi - w) < 1e-9:  # antipodal: any great circle; one through a vector normal to a
        return np.cos(f * w) * np.asarray(a) + np.sin(f * w) * _basis(a)[0]
    out = (np.sin((1 - f) * w) * np.asarray(a) + np.sin(f * w) * np.asarray(b)) / np.sin(w)
    return out / np.linalg.norm(out)


def _basis(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors orthonormal to c."""
    p1 = np.cross(c, [1.0, 0.0, 0.0] if abs(c[0]) < 0.9 else [0.0, 1.0, 0.0])
    p1 /= np.linalg.norm(p1)
    return p1, np.cross(c, p1)


class Forward:
    """Forward solves of a scene at fields |B| b on one mesh, each warm-started from the last."""

    def __init__(self, scene: Scene, elements: int, deadline: float = np.inf):
        self.scene, self.elements, self.solves, self.deadline = scene, elements, 0, deadline
        self.last: Equilibrium | None = None
        self.target = np.asarray(scene.aim.tip_direction) if scene.aim else None
        #: (error, field direction, tip d3) of the forward solve closest to the target so far
        self.best: tuple = (np.inf, np.full(3, np.nan), np.full(3, np.nan))

    def at(self, B: np.ndarray) -> Equilibrium:
        if time.perf_counter() > self.deadline:
            raise OutOfTime
        self.last = equilibrium(self._in(B), elements=self.elements, model=FULL, start=self.last)
        self._solved(B, self.last.tip()[3:])
        return self.last

    def _solved(self, B: np.ndarray, d3: np.ndarray) -> None:
        """Counts a converged forward solve at B and keeps it as :attr:`best` when its tip d3 is the
        closest to the target so far."""
        self.solves += 1
        if self.target is not None:
            error = angle(d3, self.target)
            if error < self.best[0]:
                self.best = (error, _unit(B), d3)

    def cold_tips(self, fields: list[np.ndarray]) -> list[np.ndarray | None] | None:
        """The tip d3 of a cold forward solve at each field (None where it fails), all as one stacked
        system (:mod:`matid.rod.batch_full`); None when the scene's terms do not stack."""
        if time.perf_counter() > self.deadline:
            raise OutOfTime
        _, _, _, loads, at = prepare_scene(self._in(fields[0]), FULL)
        if not stackable(loads):
            return None
        scenes = [self._in(B) for B in fields]
        parts = [prepare_scene(scene, FULL)[2:4] for scene in scenes]
        disc = mesh(self.elements, at, 7, "P2", INTORDER["P2"])
        stack = FullStack(disc, parts)
        X, _, _, reasons = batch.follow(stack, stack.reference())
        U = stack.expand(X).reshape(len(fields), disc.nscalar, 7)
        tip = disc.vertex_dof(disc.vertices.size - 1)
        tips = []
        for B, row, reason in zip(fields, U[:, tip], reasons, strict=True):
            d3 = None if reason is not None else np.array(kin.d3(row[3:].tolist()))  # Equilibrium.tip
            if d3 is not None:
                self._solved(B, d3)
            tips.append(d3)
        return tips

    def _in(self, B: np.ndarray) -> Scene:
        """The scene in the field B, without its [aim]."""
        loads = dataclasses.replace(self.scene.loads, B=tuple(B))
        return dataclasses.replace(self.scene, loads=loads, aim=None)

    def sensitivity(self, eq: Equilibrium) -> np.ndarray:
        """dd3(L)/dB (3 x 3) at a converged state, from its tangent (module docstring)."""
        _, _, rod, loads, _ = prepare_scene(eq.scene, FULL)
        c_u = default_penalty(rod, kin.NORMALISED)

        scale = Scale(eq.scene.rod.length, eq.scene.rod.E_b, None)

        def field(B) -> RodSystem:  # the system with the loads of the field B (only they bound anew)
            in_field = dataclasses.replace(eq.scene, loads=dataclasses.replace(eq.scene.loads, B=B))
            return system.with_loads(loads_of(in_field, scale))

        system = RodSystem(eq.disc, rod, loads, model=FULL, c_u=c_u, banded=True)
        X = system.reduce(eq.U.ravel())
        factor = system.evaluate(X, 1.0)[1].factor()
        R0 = field((0.0, 0.0, 0.0)).evaluate(X, 1.0, tangent=False)[0]
        dX = [factor.solve(-(field(tuple(e)).evaluate(X, 1.0, tangent=False)[0] - R0)) for e in np.eye(3)]
        nf, tip = eq.disc.nf, system.tip
        dofs = system.index[np.arange(tip * nf + 3, tip * nf + 7)]
        d3 = kin.d3(Jet.variables(eq.U[tip, 3:].reshape(4, 1), hessian=False))
        dd3_dq = np.array([c.g[0] for c in d3])  # (3, 4)
        return dd3_dq @ np.array([dx[dofs] for dx in dX]).T


def aim(scene: Scene, *, elements: int | None = None, seconds: float = AIM_SECONDS) -> AimResult:
    """The field of magnitude scene.aim.field_magnitude turning the tip's d3 closest to the target.

    The continuation starts from the field along the target; when that misses, from the
    START_TRIES fields among the CANDIDATES (26 directions of a cube's faces, edges and
    corners) that put the tip nearest to the target. Raises ConvergenceError when the closest
    direction reached misses the target by more than AIM_TOL (naming it and the field), also when
    the search stops after ``seconds`` (checked before each forward solve) with the closest
    direction any forward solve reached.
    """
    t0 = time.perf_counter()
    target, magnitude = np.asarray(scene.aim.tip_direction), scene.aim.field_magnitude
    n = elements or scene.elements or DEFAULT_ELEMENTS
    forward = Forward(scene, n, deadline=t0 + seconds)
    stopped = ""
    try:
        best = _search(forward, target, magnitude)
    except OutOfTime:
        best = forward.best
        stopped = f"; stopped after {time.perf_counter() - t0:.0f} s (matid.rod.aim.AIM_SECONDS)"
    error, b, d3 = best
    result = AimResult(magnitude * b, d3, error, forward.solves, time.perf_counter() - t0, n)
    if not error <= AIM_TOL:
        reached = (
            f"the closest direction reached is d3 = {_fmt(d3)}, {np.degrees(error):.4g} deg off, with B = "
            f"{_fmt(result.B)} T" if np.isfinite(error) else "no forward solve converged"
        )
        raise ConvergenceError(
            f"[aim]: no field of {magnitude:.6g} T found turning the tip to {_fmt(target)}: {reached} "
            f"({forward.solves} forward solves{stopped})",
            closest=result,
        )
    return result


def _search(forward: Forward, target: np.ndarray, magnitude: float) -> tuple:
    """(error, field direction, tip d3): from the field along the target, then from the nearest starts."""
    best = _continue(forward, target, magnitude, target)
    if best[0] > AIM_TOL:
        for b in _nearest_starts(forward, target, magnitude)[:START_TRIES]:
            best = min(best, _continue(forward, b, magnitude, target), key=lambda r: r[0])
            if best[0] <= AIM_TOL:
                break
    return best


#: Field directions tried when the field along the target is no start: a cube's 26 directions.
_CUBE = np.array([v for v in np.ndindex(3, 3, 3) if v != (1, 1, 1)], float) - 1.0
CANDIDATES = list(_CUBE / np.linalg.norm(_CUBE, axis=1, keepdims=True))
START_TRIES = 3
#: Solve the CANDIDATES as one stacked system (module docstring: measured)
STACKED_STARTS = True


#: Digits (rad) of a start's angle to the target that order the starts; closer is a tie.
TIE_DIGITS = 9


def _nearest_starts(forward: Forward, target: np.ndarray, magnitude: float) -> list[np.ndarray]:
    """The CANDIDATES sorted by the angle of their tip to the target (cold solves; failures left out):
    one stacked solve (:func:`Forward.cold_tips`) when the scene's terms stack, else one by one."""
    tips = forward.cold_tips([magnitude * b for b in CANDIDATES]) if STACKED_STARTS else None
    if tips is None:
        tips = []
        for b in CANDIDATES:
            forward.last = None
            try:
                tips.append(forward.at(magnitude * b).tip()[3:])
            except ConvergenceError:
                tips.append(None)
    # angles equal to 1e-9 rad (candidates symmetric about the target) keep the CANDIDATES' order:
    # sorted by the last bits, the stacked and the one-by-one solves ordered them apart (lowest pins)
    scored = [(round(angle(d3, target), TIE_DIGITS), i) for i, d3 in enumerate(tips) if d3 is not None]
    return [np.array(CANDIDATES[i]) for _, i in sorted(scored)]


def _continue(forward: Forward, b: np.ndarray, magnitude: float, target: np.ndarray) -> tuple:
    """(error, field direction, tip d3): continuation from the field b along the great circle from
    its tip direction to the target, then the fit to the target itself where a stage misses."""
    forward.last = None
    try:
        eq = forward.at(magnitude * b)
    except ConvergenceError:
        return (np.inf, b, np.full(3, np.nan))
    start = d3 = eq.tip()[3:]
    stages = max(1, int(np.ceil(angle(start, target) / MAX_TURN)))
    try:
        for k in range(1, stages + 1):
            goal = slerp(start, target, k / stages)
            b, d3, eq = _stage(forward, b, magnitude, goal, eq)
            if angle(d3, goal) > AIM_TOL:
                b, d3, eq = _stage(forward, b, magnitude, target, eq)  # the closest to the target itself
                break
    except ConvergenceError:  # no equilibrium at a stage's trial points: the last stage's field stands
        pass
    return (angle(d3, target), b, d3)


def _stage(
    forward: Forward, b: np.ndarray, magnitude: float, goal: np.ndarray, start: Equilibrium
) -> tuple[np.ndarray, np.ndarray, Equilibrium]:
    """(field direction, tip d3, state) of the least-squares fit of the tip to ``goal``, charted at b;
    ``start``: the state at b (the last stage's answer: not solved again)."""
    p1, p2 = _basis(b)
    states: dict[bytes, Equilibrium] = {np.zeros(2).tobytes(): start}

    def direction(u: np.ndarray) -> tuple[np.ndarray, float]:
        v = b + u[0] * p1 + u[1] * p2
        return v / np.linalg.norm(v), float(np.linalg.norm(v))

    def state(u: np.ndarray) -> Equilibrium:
        key = np.asarray(u, float).tobytes()
        if key not in states:
            states[key] = forward.at(magnitude * direction(u)[0])
        return states[key]

    def residual(u: np.ndarray) -> np.ndarray:
        try:
            return state(u).tip()[3:] - goal
        except ConvergenceError:  # no equilibrium there: worse than any |d3 - goal| <= 2, so the
            return np.full(3, 2.0)  # trust region shrinks back towards the last state

    def jacobian(u: np.ndarray) -> np.ndarray:
        forward.last = state(u)  # an accepted iterate: the next trial starts from its state
        bu, norm = direction(u)
        db = np.column_stack([(p - bu * (bu @ p)) / norm for p in (p1, p2)])  # (3, 2)
        return forward.sensitivity(state(u)) @ (magnitude * db)

    fit = least_squares(
        residual, np.zeros(2), jac=jacobian, x_scale=0.5 * MAX_TURN, xtol=1e-13, ftol=1e-13, gtol=1e-13
    )
    bu = direction(fit.x)[0]
    return bu, state(fit.x).tip()[3:], state(fit.x)


def _unit(v) -> np.ndarray:
    """``v`` normalised without overflow or underflow (a field of 1e-300 T has a direction too)."""
    v = np.asarray(v, float)
    v = v / np.abs(v).max()
    return v / np.linalg.norm(v)


def _fmt(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{c:.6g}" for c in np.asarray(v, float)) + ")"
