"""Advancing a tube out of a sheath (contract section 12, ``[advance]``): one equilibrium per free
length, solved in the given order, each from the state the last one reached.

Under ``[advance]`` the scene's ``[rod] length`` is the whole tube and the clamp is the sheath's
exit. Step k models the tube's distal ``free_lengths[k]``: :func:`step_scene` is that scene (segments,
magnets, magnetised pieces and point loads keep their places on the tube, measured from its
proximal end, so they shift by ``length - free`` towards the clamp; what lies in the sheath is
dropped, a piece across the exit is cut there). The warm start of a longer step is the last state
pushed out of the sheath (:func:`pushed`): a straight piece of the new length at the clamp and the
last centreline translated along the sheath's axis behind it, so a contact stays on the side of the
wall where the path put it; a step whose plane is not the last one's (a load come out of the sheath
leaves it: planar to full) starts from the straight tube instead.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from matid.errors import ConvergenceError
from matid.rod.models import PLANAR
from matid.rod.scenes import Scene, SegmentSpec, plane_of


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


def pushed(state, model: str, last: float, free: float):
    """The warm start (scaled P2 vertices and nodal values sorted by s) of a step of ``free`` m from
    ``state`` (:meth:`Equilibrium.state`) of the last step of ``last`` m: the new length straight at
    the clamp, the last shape translated along the sheath's axis (+z) behind it. None when the tube
    does not get longer (the next step then starts from the straight tube)."""
    if state is None or not free > last:
        return None
    vertices, values = state
    step = (free - last) / free
    old = values.copy()
    positions = [0, 1] if model == PLANAR else [0, 1, 2]  # (x, z, theta) planar; (x, y, z, q) full
    axis = 1 if model == PLANAR else 2
    old[:, positions] *= last / free
    old[:, axis] += step
    straight = np.repeat(values[:1], 2, axis=0)  # the clamp's row: at the origin, along +z
    straight[:, positions] = 0.0
    straight[:, axis] = [0.0, 0.5 * step]
    return (
        np.concatenate([[0.0], step + vertices * last / free]),
        np.concatenate([straight, old]),
    )


def solve_steps(scene: Scene, solve_one):
    """[(free length, Solution, Equilibrium)] of every step of ``scene.advance`` in order;
    ``solve_one(step scene, start)`` -> (Solution, Equilibrium) solves one from a warm start or None.
    A step that cannot be reached raises ConvergenceError naming it."""
    steps, last, plane = [], None, None
    for k, free in enumerate(scene.advance):
        step = step_scene(scene, free)
        here = plane_of(step)  # a load coming out of the sheath may leave the plane (or turn it):
        warm = last is not None and last[2] is not None and _same_plane(here, plane)  # no warm start then
        start = pushed(last[2].state(), last[2].model, last[0], free) if warm else None
        plane = here
        try:
            sol, eq = solve_one(step, start)
        except ConvergenceError as exc:
            raise ConvergenceError(
                f"[advance] step {k + 1} (free length {free * 1e3:.6g} mm): {exc}",
                load_factor=None,
                step=k + 1,
                free_length=free,
            ) from exc
        steps.append((free, sol, eq))
        last = (free, sol, eq)
    return steps


def _same_plane(a, b) -> bool:
    """Whether two steps' planes (plane_of: a direction, or None for 3D) are the same."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.allclose(a, b, rtol=0.0, atol=1e-12))


def step_entry(free: float, sol) -> dict:
    """One entry of solution.json's ``steps`` (contract section 12)."""
    return {
        "free_length": float(free),
        "converged": bool(sol.converged),
        "tip": {key: [float(v) for v in value] for key, value in sol.tip.items()},
        "position": [[float(v) for v in row] for row in sol.position],
        "contacts": [dict(c) for c in sol.extra.get("contacts", [])],
        "discretization_error": None if sol.discretization_error is None else float(sol.discretization_error),
        "warnings": list(sol.extra.get("warnings", [])),
    }
