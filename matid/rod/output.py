"""Present a solution: ``solution.json`` and ``shape.png`` (docs/contract.md section 6).

Nothing is computed here beyond unit changes for the picture (metres to mm).
The JSON is SI and extends the contract with ``element``, ``load_steps`` and
``terms`` (the energy terms that ran).
"""

from __future__ import annotations

import io

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from matid.rod.solve import Solution

MM = 1e3


def solution_json(sol: Solution) -> dict:
    """The solution as the JSON document of docs/contract.md section 6 (SI, lab frame)."""
    doc = {
        "scene": sol.scene.kind,
        "converged": bool(sol.converged),
        "model": sol.model,
        "elements": int(sol.elements),
        "element": sol.element,
        "newton_iterations": int(sol.newton_iterations),
        "load_steps": int(sol.load_steps),
        "runtime_s": float(sol.runtime_s),
        "terms": list(sol.terms),
        "s": _floats(sol.s),
        "position": _floats(sol.position),
        "d1": _floats(sol.d1),
        "d3": _floats(sol.d3),
        "tip": {key: _floats(value) for key, value in sol.tip.items()},
    }
    doc["field"] = {"B": _floats(sol.scene.loads.B)}  # the field used (solved for under [aim])
    if "aim" in sol.extra:
        doc["aim"] = dict(sol.extra["aim"])
    doc["warnings"] = list(sol.extra.get("warnings", []))
    if sol.three_point_bend is not None:
        doc["three_point_bend"] = {key: _floats(value) for key, value in sol.three_point_bend.items()}
    if sol.discretization_error is not None:
        doc["discretization_error"] = float(sol.discretization_error)  # relative, Richardson
        doc["error_estimate"] = sol.extra.get("error_estimate", {})
    return doc


def _floats(a: object) -> list:
    return np.asarray(a, dtype=float).tolist()


def shape_png(sol: Solution, *, dpi: int = 120) -> bytes:
    """PNG of the deformed centreline (mm), the undeformed rod dashed, the tip marked.

    Solutions in the x-z plane show that projection, others add the y-z view; a
    three-point bend shows the tube, its supports and the nose at the largest
    deflection, and the force against the deflection beside it.
    """
    bend = sol.three_point_bend is not None
    out_of_xz = np.abs(sol.position[:, 1]).max() > 1e-9 * sol.scene.rod.length  # e.g. a plane other than x-z
    panels = 2 if bend or sol.model != "planar" or out_of_xz else 1
    fig = Figure(figsize=(5.5 * panels, 4.2), layout="constrained")
    axes = fig.subplots(1, panels, squeeze=False)[0]
    _centreline(axes[0], sol, 0, "x")
    if bend:
        _bend_setup(axes[0], sol)
        _force_curve(axes[1], sol.three_point_bend)
    elif panels == 2:
        _centreline(axes[1], sol, 1, "y")
    warned = bool(sol.extra.get("warnings"))
    fig.suptitle(shape_title(sol), color="C3" if warned else "black", fontsize=9 if warned else None)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


def shape_title(sol: Solution) -> str:
    """The picture's title: scene, model, mesh; the first strain warning and how many more."""
    kind = sol.scene.kind.replace("_", " ")
    title = f"{kind}: {sol.model} model, {sol.elements} {sol.element} elements"
    warnings = sol.extra.get("warnings", [])
    if warnings:  # never silent (contract section 9)
        title += f"\nWARNING: {warnings[0]}" + (f" (+{len(warnings) - 1} more)" if len(warnings) > 1 else "")
    return title


def _centreline(ax, sol: Solution, component: int, name: str) -> None:
    """The projection of the centreline onto the (z, component) plane, equal aspect."""
    z, v = sol.position[:, 2] * MM, sol.position[:, component] * MM
    ax.plot(sol.s * MM, np.zeros_like(sol.s), "--", color="0.6", lw=1, label="straight reference")
    ax.plot(z, v, "-", color="C0", lw=2, label="deformed")
    end = "rod end (s = L)" if sol.scene.kind == "three_point_bend" else "tip (s = L)"  # a bend has no tip
    ax.plot(z[-1], v[-1], "o", color="C3", ms=5, label=end)
    ax.set_xlabel("z [mm]")
    ax.set_ylabel(f"{name} [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize=8)


def _bend_setup(ax, sol: Solution) -> None:
    """Supports and nose (rigid cylinders) at the largest deflection, and the tube outline +-R_o."""
    rod, bend = sol.scene.rod, sol.scene.bend
    R_o, L = 0.5 * rod.outer_diameter, rod.length
    d = bend.deflections[-1]
    cylinders = [
        ((-(bend.support_radius + R_o)), L / 2 + sign * bend.span / 2, bend.support_radius)
        for sign in (-1, 1)
    ]
    cylinders.append((bend.nose_radius + R_o - d, L / 2, bend.nose_radius))
    for x, z, radius in cylinders:
        ax.add_patch(Circle((z * MM, x * MM), radius * MM, facecolor="0.85", edgecolor="0.3"))
    for sign in (-1, 1):
        outline = (sol.position + sign * R_o * sol.d1) * MM
        ax.plot(outline[:, 2], outline[:, 0], "-", color="C0", lw=0.6)
    ax.autoscale_view()


def _force_curve(ax, table: dict) -> None:
    d, F = np.asarray(table["deflection"]) * MM, np.asarray(table["force"])
    ax.plot(np.concatenate([[0.0], d]), np.concatenate([[0.0], F]), "o-", color="C0", ms=4)
    ax.set_xlabel("nose deflection [mm]")
    ax.set_ylabel("nose force [N]")
    ax.grid(True, lw=0.3)
