"""One entry point for every scene: ``solve(scene) -> Solution``.

Cantilever scenes go to :func:`matid.rod.cantilever.solve_cantilever` (planar or
full model); three-point-bend scenes to the half model of
:class:`matid.rod.bend.BendModel`, whose state at the largest deflection is
mirrored onto the whole tube in the lab frame of docs/contract.md section 6:
before loading the tube lies along +z with s = 0 at one end, mid-span at
z = L/2, and x points up (the nose pushes towards -x). In the half model
(scaled by the span S) x is vertical and z runs from mid-span to the free
end, so the right half is r = (S x, 0, L/2 + S z) with angle theta and the
left half its mirror image z -> -z, theta -> -theta.
"""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np

from matid.errors import DataError
from matid.physics import kinematics as kin
from matid.rod.accuracy import refine
from matid.rod.advance import solve_steps, step_entry
from matid.rod.aim import AIM_SECONDS, AIM_TOL, aim, angle
from matid.rod.bend import DEFAULT_ELEMENTS as BEND_ELEMENTS
from matid.rod.bend import BendGeometry, BendModel, BendPath
from matid.rod.cantilever import Equilibrium, Solution, equilibrium, scene_plane
from matid.rod.checks import penalty_error, strain_warnings
from matid.rod.contact_ends import stretch_order
from matid.rod.contact_mesh import contact_rounds
from matid.rod.fem import ELEMENTS
from matid.rod.models import FULL, PLANAR
from matid.rod.scenes import MAX_SCENE_ELEMENTS, Scene, load_scene
from matid.rod.terms.contact import CONTACT_FRACTION, to_lab

MODELS = ("auto", PLANAR, FULL)
#: Energy terms of the bend half model (no field, no twist: planar by construction).
BEND_TERMS = ("bending", "shear", "extension", "contact")


def resolve_model(scene: Scene, model: str = "auto") -> str:
    """The model that will run for ``model`` ("auto", "planar" or "full"); ValueError if it cannot."""
    if model not in MODELS:
        raise ValueError(f"model must be one of {', '.join(MODELS)}, got {model!r}")
    if scene.kind == "three_point_bend":
        if model == FULL:
            raise ValueError("the three-point bend runs the planar half model only: model 'auto' or 'planar'")
        return PLANAR
    planar = scene_plane(scene) is not None
    if model == PLANAR and not planar:
        raise ValueError(
            "the scene is not planar (a load, moment or precurvature leaves the plane): "
            "use model 'full' or 'auto'"
        )
    return model if model != "auto" else (PLANAR if planar else FULL)


def solve(
    scene: Scene | str | os.PathLike,
    *,
    elements: int | None = None,
    model: str = "auto",
    variant: str = kin.NORMALISED,
    element: str = "P2",
    aim_seconds: float = AIM_SECONDS,
) -> Solution:
    """Static equilibrium of a scene, SI, lab frame. Raises ConvergenceError (SlipOffError) on failure.

    ``scene`` is a :class:`~matid.rod.scenes.Scene` or the path of a scene file (read by
    :func:`~matid.rod.scenes.load_scene`); anything else is a TypeError. ``elements`` overrides
    the scene's; for the three-point bend it counts the elements of the half model. ``variant``
    ("normalised" or "raw") and ``element`` ("P2", "P1" or "Hermite", the paper's cubic) apply to the
    cantilever models. ``aim_seconds``: how long a scene's ``[aim]`` may search (then a
    ConvergenceError naming the closest direction reached).
    """
    if isinstance(scene, (str, os.PathLike)):
        scene = load_scene(scene)
    elif not isinstance(scene, Scene):
        raise TypeError(
            f"scene must be a matid.rod.Scene or the path of a scene file, got {type(scene).__name__}"
        )
    if variant not in (kin.NORMALISED, kin.RAW):
        raise ValueError(f"variant must be 'normalised' or 'raw', got {variant!r}")
    if element not in ELEMENTS:
        raise ValueError(f"element must be one of {', '.join(ELEMENTS)}, got {element!r}")
    if elements is not None and elements < 1:
        raise ValueError(f"elements must be at least 1, got {elements}")
    if elements is not None and elements > MAX_SCENE_ELEMENTS:
        raise DataError(
            f"elements: at most {MAX_SCENE_ELEMENTS} (the automatic meshing's limit), got {elements}"
        )
    if scene.advance is not None:  # quasi-static insertion (contract section 12)
        return _solve_advanced(scene, elements=elements, model=model, variant=variant, element=element)
    if scene.aim is not None:  # the inverse problem (contract section 9): the field is solved for
        options = {"elements": elements, "model": model, "variant": variant, "element": element}
        return _solve_aimed(scene, aim_seconds, **options)
    return _solve_forward(scene, elements=elements, model=model, variant=variant, element=element)[0]


def _solve_forward(scene: Scene, *, elements, model, variant, element, start=None):
    """(Solution, its Equilibrium or None) of a scene on its meshes with the error estimate;
    ``start``: a warm start (scaled P2 vertices, values) for the first mesh (cantilevers)."""
    chosen = resolve_model(scene, model)
    last, contact_at = start, ()  # the last mesh's Equilibrium: each finer mesh starts from it

    def at(n: int):
        nonlocal last
        if scene.kind == "cantilever":  # presented as a Solution only if it is the answer
            options = {"variant": variant, "element": element, "start": last, "contact_at": contact_at}
            last = equilibrium(scene, elements=n, model=chosen, confirm=False, **options)
            return last, last.quantities(), last.runtime_s
        sol = solve_bend(scene, elements=n)
        force = np.asarray(sol.three_point_bend["force"])
        return sol, force / bend_force_scale(scene), sol.runtime_s

    def meshes_at(points: tuple[float, ...], enough=None, stretches=(), more=None):
        nonlocal contact_at
        contact_at = points
        cap = lambda result: stretch_order(result, stretches)  # noqa: E731
        return refine(at, tolerance=scene.tolerance, fixed=fixed, enough=enough, cap=cap, more=more)

    fixed = elements or scene.elements
    if scene.walls or scene.lumen is not None:
        result, est, rounds, moved = contact_rounds(meshes_at, scene.tolerance)
    else:  # nothing to touch: contact_rounds' first round is the answer, without its bookkeeping
        result, est = meshes_at(())
        rounds, moved = [est], 0.0
    estimate = {
        "method": "richardson",
        "order": est.order,
        "meshes": [n for n, _ in est.history],
        "total_runtime_s": sum(t for e in rounds for _, t in e.history),
        "tolerance": None if fixed else scene.tolerance,
    }
    if len(rounds) > 1:  # interior contacts moved onto vertices (issue 31): their last step counts
        estimate["contact_rounds"], estimate["contact_step"] = len(rounds) - 1, moved
    if isinstance(result, Equilibrium):  # the Solution is built once, with its estimate
        result = result.confirmed()  # the answer's last Newton evaluation, deferred (equilibrium)
        error = est.error + moved
        if variant == kin.RAW:  # the paper's penalty has an error of its own (~1/c_u): included
            estimate["penalty_error"] = penalty_error(result)
            error += estimate["penalty_error"]
        extra = {"error_estimate": estimate, "warnings": strain_warnings(result)}
        if result.contact is not None:  # walls and lumen (contract section 12)
            extra.update(contacts_of(result))
        return result.solution(discretization_error=error, extra=extra), result
    extra = {**result.extra, "error_estimate": estimate}
    return replace(result, discretization_error=est.error, extra=extra), None


def _solve_advanced(scene: Scene, **options):
    """:func:`solve` of a scene with ``[advance]``: every step in order, each warm-started from the
    last, through intermediate free lengths where it must (:mod:`matid.rod.advance`); the last
    step's Solution with ``steps`` in its extra (each with its ``substeps``)."""
    steps = solve_steps(scene, lambda step, start: _solve_forward(step, start=start, **options))
    free, sol = steps[-1].free, steps[-1].solution
    entries = [step_entry(s.free, s.solution, s.substeps) for s in steps]
    runtime = sum(s.runtime_s for s in steps)  # sub-steps included
    return replace(sol, runtime_s=runtime, extra={**sol.extra, "steps": entries, "free_length": free})


def bend_force_scale(scene: Scene) -> float:
    """A force scale of a bend scene that no mesh changes: Timoshenko's small-deflection force at
    the deepest deflection, d / (S^3 / (48 E_b) + S / (4 E_s)). (Dividing each mesh's forces by its
    own largest force, as before, cancelled the error common to all of them: the estimate said 2e-7
    where the error was 1.3e-6; tests/test_examples.py.)"""
    S, rod = scene.bend.span, scene.rod
    d = max(max(scene.bend.deflections), 1e-3 * S)
    return d / (S**3 / (48 * rod.E_b) + S / (4 * rod.E_s))


def _solve_aimed(scene: Scene, seconds: float, **options):
    """:func:`solve` of a scene with ``[aim]``: the field found by :func:`aim`, then the
    forward solve of the scene in it (its mesh and error estimate as any scene's); the aim is
    repeated on that mesh when its tip misses the target by more than AIM_TOL."""
    found = aim(scene, elements=options.get("elements"), seconds=seconds)
    forward = replace(scene, aim=None, loads=replace(scene.loads, B=tuple(found.B)))
    sol = solve(forward, **options)
    target = np.asarray(scene.aim.tip_direction)
    solves, runtime = found.forward_solves, found.runtime_s
    left = seconds - found.runtime_s  # one budget for the whole aim (docs/limits.md)
    if angle(sol.tip["d3"], target) > AIM_TOL and sol.elements != found.elements and left > 0:
        again = aim(replace(scene, elements=sol.elements), seconds=left)
        forward = replace(forward, loads=replace(scene.loads, B=tuple(again.B)))
        sol = solve(forward, **{**options, "elements": sol.elements})
        solves, runtime = solves + again.forward_solves, runtime + again.runtime_s
    error = angle(sol.tip["d3"], target)
    report = {"tip_direction_error_rad": error, "forward_solves": solves, "runtime_s": runtime}
    aimed = replace(forward, aim=scene.aim)
    return replace(sol, scene=aimed, extra={**sol.extra, "aim": report})


def solve_bend(scene: Scene, *, elements: int | None = None) -> Solution:
    """The three-point bend of a scene: nose force at each deflection and the shape at the last one."""
    rod, bend = scene.rod, scene.bend
    _check_bend(scene)
    geometry = BendGeometry(bend.span, rod.length, bend.support_radius, bend.nose_radius, rod.outer_diameter)
    n = elements or scene.elements or BEND_ELEMENTS
    if n < 2:
        raise DataError(f"elements: the three-point-bend half model needs at least 2, got {n}")
    model = BendModel(geometry, elements=n)
    path = model.solve(rod.E_b, rod.E_s, rod.E_e, np.asarray(bend.deflections))
    s, position, d1, d3 = whole_tube(model, path)
    return Solution(
        scene=scene,
        model=PLANAR,
        elements=model.elements,
        element="P2",
        newton_iterations=path.newton_iterations,
        load_steps=path.load_steps,
        runtime_s=path.runtime_s,
        s=s,
        position=position,
        d1=d1,
        d3=d3,
        terms=BEND_TERMS,
        three_point_bend={
            "deflection": path.deflection.tolist(),
            "force": path.force.tolist(),
            "support_contact_s": path.support_s.tolist(),
        },
    )


def _check_bend(scene: Scene) -> None:
    """The bend half model has a uniform, straight, unloaded tube; say so rather than ignore the rest."""
    loads, rod = scene.loads, scene.rod
    present = {
        "[[segment]]": rod.segments,
        "rod.precurvature": any(rod.precurvature),
        "[field]": any(loads.B),
        "[load]": any(loads.distributed_force),
        "[tip]": any(loads.tip_force) or any(loads.tip_moment),
        "[[magnet]]": loads.magnets,
        "[[magnetization]]": loads.magnetization,
        "[[point_load]]": loads.point_loads,
    }
    ignored = [name for name, there in present.items() if there]
    if ignored:
        raise DataError(f"three_point_bend: {', '.join(ignored)} not supported (a uniform straight tube)")
    if any(b < a for a, b in zip(scene.bend.deflections, scene.bend.deflections[1:], strict=False)):
        raise DataError("three_point_bend.deflection: give the nose displacements in increasing order")


def whole_tube(model: BendModel, path: BendPath):
    """(s, position, d1, d3) of the whole tube at the last deflection, mirrored from the half model."""
    L = model.geometry.specimen_length
    s_half, x, z, theta = model.half_state(path)
    right = (L / 2 + s_half, x, L / 2 + z, theta)
    left = tuple(np.flip(a[1:]) for a in (L / 2 - s_half, x, L / 2 - z, -theta))
    s, x, z, theta = (np.concatenate([a, b]) for a, b in zip(left, right, strict=True))
    zero = np.zeros_like(s)
    position = np.column_stack([x, zero, z])
    d1 = np.column_stack([np.cos(theta), zero, -np.sin(theta)])
    d3 = np.column_stack([np.sin(theta), zero, np.cos(theta)])
    return s, position, d1, d3


def contacts_of(result: Equilibrium) -> dict:
    """{"contacts", "contact_tolerance"} of a converged state with walls or a lumen, SI, lab frame."""
    rod = result.scene.rod
    contacts = to_lab(result.contact[0], result.e_a, rod.length, rod.E_b)
    return {"contacts": contacts, "contact_tolerance": CONTACT_FRACTION * result.scene.tolerance * rod.length}
