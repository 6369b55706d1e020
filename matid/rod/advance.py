"""Advancing a tube out of a sheath (contract section 12, ``[advance]``): one equilibrium per free
length, solved in the given order, each from the state the last one reached.

Under ``[advance]`` the scene's ``[rod] length`` is the whole tube and the clamp is the sheath's
exit. Step k models the tube's distal ``free_lengths[k]``: :func:`step_scene` is that scene (segments,
magnets, magnetised pieces and point loads keep their places on the tube, measured from its
proximal end, so they shift by ``length - free`` towards the clamp; what lies in the sheath is
dropped, a piece across the exit is cut there).

The warm start of a longer step is the last state pushed out of the sheath (:func:`pushed`): the
last centreline kept where it is and the new length continued beyond its tip along the tip's
tangent (the tube follows its own path, as through a vessel), every node then moved onto the
allowed side of the walls and lumen (:func:`keep_out_of`), so a contact stays on the side of the
wall where the path put it. A step whose plane is not the last one's (a load come out of the
sheath leaves it: planar to full) starts from the straight tube instead.

A step that does not solve from that start is reached through intermediate free lengths
(:func:`reach`): the failed increment is halved, and halved again while it fails, down to
MIN_SUBSTEP of the step's free length, each sub-step from the last one reached (the first step from
the sheath, free length 0). Only the listed steps are reported; each counts its ``substeps``.

Measured (examples/scenes/advance_lumen.toml continued to 22.5 and 25 mm, 75 degrees into the bend;
tests/rod/test_advance.py): the start translated along the sheath's axis (before) put the tip
2.1 mm beyond the bend's outer wall and failed at 22.5 mm, with sub-steps too (reached 20.7 mm);
the tangent continuation without the projection failed at 10 mm (at 20.9 mm with sub-steps); with
the projection but no sub-steps at 15 mm; both together reach 25 mm (sub-steps at 15 and 22.5 mm:
2 and 3), every step within 1.9e-8 of the free length of the shooting reference. The bench's
channel that changes sides (matid.bench.contact, 16 elements) solved none of its steps past 20 mm
and now solves all six (one sub-step at 30 mm).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from matid.errors import ConvergenceError
from matid.physics import kinematics as kin
from matid.physics.boundaries import Centreline, lumen_gap, wall_gap
from matid.rod.models import PLANAR
from matid.rod.scene_contact import outer_radius
from matid.rod.scenes import Scene, SegmentSpec, plane_of

#: The shortest sub-step (a fraction of the step's free length) of a step reached through
#: intermediate free lengths: at most six halvings of a failed increment.
MIN_SUBSTEP = 1.0 / 64


def step_scene(scene: Scene, free: float) -> Scene:
    """The cantilever of the tube's distal ``free`` metres (m) of an ``[advance]`` scene."""
    rod, loads = scene.rod, scene.loads
    off = rod.length - free
    segments = tuple(
        replace(seg, start=max(seg.start - off, 0.0), end=seg.end - off)
        for seg in rod.segments
        if seg.end - off > 0.0
    )
    kept = [k for k, (at, _) in enumerate(loads.magnets) if at - off >= 0.0]
    magnets = tuple((loads.magnets[k][0] - off, loads.magnets[k][1]) for k in kept)
    magnet_directions = tuple(loads.magnet_directions[k] for k in kept) if loads.magnet_directions else ()
    pieces = [k for k, (_, b, _) in enumerate(loads.magnetization) if b - off > 0.0]
    magnetization = tuple(
        (max(a - off, 0.0), b - off, m) for a, b, m in (loads.magnetization[k] for k in pieces)
    )
    piece_directions = (
        tuple(loads.magnetization_directions[k] for k in pieces) if loads.magnetization_directions else ()
    )
    point_loads = tuple((at - off, f, m) for at, f, m in loads.point_loads if at - off >= 0.0)
    new_loads = replace(
        loads,
        magnets=magnets,
        magnet_directions=magnet_directions,
        magnetization=magnetization,
        magnetization_directions=piece_directions,
        point_loads=point_loads,
    )
    new_rod = replace(rod, length=free, segments=tuple(SegmentSpec(**_fields(s)) for s in segments))
    return replace(scene, rod=new_rod, loads=new_loads, advance=None)


def _fields(seg: SegmentSpec) -> dict:
    return {"start": seg.start, "end": seg.end, "overrides": dict(seg.overrides),
            "rigid": seg.rigid, "precurvature": seg.precurvature}  # fmt: skip


def pushed(state, model: str, last: float, free: float, keep_out=None):
    """The warm start (scaled P2 vertices and nodal values sorted by s) of a step of ``free`` m from
    ``state`` (:meth:`Equilibrium.state`) of the last step of ``last`` m: the last centreline kept
    where it is and the new length continued beyond its tip along the tip's tangent (the tube
    follows its own path, as pushed through a lumen), every node then moved onto the allowed side
    of the walls by ``keep_out(points (n, 3) in m, s in m)`` -> points (:func:`keep_out_of`).
    None when the tube does not get longer (the next step then starts from the straight tube)."""
    if state is None or not free > last:
        return None
    vertices, values = state
    ratio = last / free
    positions = [0, 1] if model == PLANAR else [0, 1, 2]  # (x, z, theta) planar; (x, y, z, q) full
    old = values.copy()
    old[:, positions] *= ratio
    tip = old[-1]
    d3 = _tangent(model, tip)
    ahead = np.array([0.5 * (ratio + 1.0), 1.0])
    new = np.repeat(tip[None, :], 2, axis=0)
    new[:, positions] += (ahead - ratio)[:, None] * d3[None, :]
    values = np.concatenate([old, new])
    s = np.concatenate([_nodes(vertices * ratio), ahead])
    if keep_out is not None:
        values[:, positions] = _planar_out(model, keep_out, values[:, positions], s, free)
    return np.concatenate([vertices * ratio, [1.0]]), values


def _nodes(vertices: np.ndarray) -> np.ndarray:
    """The P2 nodes' s (vertex, mid-point, vertex, ...) of a mesh's vertices."""
    s = np.empty(2 * vertices.size - 1)
    s[::2], s[1::2] = vertices, 0.5 * (vertices[:-1] + vertices[1:])
    return s


def _tangent(model: str, row: np.ndarray) -> np.ndarray:
    """d3 of one nodal row in the state's coordinates: (x, z) planar, (x, y, z) full."""
    if model == PLANAR:
        return np.array([np.sin(row[2]), np.cos(row[2])])
    return np.asarray(kin.d3(row[3:7] / np.linalg.norm(row[3:7])))


def _planar_out(model, keep_out, r, s, free):
    """``keep_out`` of scaled positions r (planar (x, z) with x along the plane's e_a, or 3D)."""
    if model != PLANAR:
        return keep_out(r * free, s * free) / free
    lab = np.stack([r[:, 0], np.zeros(len(r)), r[:, 1]], axis=1)  # the plane's own frame: walls
    out = keep_out(lab * free, s * free) / free  # and lumen are given in it by keep_out_of
    return out[:, [0, 2]]


def keep_out_of(scene: Scene, e_a, passes: int = 4):
    """The projection of :func:`pushed` for a step scene: each centreline point whose tube surface
    crosses a wall or the lumen moved along the gap's gradient onto it (a few passes for points
    near two boundaries); None without walls and lumen. ``e_a``: the planar model's plane
    direction (its (transverse, normal, axial) frame), None for the full model."""
    if not scene.walls and scene.lumen is None:
        return None
    frame = np.eye(3)
    if e_a is not None:
        frame = np.array([[e_a[0], e_a[1], 0.0], [-e_a[1], e_a[0], 0.0], [0.0, 0.0, 1.0]])
    walls = [(frame @ np.asarray(w.point, float), frame @ np.asarray(w.normal, float)) for w in scene.walls]
    line = None
    if scene.lumen is not None:
        line = Centreline.rounded([frame @ np.asarray(p, float) for p in scene.lumen.centreline],
                                  scene.lumen.corner_radius)  # fmt: skip

    def project(r: np.ndarray, s: np.ndarray) -> np.ndarray:
        r, R = np.array(r, float), outer_radius(scene.rod, s)
        for _ in range(passes):
            gaps = [wall_gap(r, p, n, R)[:2] for p, n in walls]
            if line is not None:
                gaps.append(lumen_gap(r, line, scene.lumen.radius, R)[:2])
            for g, grad in gaps:
                r -= np.minimum(g, 0.0)[:, None] * grad
        return r

    return project


class Reached(NamedTuple):
    """A step of an advance as solved: its free length (m), Solution and Equilibrium, the number of
    intermediate free lengths solved on the way to it and the run time of all of them (s)."""

    free: float
    solution: object
    equilibrium: object
    substeps: int
    runtime_s: float


def solve_steps(scene: Scene, solve_one) -> list[Reached]:
    """Every step of ``scene.advance`` in order; ``solve_one(step scene, start)`` -> (Solution,
    Equilibrium) solves one from a warm start or None. A step that fails from the last one's state
    is reached through intermediate free lengths (:func:`reach`); one that cannot be reached raises
    ConvergenceError naming it, the free length reached on the way and the solver's load factor."""
    steps, last, plane = [], None, None
    for k, free in enumerate(scene.advance):
        t0 = time.perf_counter()
        try:
            (free, sol, eq), plane, substeps = reach(scene, solve_one, last, plane, free)
        except ConvergenceError as exc:
            reached = exc.info.get("free_length_reached")
            where = "" if reached is None else f", reached {reached * 1e3:.6g} mm"
            raise ConvergenceError(
                f"[advance] step {k + 1} (free length {free * 1e3:.6g} mm{where}): {exc}",
                load_factor=None,
                step=k + 1,
                free_length=free,
                free_length_reached=reached,
            ) from exc
        last = (free, sol, eq)
        steps.append(Reached(free, sol, eq, substeps, time.perf_counter() - t0))
    return steps


def reach(scene: Scene, solve_one, last, plane, free: float):
    """((free, Solution, Equilibrium), its plane, sub-steps) of the step of ``free`` m from ``last``
    ((free length, Solution, Equilibrium), or None before the first step) whose plane was
    ``plane``: in one step first; when that fails, from the middle of the increment (halved again
    while it fails, down to MIN_SUBSTEP x free), each sub-step from the last one reached. The
    ConvergenceError of a sub-step at that minimum is raised with the free length reached."""
    targets, solved = [free], 0
    while targets:
        target = targets[-1]
        step = step_scene(scene, target)
        here = plane_of(step)  # a load coming out of the sheath may leave the plane (or turn it):
        warm = last is not None and last[2] is not None and _same_plane(here, plane)  # no warm start then
        start = None
        if warm:
            eq = last[2]
            start = pushed(eq.state(), eq.model, last[0], target, keep_out_of(step, eq.e_a))
        try:
            sol, eq = solve_one(step, start)
        except ConvergenceError as exc:
            base = 0.0 if last is None else last[0]  # the first step: out of the sheath from 0
            if target - base <= MIN_SUBSTEP * free:
                exc.info.setdefault("free_length_reached", None if last is None else last[0])
                raise
            targets.append(0.5 * (base + target))
            continue
        targets.pop()
        last, plane, solved = (target, sol, eq), here, solved + 1
    return last, plane, solved - 1


def _same_plane(a, b) -> bool:
    """Whether two steps' planes (plane_of: a direction, or None for 3D) are the same."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.allclose(a, b, rtol=0.0, atol=1e-12))


def step_entry(free: float, sol, substeps: int = 0) -> dict:
    """One entry of solution.json's ``steps`` (contract section 12); ``substeps``: the intermediate
    free lengths solved on the way to it."""
    return {
        "free_length": float(free),
        "substeps": int(substeps),
        "converged": bool(sol.converged),
        "tip": {key: [float(v) for v in value] for key, value in sol.tip.items()},
        "position": [[float(v) for v in row] for row in sol.position],
        "contacts": [dict(c) for c in sol.extra.get("contacts", [])],
        "discretization_error": None if sol.discretization_error is None else float(sol.discretization_error),
        "warnings": list(sol.extra.get("warnings", [])),
    }
