"""Many scenes at once (contract section 13): ``solve_many(scenes)`` -> one Solution per scene.

Planar cantilever scenes that share a mesh (the same breaks and element count) are solved as one
stack (:mod:`matid.rod.batch`) through the error estimate's meshes of
:func:`matid.rod.accuracy.refine`: each scene leaves the doubling when its own estimate meets its
tolerance, every finer mesh starts from the coarser state (Newton at the full load; the
continuation from the straight rod where that fails), as :func:`matid.rod.api.solve` does for one.
Any other scene (full model, three-point bend, ``[aim]``, a term the stack does not evaluate) runs
alone through :func:`matid.rod.api.solve`. A scene that fails is a :class:`Failure` with its
reason; never a non-converged state.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from matid.errors import MatidError
from matid.rod import accuracy
from matid.rod import batch as B
from matid.rod.api import solve
from matid.rod.cantilever import INTORDER, Equilibrium, Solution, _prepare, interpolate_p2, mesh
from matid.rod.checks import strain_warnings
from matid.rod.models import PLANAR
from matid.rod.newton import NewtonInfo
from matid.rod.scenes import Scene
from matid.rod.system import term_labels


@dataclass(frozen=True)
class Failure:
    """A scene that has no answer: its reason (``converged`` is False, contract section 13)."""

    scene: Scene
    reason: str
    converged: bool = False


def solve_many(scenes, *, elements: int | None = None) -> list[Solution | Failure]:
    """One :class:`Solution` (or :class:`Failure`) per scene, in order (see the module docstring)."""
    scenes = list(scenes)
    out: list = [None] * len(scenes)
    groups: dict = {}
    for i, scene in enumerate(scenes):
        key, prepared = _stack_key(scene, elements)
        if key is None:
            out[i] = _alone(scene, elements)
        else:
            groups.setdefault(key, []).append((i, prepared))
    for (at, fixed), members in groups.items():
        ids = [i for i, _ in members]
        solved = _solve_group([scenes[i] for i in ids], [p for _, p in members], at, fixed)
        for i, result in zip(ids, solved, strict=True):
            out[i] = result
    return out


def _alone(scene: Scene, elements: int | None):
    try:
        return solve(scene, elements=elements)
    except MatidError as exc:
        return Failure(scene, str(exc))


def _stack_key(scene: Scene, elements: int | None) -> tuple:
    """((mesh breaks, fixed element count or None), its _prepare) of a scene the stack solves,
    else (None, None)."""
    if not isinstance(scene, Scene) or scene.kind != "cantilever" or scene.aim is not None:
        return None, None
    fixed = elements or scene.elements
    if fixed == 1:  # a single element is estimated against two: runs alone
        return None, None
    try:
        prepared = _prepare(scene, "auto")
    except ValueError:
        return None, None
    if prepared[0] != PLANAR or not B.stackable(prepared[3]):
        return None, None
    return (prepared[4], fixed), prepared


def _solve_group(scenes: list[Scene], prepared: list, at: tuple, fixed: int | None) -> list:
    """The scenes of one mesh family through the doubling meshes (accuracy.refine, per scene)."""
    N = len(scenes)
    results: list = [None] * N
    tips: list[list] = [[] for _ in range(N)]
    history: list[list] = [[] for _ in range(N)]
    levels = ([max(fixed // 2, 1), fixed] if fixed > 1 else [1, 2]) if fixed else None
    n = levels[0] if levels else accuracy.START // 2
    live, last = list(range(N)), None
    while live:
        t0 = time.perf_counter()
        eqs = _level([scenes[i] for i in live], [prepared[i] for i in live], n, at, last)
        share = (time.perf_counter() - t0) / len(live)
        keep = []
        for i, eq in zip(live, eqs, strict=True):
            if isinstance(eq, Failure):
                results[i] = eq
                continue
            tips[i].append(eq.tip())
            history[i].append((n, share))
            done = _finished(scenes[i], tips[i], n, levels)
            if done is None:
                keep.append((i, eq))
            else:
                results[i] = _present(eq, prepared[i][2], done, history[i], fixed)
        live = [i for i, _ in keep]
        last = [eq for _, eq in keep]
        n = levels[1] if levels else 2 * n
    return results


def _finished(scene: Scene, tips: list, n: int, levels) -> tuple | None:
    """(error, order) once this mesh is the answer, else None (accuracy.refine's rule)."""
    if len(tips) < 2:
        return None
    error, order = accuracy.richardson(tips)
    if levels:
        return error, order
    if error <= scene.tolerance or 2 * n > accuracy.MAX_ELEMENTS:
        return error, order
    return None


def _present(eq: Equilibrium, rod, done: tuple, history: list, fixed) -> Solution:
    """The Solution of api.solve: the estimate, the strain warnings."""
    error, order = done
    estimate = {
        "method": "richardson",
        "order": order,
        "meshes": [n for n, _ in history],
        "total_runtime_s": sum(t for _, t in history),
        "tolerance": None if fixed else eq.scene.tolerance,
    }
    extra = {"error_estimate": estimate, "warnings": strain_warnings(eq, rod)}
    return eq.solution(discretization_error=error, extra=extra)


def _level(scenes, prepared, n: int, at: tuple, coarse: list | None) -> list:
    """Equilibria (or Failures) of the scenes on the mesh of n elements, one stack."""
    t0 = time.perf_counter()
    disc = mesh(n, at, 3, "P2", INTORDER["P2"])
    stack = B.Stack(disc, [(p[2], p[3]) for p in prepared])
    N = len(scenes)
    X, info, stress = np.zeros((N, stack.n)), np.zeros((N, 3), int), None
    todo = np.arange(N)
    if coarse is not None:  # Newton at the full load from the coarser state
        X0 = stack.reference()
        vals = np.stack([eq.U[eq.disc.value_dofs] for eq in coarse])  # (N, m, 3)
        m = vals.shape[1]
        U0 = interpolate_p2(coarse[0].disc.vertices, vals.transpose(1, 0, 2).reshape(m, -1), disc.s_dof)
        X0 = U0.reshape(disc.nscalar, N, 3).transpose(1, 0, 2).reshape(N, -1)[:, disc.free]
        S0 = np.stack([_stress(eq, disc) for eq in coarse])
        Xw, k, pd, sw, why = B.newton(stack, X0, np.ones(N), S0)
        ok = np.array([w is None for w in why])
        ok[ok] = B.admissible(stack.take(np.flatnonzero(ok)), Xw[ok], np.ones(int(ok.sum())), pd[ok])
        X[ok], info[ok, 0], info[ok, 1] = Xw[ok], k[ok], 1
        stress = np.full((N,) + sw.shape[1:], np.nan)
        stress[ok] = sw[ok]
        todo = np.flatnonzero(~ok)
    reasons: list = [None] * N
    if todo.size:
        sub = stack.take(todo)
        Xf, inf, sf, why = B.follow(sub, sub.reference())
        X[todo], info[todo] = Xf, inf
        if stress is None:
            stress = np.full((N,) + sf.shape[1:], np.nan)
        stress[todo] = sf
        for j, i in enumerate(todo):
            reasons[i] = why[j]
    runtime = (time.perf_counter() - t0) / N
    U = stack.expand(X)
    out = []
    for i, (scene, p) in enumerate(zip(scenes, prepared, strict=True)):
        if reasons[i] is not None:
            out.append(Failure(scene, reasons[i]))
            continue
        its, steps, rejected = (int(v) for v in info[i])
        terms = tuple(term_labels(PLANAR, p[2], p[3], p[2].kappa_ref_at(disc.s_quad)))
        nfo = NewtonInfo(iterations=its, steps=steps, rejected=rejected)
        U_i = U[i].reshape(disc.nscalar, 3)
        out.append(Equilibrium(scene, PLANAR, disc, U_i, p[1], nfo, runtime, terms, stress[i]))
    return out


def _stress(eq: Equilibrium, disc) -> np.ndarray:
    got = eq.stress_at(disc)
    return np.full(disc.s_quad.shape + (2,), np.nan) if got is None else got
