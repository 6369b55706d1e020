"""Solve a scene: scale, pick the model, continue the load, map back to SI.

Cantilever scenes run the planar model (x, z, theta) when :func:`plane_of`
finds a plane holding every load, the full model (r, q) otherwise; the
three-point bend is planar by construction (:mod:`matid.physics.contact`).
Positions and directors come back in the lab frame and in metres.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from matid.physics import kinematics as kin
from matid.rod.contact_rounds import carry, report, reset, settle
from matid.rod.fem import Discretisation, graded_vertices
from matid.rod.models import FULL, PLANAR, ScaledRod, Segment, lab_frames
from matid.rod.newton import (
    XTOL,
    NewtonFailure,
    NewtonInfo,
    check_admissible,
    confirm_by_residual,
    follow,
    newton,
)
from matid.rod.scenes import Scene, plane_of
from matid.rod.starts import cold_start
from matid.rod.system import RodSystem
from matid.rod.terms import Scale, Term, loads_of
from matid.rod.terms.contact import contact_of
from matid.rod.transfer import interpolate_warm, stress_recovery

#: A rigid segment: bending and twist RIGID_FACTOR times the rod's, shear and
#: extension at least RIGID_FACTOR (scaled by E_b/L^2). Its share of the rod's
#: compliance (bending, O(1) scaled) is then ~1e-6, far below the
#: discretisation error, and it never widens the stiffness spread beyond
#: max(RIGID_FACTOR, the rod's own E_s, E_e) - which sets Newton's round-off
#: floor. (Multiplying every term by 1e6 x the stiffest gave 1e14 on a slender
#: rod: Newton then took corrections of 0.1 for round-off - found by matid bench.)
RIGID_FACTOR = 1e6
#: Quadrature order per element: 2 = two-point Gauss. Measured (bench): P2 with the
#: three-point rule locks on slender rods, with two-point Gauss it does not. The cubic
#: Hermite needs three points (two leave its tangent singular: no solve converges).
INTORDER = {"P2": 2, "P1": 2, "Hermite": 4}
DEFAULT_ELEMENTS = 16


@dataclass(frozen=True)
class Solution:
    """Static equilibrium of a scene, SI, lab frame (docs/contract.md section 6)."""

    scene: Scene
    model: str
    elements: int
    element: str
    newton_iterations: int
    load_steps: int
    runtime_s: float
    s: np.ndarray
    position: np.ndarray  # (n, 3)
    d1: np.ndarray
    d3: np.ndarray
    terms: tuple[str, ...] = ()
    three_point_bend: dict | None = None
    discretization_error: float | None = None
    extra: dict = field(default_factory=dict, hash=False)
    converged: bool = True  # a Solution only exists converged; kept for the JSON contract

    @property
    def tip(self) -> dict:
        return {key: getattr(self, key)[-1].tolist() for key in ("position", "d1", "d3")}


def scaled(scene: Scene, e_a: np.ndarray | None) -> tuple[ScaledRod, tuple[Term, ...]]:
    """The scene's rod and the terms of its loads in scaled units; projected onto the plane when
    e_a is given."""
    scale = Scale(scene.rod.length, scene.rod.E_b, e_a)
    return scaled_rod(scene.rod, scale), loads_of(scene, scale)


def scaled_rod(rod, scale: Scale) -> ScaledRod:
    """The rod's stiffnesses (relative to E_b at the clamp), segments and precurvature, scaled."""
    L, Eb = rod.length, rod.E_b
    base = {"E_b": 1.0, "E_t": rod.E_t / Eb, "E_s": rod.E_s * L**2 / Eb, "E_e": rod.E_e * L**2 / Eb}
    segments = []
    for seg in rod.segments:
        scaled = dict(base)
        for k, v in seg.overrides.items():
            if k in scaled:
                scaled[k] = v / Eb * (1.0 if k in ("E_b", "E_t") else L**2)
        if seg.rigid:  # bending and twist RIGID_FACTOR times, shear and extension at least RIGID_FACTOR
            scaled = {
                k: RIGID_FACTOR * v if k in ("E_b", "E_t") else max(v, RIGID_FACTOR)
                for k, v in scaled.items()
            }
        kappa = None if seg.precurvature is None else scale.moment(seg.precurvature, L)
        segments.append(Segment(seg.start / L, seg.end / L, **scaled, kappa_ref=kappa))
    return ScaledRod(
        **{k: base[k] for k in ("E_t", "E_s", "E_e")},
        segments=tuple(segments),
        kappa_ref=scale.moment(rod.precurvature, L),
    )


def default_penalty(rod: ScaledRod, variant: str) -> float:
    """c_u (scaled) of the unity penalty when none is given.

    Normalised variant: the penalty only holds the nodal |q| (matid.rod.terms.gauge);
    measured on the q = 6.4 magnetic cantilever (16 elements), Newton needs the fewest
    steps at c_u ~ sqrt(stiffest scaled term): E = 1e4 -> 4 steps at c_u = 1e2 (8 at 1),
    E = 1e8 -> 16 at 1e4 (36 at 1, 115 at 1e8). Raw variant (the paper's): the
    penalty error is ~1/c_u, so it must be large: 1e6 by default (see matid bench).
    """
    if variant == kin.RAW:
        return 1e6
    stiffest = max([1.0, rod.E_t, rod.E_s, rod.E_e] + [max(s.E_s, s.E_e) for s in rod.segments])
    return float(np.sqrt(stiffest))


def breaks(scene: Scene) -> tuple[float, ...]:
    """Scaled arc lengths where the mesh needs a vertex (segment ends, magnets, magnetisation ends)."""
    L = scene.rod.length
    points = [p for seg in scene.rod.segments for p in (seg.start, seg.end)]
    points += [at for at, _ in scene.loads.magnets]
    points += [p for a, b, _ in scene.loads.magnetization for p in (a, b)]
    points += [at for at, _, _ in scene.loads.point_loads]
    return tuple(sorted({p / L for p in points}))


def solve_cantilever(scene: Scene, **options) -> Solution:
    """Static equilibrium of a clamped rod (raises ConvergenceError, never returns a failed state);
    ``options`` are those of :func:`equilibrium`."""
    return equilibrium(scene, **options).solution()


def equilibrium(
    scene: Scene,
    *,
    elements: int | None = None,
    model: str = "auto",
    variant: str = kin.NORMALISED,
    c_u: float | None = None,
    element: str = "P2",
    intorder: int | None = None,
    start: tuple[np.ndarray, np.ndarray] | None = None,
    contact_at: tuple[float, ...] = (),
    confirm: bool = True,
) -> Equilibrium:
    """The converged scaled state of a cantilever (raises ConvergenceError, never returns a failed state).

    ``start``: a state of the same scene on another mesh (P2, :meth:`Equilibrium.state`).
    Newton runs at the full load from its interpolant (measured: 3-6 iterations from the
    half mesh); the load continuation from the straight rod is the fallback when that fails.
    Without ``start``, Newton at the full load from the scene's cold start first (rod.starts).
    ``contact_at``: scaled arc lengths of interior contact points, mesh vertices too (issue 31).
    ``confirm=False`` (a mesh of the error estimate that may be no answer; not with walls): Newton
    may stop once its quadratic model forecasts the next correction below XTOL, and the confirming
    evaluation waits for :meth:`Equilibrium.confirmed` (one per mesh saved on the coarser meshes).
    """
    t0 = time.perf_counter()
    again = dict(elements=elements, model=model, variant=variant, c_u=c_u, element=element)
    again.update(intorder=intorder, start=start, contact_at=contact_at)
    chosen, e_a, rod, loads, at = prepare_scene(scene, model)
    ne = elements or scene.elements or DEFAULT_ELEMENTS
    order = intorder or INTORDER[element]
    if contact_at:
        at = tuple(sorted(set(at) | {float(s) for s in contact_at}))
    disc = mesh(ne, at, 3 if chosen == PLANAR else 7, element, order)
    system = RodSystem(
        disc,
        rod,
        loads,
        model=chosen,
        variant=variant,
        c_u=c_u or default_penalty(rod, variant),
        banded=True,
        mixed=True,  # the mixed-integration-point Newton (RodSystem.mixed_update)
    )
    provisional, kinks = not confirm and contact_of(system) is None, None
    if isinstance(start, Equilibrium):
        system.stress_start = start.stress_at(disc)
        carry(system, start)  # the contact multipliers (contact_rounds)
        start, kinks = start.state(), start.kinks
    X = _warm(system, start, provisional, kinks) if start is not None and element == "P2" else None
    if X is None and start is None and element == "P2" and (cold := cold_start(system)) is not None:
        system.stress_start = cold[1]
        X = _full_load(system, cold[0], provisional)
    if X is None:
        system.stress_start = None  # the continuation starts from the straight rod
        reset(system)
        x0, probe = system.reduce(system.reference()), probe_start(rod, loads, chosen)
        X, info = follow(system, x0, [1.0], definite_start=probe, provisional=provisional)
    else:
        X, info = X
    X = settle(system, X, info)  # walls and lumen (contact_rounds)
    U = system.expand(X).reshape(disc.nscalar, disc.nf)
    runtime = time.perf_counter() - t0
    contact = report(system, X)
    pending = None if info.confirmed else (system, X, lambda: equilibrium(scene, **again))
    state = (U, e_a, info, runtime, tuple(system.terms), system.converged_stress(), contact, pending)
    return Equilibrium(scene, chosen, disc, *state)


def probe_start(rod: ScaledRod, loads: tuple[Term, ...], model: str) -> bool:
    """Whether the continuation's first step is tested for a stable start (newton.definite_step).

    Planar model: dead forces and moments have potentials linear in (x, z, theta) and the
    unloaded rod no stress, so only the field changes its tangent, by lam m B.d3 in each
    magnetised piece's theta-theta stiffness: nothing to test on a straight rod (d3 = e3)
    unless some m B_3 < 0. Not in 3D: a lumped tip magnet in a rigid body (bench stability,
    "3D, rigid magnet body") has an indefinite unloaded tangent at lam = 1e-3, yet Newton
    converges at lam = 0.125: the test would cost 10 halvings and 41 iterations, not 28.
    """
    magnetic = [term for term in loads if term.label == "magnetic"]
    if model != PLANAR or not magnetic:
        return False
    if any(rod.kappa_ref) or any(seg.kappa_ref is not None for seg in rod.segments):
        return True  # d3 turns along the unloaded rod: test
    return any(term.softens_straight_rod() for term in magnetic)


@dataclass(frozen=True)
class Equilibrium:
    """A converged cantilever in scaled units, before it is presented as a :class:`Solution`
    (the error estimate's coarser meshes only need the tip and the state)."""

    scene: Scene
    model: str
    disc: Discretisation
    U: np.ndarray  # (nscalar, nf) nodal values, scikit-fem order
    e_a: np.ndarray | None
    info: NewtonInfo
    runtime_s: float
    terms: tuple[str, ...]
    stress: np.ndarray | None = None  # C e(u) at the quadrature points (ne, nq, ns), mixed Newton
    contact: tuple | None = None  # contact_rounds.report (scaled); None: no walls
    pending: tuple | None = field(default=None, repr=False)  # (system, X, redo): not yet confirmed

    def confirmed(self) -> Equilibrium:
        """This state after Newton's confirming evaluation (``equilibrium(confirm=False)``): from its
        residual and the last factor (newton.confirm_by_residual) or a full iteration, the same
        test of convergence and the stability test as a confirmed solve; if it fails, the mesh is
        solved again confirmed (``redo``)."""
        if self.pending is None:
            return self
        t0, (system, X, redo) = time.perf_counter(), self.pending
        try:
            chord = confirm_by_residual(system, X, 1.0, self.info)
            if chord is not None:
                X, its, lu = chord, 1, self.info.lu
            else:
                system.stress_start = None  # the consistent tangent, as the iteration it stands for
                X, its, lu = newton(system, X, 1.0)
            check_admissible(system, X, 1.0, lu)
        except NewtonFailure:
            return redo()
        info = NewtonInfo(self.info.iterations + its, self.info.steps, self.info.rejected, lu)
        U, stress = system.expand(X).reshape(self.U.shape), system.converged_stress()
        runtime = self.runtime_s + time.perf_counter() - t0
        return replace(self, U=U, info=info, runtime_s=runtime, stress=stress, pending=None)

    def stress_at(self, disc: Discretisation) -> np.ndarray | None:
        """The point stresses recovered at another mesh's quadrature points: through the two Gauss
        points of the element of this mesh holding each point (where P2 stresses are accurate) and,
        without contact, the nearest of each neighbour not across a break (transfer.stress_recovery).
        Only the first Newton tangent of a warm start uses them (see equilibrium)."""
        if self.stress is None or self.disc.element != "P2" or self.stress.shape[1] != 2:
            return None
        meshes = (self.disc.vertices.tobytes(), self.disc.s_quad.tobytes(), disc.s_quad.tobytes())
        R = stress_recovery(*meshes, self.kinks)
        ns = self.stress.shape[-1]
        return (R @ self.stress.reshape(-1, ns)).reshape(disc.s_quad.shape + (ns,))

    @functools.cached_property
    def kinks(self) -> bytes | None:
        """Where this state's fields may kink: its scene's breaks (bytes), None with contact (its
        forces kink them anywhere) or without a scene (read by both transfers of a warm start)."""
        smooth = self.scene is not None and self.contact is None
        return np.asarray(breaks(self.scene), float).tobytes() if smooth else None

    def solution(self, **fields) -> Solution:
        """The state presented (SI, lab frame); ``fields``: further Solution fields (the estimate)."""
        L, disc, order = self.scene.rod.length, self.disc, self.disc.value_dofs
        position, d1, d3 = lab_frames(self.U[order], self.e_a, L)
        if not (np.isfinite(position).all() and np.isfinite(d1).all()):
            raise FloatingPointError("non-finite solution")  # unreachable: Newton rejects NaN
        return Solution(
            scene=self.scene,
            model=self.model,
            elements=disc.ne,
            element=disc.element,
            newton_iterations=self.info.iterations,
            load_steps=self.info.steps,
            runtime_s=self.runtime_s,
            s=disc.s_dof[order] * L,
            position=position,
            d1=d1,
            d3=d3,
            terms=self.terms,
            **fields,
        )

    def state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(vertices, nodal values sorted by s) for a warm start on another mesh (P2 only)."""
        if self.disc.element != "P2":
            return None
        return self.disc.vertices.copy(), self.U[self.disc.value_dofs]

    def quantities(self) -> np.ndarray:
        """What the error estimate follows: the tip, and with contact each boundary's resultant
        (relative to the largest component), its force-weighted s and the log of that largest
        component (its relative change: the ratios alone hid the forces' size, issue 31)."""
        if self.contact is None:
            return self.tip()
        q = self.contact[1].reshape(-1, 4).copy()
        largest = max(float(np.abs(q[:, :3]).max()), 1e-300)
        q[:, :3] /= largest
        return np.concatenate([self.tip(), q.ravel(), [math.log(largest)]])

    def tip(self) -> np.ndarray:
        """(tip position / L, tip d3): the Solution's last row (to round-off), without building it."""
        row = self.U[self.disc.vertex_dof(self.disc.vertices.size - 1)].tolist()  # the tip's values
        if self.model == PLANAR:  # lab_frames of one row, in floats (numpy costs ~1 us per operation)
            a0, a1 = float(self.e_a[0]), float(self.e_a[1])
            x, z, th = row[:3]
            s, c = math.sin(th), math.cos(th)
            return np.array([x * a0, x * a1, z, a0 * s, a1 * s, c])
        return np.array(row[:3] + kin.d3(row[3:7]))  # d3 of q/|q|, as lab_frames


#: The last scene's plane and its prepared (model, plane, scaled rod, breaks) per model asked.
_LAST: dict[str, tuple] = {}


def _remembered(slot: str, scene: Scene, make):
    """``make()`` for the last scene asked in ``slot``, remembered while it is this scene, unchanged:
    scenes are frozen, but a segment's ``overrides`` is a dict that could be edited in place."""
    overrides = tuple(tuple(sorted(seg.overrides.items())) for seg in scene.rod.segments)
    last = _LAST.get(slot)
    if last is None or last[0] is not scene or last[1] != overrides:
        last = _LAST[slot] = (scene, overrides, make())
    return last[2]


def scene_plane(scene: Scene) -> tuple[float, float, float] | None:
    """:func:`matid.rod.scenes.plane_of`, remembered for the last scene asked."""
    return _remembered("plane", scene, lambda: plane_of(scene))


def prepare_scene(scene: Scene, model: str) -> tuple:
    """(model, plane direction, scaled rod, its load terms, mesh breaks) of a scene; the last one is
    remembered (scenes are frozen), so the meshes of one error estimate compute them once."""

    def make():
        plane = scene_plane(scene) if model in ("auto", PLANAR) else None
        if model == PLANAR and plane is None:
            raise ValueError("the scene is not planar: use model='full' or 'auto'")
        chosen = PLANAR if plane is not None else FULL
        e_a = None if chosen == FULL else np.asarray(plane)
        return chosen, e_a, *scaled(scene, e_a), breaks(scene)

    return _remembered(model, scene, make)


@functools.lru_cache(maxsize=64)
def mesh(elements: int, at: tuple[float, ...], nf: int, element: str, intorder: int) -> Discretisation:
    """The cantilever's discretisation, built once per (mesh, fields, element, rule).

    Nothing in it depends on the loads or stiffnesses, and the clamp (the only
    fixed dofs of a cantilever) is the same for every scene, so repeated solves and
    the meshes of the error estimate share it (its tables are read-only).
    """
    return Discretisation(graded_vertices(1.0, elements, breaks=at), nf, element=element, intorder=intorder)


def _warm(system: RodSystem, start: tuple, provisional: bool, kinks) -> tuple[np.ndarray, NewtonInfo] | None:
    """Newton at the full load from a state on another mesh (transfer.interpolate_warm with the
    state's ``kinks``); None if it fails."""
    U0 = interpolate_warm(*start, system.disc.s_dof, kinks)
    if system.model == FULL:
        U0[:, 3:] /= np.linalg.norm(U0[:, 3:], axis=1, keepdims=True)
    return _full_load(system, U0, provisional)


def _full_load(system: RodSystem, U0: np.ndarray, provisional: bool) -> tuple[np.ndarray, NewtonInfo] | None:
    """Newton at the full load from nodal values U0 (nscalar, nf); None if it fails or is inadmissible
    (``provisional``: see :func:`equilibrium`'s ``confirm``)."""
    info = NewtonInfo(steps=1)
    try:
        x0, accept = system.reduce(U0.ravel()), XTOL if provisional else 0.0
        X, info.iterations, info.lu = newton(system, x0, 1.0, accept=accept, info=info)
        check_admissible(system, X, 1.0, info.lu)
    except NewtonFailure:
        return None
    return X, info
