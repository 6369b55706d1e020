"""Convergence: error against elements and against run time, per element and quadrature.

Scenes and references (all computed at run time):

- magnetic cantilever, q = mu B L^2/E_b = 6.4, magnetisation over the whole
  rod, field at 120 deg: error |r_tip - r_ref|/L against the Richardson
  extrapolation (order 4) of P2 two-point-Gauss tips on N and 2N elements,
  checked against the printed digits (98.636 deg, (0.83419, 0.29063)) and the
  elastica BVP of :mod:`matid.bench.references` (exact here: a uniform field
  exerts no force, so shear and extension carry nothing);
- tip force F L^2/E_b = 2 perpendicular to the rod, E_s = E_e = 1e8 E_b/L^2:
  error |r_tip - r_ref|/L against the planar rod BVP with the same stiffnesses
  (solve_bvp, checked by shooting);
- full circle, M = 2 pi E_b/L: error max_nodes |r - r_exact|/L against the arc.
  The tip error is no measure here: on uniform elements the Gauss rule
  integrates sin and cos over a whole period exactly, so the tip closes to
  round-off on any mesh;
- three-point bend, span 10 mm, d = 1 mm: relative nose-force error against the
  Richardson extrapolation of BendModel on N and 2N elements. The bend half
  model is built on P2 with two-point Gauss only;
- tip on a wall (contact, issue 31): the magnetic cantilever held by a wall at
  x = 0.75 L, the larger of the tip error / L and the reaction's relative
  error against the elastica shot with the wall's reaction at the tip
  (:mod:`matid.bench.contact`); P2 with two-point Gauss (the contact acts at
  the nodes of any element, the default is measured).

Observed order: least-squares slope of log(error) against log(h) over the
finest ``FIT_LEVELS`` levels with error above ``FLOOR`` (below it the
reference and round-off dominate).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from matid.bench import contact
from matid.bench import scenes as S
from matid.bench.common import best_of, tip_angle, tip_xz
from matid.bench.references import Elastica, circle_shape, follow_elastica, richardson
from matid.errors import ConvergenceError
from matid.rod.bend import BendModel
from matid.rod.cantilever import Solution, solve_cantilever
from matid.rod.scenes import Scene

LEVELS = (2, 4, 8, 16, 32, 64, 128, 256, 512)
QUICK_LEVELS = (2, 4, 8, 16)
BEND_LEVELS = (4, 8, 16, 32, 64, 128, 256, 512)
QUICK_BEND_LEVELS = (4, 8, 16, 32)
#: (element, intorder): P2 with 2-point Gauss (the default), P2 with 3-point Gauss, P1, and the
#: paper's cubic Hermite with 3-point Gauss (2 points leave its tangent singular).
CHOICES = (("P2", 2), ("P2", 4), ("P1", 2), ("Hermite", 4))
QUADRATURE = {2: "2-point Gauss", 4: "3-point Gauss"}
#: Errors below this are left out of the order fits: the Newton tolerance and round-off of the
#: stiff (1e8) scenes stop the magnetic cantilever at ~1.6e-11 (measured), the references at ~1e-12.
FLOOR = 1e-10
LOCKED = 0.1  # an error above this on a fine mesh is locking, not approximation
FIT_LEVELS = 4
TARGET = 1e-6  # error of the "time to reach" highlight
PRINTED = {"tip_angle_deg": 98.636, "tip_xz": (0.83419, 0.29063)}
BEND_DEFLECTION = 0.001
SERIES = ("scene", "element", "quadrature")


@dataclass(frozen=True)
class Case:
    name: str
    scene: Scene
    error: Callable[[Solution], float]
    reference: str


def run(quick: bool = False) -> dict:
    """Rows {scene, model, element, quadrature, elements, runtime_s, error, reference}, orders, highlights."""
    levels = QUICK_LEVELS if quick else LEVELS
    cases, checks = _cantilever_cases(quick)
    rows = [_level(case, el, order, n) for case in cases for el, order in CHOICES for n in levels]
    bend_rows, checks["three-point bend"] = _bend_rows(quick)
    rows += bend_rows
    contact_rows, checks[contact.CONVERGENCE_SCENE] = contact.convergence_rows(levels, best_of)
    rows += contact_rows
    return {
        "rows": rows,
        "orders": observed_orders(rows),
        "time_to_target": time_to_target(rows, TARGET),
        "p2_vs_hermite": side_by_side(rows),
        "references": checks,
        "notes": [
            "P2 with 3-point Gauss and P1 integrate the stiff shear and axial terms exactly and lock "
            "(error ~1 until h^2 E_e L^2/E_b << 1); P2 with 2-point Gauss does not.",
            "The cubic Hermite (the paper's element, 3-point Gauss) converges at order 4 where nothing "
            "is stiff (the circle) and locks like P1 on the E = 1e8 scenes.",
            "The three-point bend runs P2 with 2-point Gauss only (the half model is built on it); so does "
            "the tip on a wall (contact).",
            "Circle: error is the largest nodal position error; the tip closes to round-off on any "
            "uniform mesh (a Gauss rule on equal elements integrates a full period of sin, cos exactly).",
            f"Observed order: slope of log error against log h over the finest {FIT_LEVELS} levels with "
            f"error > {FLOOR:g}.",
        ],
    }


def _cantilever_cases(quick: bool) -> tuple[list[Case], dict]:
    L = S.L
    magnetic = S.magnetic(6.4, 120.0)
    n_ref = 128 if quick else 512
    fine = [tip_xz(solve_cantilever(magnetic, elements=n), L) for n in (n_ref, 2 * n_ref)]
    mag_ref = richardson(*fine)
    bvp = follow_elastica(Elastica(q=6.4, field_angle=math.radians(120.0)))
    theta_ref = math.degrees(tip_angle(solve_cantilever(magnetic, elements=2 * n_ref)))
    tip = follow_elastica(Elastica(force=(2.0, 0.0), E_s=S.STIFF, E_e=S.STIFF))
    checks = {
        "magnetic cantilever": {
            "method": f"Richardson (order 4) of P2 2-point tips on {n_ref} and {2 * n_ref} elements",
            "tip_xz": mag_ref,
            "tip_angle_deg": theta_ref,
            "printed": PRINTED,
            "minus_printed": mag_ref - np.array(PRINTED["tip_xz"]),
            "minus_elastica_bvp": mag_ref - bvp["tip"][:2],
            "richardson_correction": float(np.max(np.abs(mag_ref - fine[1]))),
        },
        "tip force": {
            "method": "planar rod BVP (solve_bvp, tol 1e-10) with E_s = E_e = 1e8 E_b/L^2",
            "tip_xz": tip["tip"][:2],
            "shooting_minus_collocation": tip["agreement"],
        },
        "circle": {"method": "closed form: arc of radius L/(2 pi)"},
    }
    cases = [
        Case(
            "magnetic cantilever",
            magnetic,
            lambda sol: _dist(tip_xz(sol, L), mag_ref),
            "Richardson extrapolation of fine P2 meshes (checked against printed digits and the BVP)",
        ),
        Case(
            "tip force",
            S.tip_force(2.0),
            lambda sol: _dist(tip_xz(sol, L), tip["tip"][:2]),
            "planar rod BVP (scipy solve_bvp, same E_s, E_e), checked by shooting",
        ),
        Case("circle", S.end_moment(1.0), _circle_error, "closed form (circular arc), largest nodal error"),
    ]
    return cases, checks


def _dist(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)))


def _circle_error(sol: Solution) -> float:
    exact = circle_shape(np.asarray(sol.s) / S.L, 1.0)
    return float(np.max(np.linalg.norm(np.asarray(sol.position)[:, [0, 2]] / S.L - exact, axis=1)))


def _level(case: Case, element: str, intorder: int, n: int) -> dict:
    """The case on ``n`` elements (best of 3), or the ConvergenceError it raised."""
    row = {
        "scene": case.name,
        "model": "planar",
        "element": element,
        "quadrature": QUADRATURE[intorder],
        "intorder": intorder,
        "elements": n,
        "reference": case.reference,
    }
    try:
        sol, runtime, _ = best_of(
            lambda: solve_cantilever(case.scene, elements=n, element=element, intorder=intorder)
        )
    except ConvergenceError as exc:
        return {**row, "runtime_s": None, "error": None, "status": f"raised ConvergenceError: {exc}"}
    return {
        **row,
        "model": sol.model,
        "runtime_s": runtime,
        "error": case.error(sol),
        "newton_iterations": sol.newton_iterations,
        "load_steps": sol.load_steps,
        "status": "ok",
    }


def _bend_rows(quick: bool) -> tuple[list[dict], dict]:
    geometry, (E_b, E_s, E_e) = S.bend_geometry(), S.BEND_E
    n_ref = 256 if quick else 1024
    force = [
        BendModel(geometry, elements=n).solve(E_b, E_s, E_e, [BEND_DEFLECTION]).force[-1]
        for n in (n_ref, 2 * n_ref)
    ]
    F_ref = float(richardson(np.array(force[0]), np.array(force[1])))
    check = {
        "method": f"Richardson (order 4) of BendModel on {n_ref} and {2 * n_ref} elements (P2 only)",
        "force_N": F_ref,
        "richardson_correction": abs(F_ref - force[1]) / F_ref,
    }
    rows = []
    for n in QUICK_BEND_LEVELS if quick else BEND_LEVELS:
        model = BendModel(geometry, elements=n)
        path, runtime, _ = best_of(lambda m=model: m.solve(E_b, E_s, E_e, [BEND_DEFLECTION]))
        rows.append(
            {
                "scene": "three-point bend",
                "model": "planar",
                "element": "P2",
                "quadrature": "2-point Gauss",
                "intorder": 2,
                "elements": n,
                "runtime_s": runtime,
                "error": abs(path.force[-1] - F_ref) / F_ref,
                "newton_iterations": path.newton_iterations,
                "load_steps": path.load_steps,
                "status": "ok",
                "reference": "Richardson extrapolation of fine-mesh BendModel (elements of the half model)",
            }
        )
    return rows, check


def _series(rows: list[dict]) -> dict[tuple[str, str, str], list[dict]]:
    """Rows by series (scene, element, quadrature)."""
    out: dict[tuple[str, str, str], list[dict]] = {}
    for row in rows:
        out.setdefault(tuple(row[k] for k in SERIES), []).append(row)
    return out


def observed_orders(rows: list[dict]) -> list[dict]:
    """Least-squares slope of log error against log h over the asymptotic range, per series."""
    out = []
    for key, series in _series(rows).items():
        pts = [(r["elements"], r["error"]) for r in series if r["error"] is not None and r["error"] > FLOOR]
        used = pts[-FIT_LEVELS:]
        order = None
        if len(used) >= 2:
            n, e = np.array(used, float).T
            order = float(np.polyfit(np.log(1.0 / n), np.log(e), 1)[0])
        local = [math.log2(a[1] / b[1]) for a, b in zip(pts, pts[1:], strict=False) if b[0] == 2 * a[0]]
        locked = [r["elements"] for r in series if r["error"] is not None and r["error"] > LOCKED]
        note = (
            f"locks: error > {LOCKED:g} up to {max(locked)} elements" if locked and max(locked) >= 8 else ""
        )
        out.append(
            {
                **dict(zip(SERIES, key, strict=True)),
                "observed_order": order,
                "levels": [int(u[0]) for u in used],
                "local_orders": local,
                "note": note,
            }
        )
    return out


def time_to_target(rows: list[dict], target: float) -> list[dict]:
    """Per series, the coarsest level whose error is <= target and its run time (None if none)."""
    out = []
    for key, series in _series(rows).items():
        hit = next((r for r in series if r["error"] is not None and r["error"] <= target), None)
        out.append(
            {
                **dict(zip(SERIES, key, strict=True)),
                "target": target,
                "elements": None if hit is None else hit["elements"],
                "runtime_s": None if hit is None else hit["runtime_s"],
            }
        )
    return out


def side_by_side(rows: list[dict], pair: tuple[str, str] = ("P2", "Hermite")) -> list[dict]:
    """Error and run time of the default P2 (2-point Gauss) and the Hermite, per scene and mesh."""
    default = {"P2": "2-point Gauss", "Hermite": "3-point Gauss"}
    cells = {
        (r["scene"], r["elements"], r["element"]): r
        for r in rows
        if r["quadrature"] == default.get(r["element"])
    }
    out = []
    for scene, n in dict.fromkeys((k[0], k[1]) for k in cells if k[2] == pair[1]):
        row = {"scene": scene, "elements": n}
        for element in pair:
            r = cells.get((scene, n, element), {})
            row[f"{element}_error"], row[f"{element}_runtime_s"] = r.get("error"), r.get("runtime_s")
        out.append(row)
    return out


def side_by_side_table(rows: list[dict]) -> str:
    """Plain-text :func:`side_by_side` (printed by ``matid bench``)."""

    def cell(v, f):
        return f"{'-':>9s}" if v is None else format(v, f)

    lines = [f"{'scene':22s} {'n':>4s} {'P2 error':>9s} {'P2 ms':>9s} {'Hermite':>9s} {'Herm. ms':>9s}"]
    for r in rows:
        p2, h = (r["P2_runtime_s"], r["Hermite_runtime_s"])
        lines.append(
            f"{r['scene']:22s} {r['elements']:4d} {cell(r['P2_error'], '9.1e')} "
            f"{cell(None if p2 is None else 1e3 * p2, '9.2f')} {cell(r['Hermite_error'], '9.1e')} "
            f"{cell(None if h is None else 1e3 * h, '9.2f')}"
        )
    return "\n".join(lines)
