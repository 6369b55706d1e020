"""The stability catalogue's yardsticks: references computed once (on first use, so the quick
subset computes only what it needs), the error measures against them, and the cantilever case.

References are independent of the solver where one exists (closed forms, the elastica BVP of
:mod:`matid.bench.references`); where none exists (3D scenes) a fine-mesh or Richardson solve says so.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache

import numpy as np

from matid.bench import scenes as S
from matid.bench.case import Case
from matid.bench.checks import planar_state_check
from matid.bench.common import tip_xz
from matid.bench.references import Elastica, circle_shape, first_branch, follow_elastica, richardson
from matid.rod.bend import BendModel
from matid.rod.cantilever import solve_cantilever

# -- references (computed once, on first use) ---------------------------------------------------


@cache
def elastica(
    alpha: float = 0.0, E_s: float = math.inf, E_e: float = math.inf, q: float = 0.0, psi_deg: float = 0.0
) -> np.ndarray:
    rod = Elastica(force=(alpha, 0.0), q=q, field_angle=math.radians(psi_deg), E_s=E_s, E_e=E_e)
    return follow_elastica(rod)["tip"][:2]


@cache
def branch_tip(q: float, psi_deg: float) -> np.ndarray:
    """Tip (x, z)/L of the first-mode branch bending towards +x (shooting scan; see references)."""
    return first_branch(Elastica(q=q, field_angle=math.radians(psi_deg)))["tip"][:2]


@cache
def spatial_tip(elements: int, stiff: float = 1e6, rigid: bool = False) -> np.ndarray:
    sol = solve_cantilever(S.spatial(stiff=stiff, rigid=rigid), elements=elements)
    return np.asarray(sol.position[-1]) / S.L


@cache
def bend_reference(n: int, specimen: float, deflections: tuple[float, ...]) -> np.ndarray:
    E = S.BEND_E
    forces = [
        BendModel(S.bend_geometry(specimen), elements=m).solve(*E, deflections).force for m in (n, 2 * n)
    ]
    return richardson(*forces)


def tip_error(reference: Callable[[], np.ndarray]) -> Callable[[object], float]:
    return lambda sol: float(np.linalg.norm(tip_xz(sol, S.L) - reference()))


def tip3_error(reference: Callable[[], np.ndarray]) -> Callable[[object], float]:
    return lambda sol: float(np.linalg.norm(np.asarray(sol.position[-1]) / S.L - reference()))


def arc_error(turns: float) -> Callable[[object], float]:
    def error(sol) -> float:
        exact = np.insert(circle_shape(np.asarray(sol.s) / S.L, turns), 1, 0.0, axis=1)  # (x, 0, z)
        return float(np.max(np.linalg.norm(np.asarray(sol.position) / S.L - exact, axis=1)))

    return error


def relative_error(value: np.ndarray, reference: np.ndarray) -> float:
    return float(np.max(np.abs(value - reference) / np.abs(reference)))


def straight_error(sol) -> float:
    p = np.asarray(sol.position)
    return float(np.max(np.abs(p - np.column_stack([0 * p[:, 0], 0 * p[:, 0], sol.s])))) / S.L


def cantilever_case(
    family: str,
    name: str,
    parameters: dict,
    scene,
    error: Callable[[object], float],
    reference: str,
    *,
    elements: int = 16,
    solve: dict | None = None,
    check: bool = False,
    **options,
) -> Case:
    """A cantilever case: ``solve_cantilever(scene, elements, **solve)``, its elements appended to
    ``parameters``; ``check``: rebuild the returned planar state (residual, stability)."""
    return Case(
        family,
        name,
        {**parameters, "elements": elements},
        lambda: solve_cantilever(scene, elements=elements, **(solve or {})),
        error,
        reference,
        check=(lambda sol: planar_state_check(scene, sol)) if check else None,
        **options,
    )
