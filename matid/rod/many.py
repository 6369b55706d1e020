"""Many scenes at once (contract section 13): ``solve_many(scenes)`` -> one Solution per scene.

Planar cantilever scenes that share a mesh (the same breaks and element count) are solved as one
stack (:mod:`matid.rod.batch`) through the error estimate's meshes of
:func:`matid.rod.accuracy.refine`: each scene leaves the doubling when its own estimate meets its
tolerance, every finer mesh starts from the coarser state (Newton at the full load; the
continuation from the straight rod where that fails), and the first from the rod turned into a
field beyond buckling or by a dead tip force where that applies (:mod:`matid.rod.aligned`), as
:func:`matid.rod.api.solve` does for one.
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
from matid.rod.aligned import turned
from matid.rod.api import solve
from matid.rod.cantilever import (
    INTORDER,
    Equilibrium,
    Solution,
    mesh,
    prepare_scene,
    probe_start,
)
from matid.rod.checks import planar_point_strains, strain_warnings
from matid.rod.models import PLANAR
from matid.rod.newton import NewtonInfo
from matid.rod.scenes import Scene
from matid.rod.system import term_labels
from matid.rod.transfer import interpolate_p2, stress_recovery


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
    """((mesh breaks, fixed element count or None), its prepare_scene) of a scene the stack solves,
    else (None, None)."""
    if not isinstance(scene, Scene) or scene.kind != "cantilever" or scene.aim is not None:
        return None, None
    fixed = elements or scene.elements
    if fixed == 1:  # a single element is estimated against two: runs alone
        return None, None
    try:
        prepared = prepare_scene(scene, "auto")
    except ValueError:
        return None, None
    if prepared[0] != PLANAR or not B.stackable(prepared[3]):
        return None, None
    return (prepared[4], fixed), prepared


def _solve_group(scenes: list[Scene], prepared: list, at: tuple, fixed: int | None) -> list:
    """The scenes of one mesh family through the doubling meshes (accuracy.refine, per scene); the
    state of the scenes still refining stays stacked from one mesh to the next."""
    N = len(scenes)
    results: list = [None] * N
    tips: list[list] = [[] for _ in range(N)]
    history: list[list] = [[] for _ in range(N)]
    levels = ([max(fixed // 2, 1), fixed] if fixed > 1 else [1, 2]) if fixed else None
    n = levels[0] if levels else accuracy.START // 2
    live, last = np.arange(N), None
    plane = np.array([p[1][:2] for p in prepared])  # (a0, a1) of each scene's plane
    probe = np.array([probe_start(p[2], p[3], PLANAR) for p in prepared], bool)
    while live.size:
        t0 = time.perf_counter()
        level = _level([prepared[i] for i in live], n, at, last, probe[live])
        share = (time.perf_counter() - t0) / live.size
        tip = _tips(level, plane[live])
        keep, finished = [], []
        for j, i in enumerate(live):
            if level.reasons[j] is not None:
                results[i] = Failure(scenes[i], level.reasons[j])
                continue
            tips[i].append(tip[j])
            history[i].append((n, share))
            done = _finished(scenes[i], tips[i], n, levels)
            if done is None:
                keep.append(j)
            else:
                finished.append((j, done))
        ids = np.array([j for j, _ in finished], int)
        ref = np.stack([_precurvature(prepared[live[j]][2], level.disc) for j in ids]) if ids.size else None
        shear, bend = planar_point_strains(level.disc, level.U[ids], ref) if ids.size else (None, None)
        for k, (j, done) in enumerate(finished):
            i = live[j]
            eq = level.equilibrium(j, scenes[i], prepared[i])
            strains = (level.disc.s_quad, shear[k], bend[k])
            results[i] = _present(eq, prepared[i][2], done, history[i], fixed, strains)
        live, last = live[keep], level.take(np.array(keep, int))
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


def _precurvature(rod, disc) -> np.ndarray:
    """The rod's precurvature about the plane normal at the mesh's points (ne, nq)."""
    ref = rod.kappa_ref_at(disc.s_quad)
    return np.full(disc.s_quad.shape, float(rod.kappa_ref[1])) if ref is None else ref[..., 1]


def _present(eq: Equilibrium, rod, done: tuple, history: list, fixed, strains) -> Solution:
    """The Solution of api.solve: the estimate, the strain warnings."""
    error, order = done
    estimate = {
        "method": "richardson",
        "order": order,
        "meshes": [n for n, _ in history],
        "total_runtime_s": sum(t for _, t in history),
        "tolerance": None if fixed else eq.scene.tolerance,
    }
    extra = {"error_estimate": estimate, "warnings": strain_warnings(eq, rod, strains)}
    return eq.solution(discretization_error=error, extra=extra)


@dataclass
class Level:
    """The stacked answers of one mesh: states U (N, nscalar 3), Newton (iterations, steps,
    rejected) per scene, converged point stresses, failure reasons (None: converged)."""

    disc: object
    U: np.ndarray
    info: np.ndarray
    stress: np.ndarray
    reasons: list
    runtime: float

    def take(self, ids: np.ndarray) -> Level:
        reasons = [self.reasons[i] for i in ids]
        return Level(self.disc, self.U[ids], self.info[ids], self.stress[ids], reasons, 0.0)

    def equilibrium(self, j: int, scene: Scene, p: tuple) -> Equilibrium:
        disc = self.disc
        terms = tuple(term_labels(PLANAR, p[2], p[3], p[2].kappa_ref_at(disc.s_quad)))
        its, steps, rejected = (int(v) for v in self.info[j])
        nfo = NewtonInfo(iterations=its, steps=steps, rejected=rejected)
        U = self.U[j].reshape(disc.nscalar, 3)
        return Equilibrium(scene, PLANAR, disc, U, p[1], nfo, self.runtime, terms, self.stress[j])


def _tips(level: Level, plane: np.ndarray) -> np.ndarray:
    """Equilibrium.tip of every scene: (tip position / L, tip d3), (N, 6)."""
    d = level.disc
    k = d.vertex_dof(d.vertices.size - 1) * 3
    x, z, th = (level.U[:, k + i] for i in range(3))
    a0, a1, s = plane[:, 0], plane[:, 1], np.sin(th)
    return np.stack([x * a0, x * a1, z, a0 * s, a1 * s, np.cos(th)], axis=1)


def _level(prepared, n: int, at: tuple, coarse: Level | None, probe: np.ndarray) -> Level:
    """The scenes on the mesh of n elements, one stack: Newton at the full load from the coarser
    mesh's states, or on the first mesh from a cold start where a scene has one (rod.aligned); the
    continuation from the straight rod where that fails or there is none."""
    t0 = time.perf_counter()
    disc = mesh(n, at, 3, "P2", INTORDER["P2"])
    stack = B.Stack(disc, [(p[2], p[3]) for p in prepared], probe)
    N = len(prepared)
    X, info, stress = np.zeros((N, stack.n)), np.zeros((N, 3), int), None
    todo = tried = np.arange(N)
    if coarse is not None:  # Newton at the full load from the coarser state
        cd = coarse.disc
        vals = coarse.U.reshape(N, cd.nscalar, 3)[:, cd.value_dofs]  # (N, m, 3)
        m = vals.shape[1]
        U0 = interpolate_p2(cd.vertices, vals.transpose(1, 0, 2).reshape(m, -1), disc.s_dof)
        X0 = U0.reshape(disc.nscalar, N, 3).transpose(1, 0, 2).reshape(N, -1)[:, disc.free]
        S0 = _stresses(coarse, disc)
    else:  # the cold starts of cantilever.equilibrium (rod.starts) the stack has: rod.aligned
        cold = [turned(PLANAR, p[2], p[3], disc) for p in prepared]
        tried = np.array([i for i, c in enumerate(cold) if c is not None], int)
        X0 = np.array([cold[i][0].ravel()[disc.free] for i in tried]).reshape(tried.size, stack.n)
        S0 = np.array([cold[i][1] for i in tried]).reshape((tried.size,) + disc.s_quad.shape + (2,))
    if tried.size:
        sub = stack if tried.size == N else stack.take(tried)
        Xw, k, pd, sw, why, _ = B.newton(sub, X0, np.ones(tried.size), S0)
        ok = np.array([w is None for w in why])
        ok[ok] = B.admissible(sub.take(np.flatnonzero(ok)), Xw[ok], np.ones(int(ok.sum())), pd[ok])
        done = tried[ok]
        X[done], info[done, 0], info[done, 1] = Xw[ok], k[ok], 1
        stress = np.full((N,) + sw.shape[1:], np.nan)
        stress[done] = sw[ok]
        todo = np.setdiff1d(np.arange(N), done)
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
    return Level(disc, stack.expand(X), info, stress, reasons, (time.perf_counter() - t0) / N)


def _stresses(coarse: Level, disc) -> np.ndarray:
    """Equilibrium.stress_at of every scene: the coarse point stresses recovered at disc's points."""
    cd = coarse.disc
    R = stress_recovery(cd.vertices.tobytes(), cd.s_quad.tobytes(), disc.s_quad.tobytes())
    N, ns = coarse.stress.shape[0], coarse.stress.shape[-1]
    flat = coarse.stress.reshape(N, -1, ns).transpose(1, 0, 2).reshape(-1, N * ns)
    return (R @ flat).reshape(-1, N, ns).transpose(1, 0, 2).reshape((N,) + disc.s_quad.shape + (ns,))
