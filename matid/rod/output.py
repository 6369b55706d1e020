"""Present a solution: ``solution.json`` and ``shape.png`` (docs/contract.md section 6).

Nothing is computed here beyond unit changes for the picture (metres to mm).
The JSON is SI and extends the contract with ``element``, ``load_steps`` and
``terms`` (the energy terms that ran).
"""

from __future__ import annotations

import io
import textwrap

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from matid.rod.cantilever import Solution

MM = 1e3
#: The unit of every number in ``solution.json`` (SI), by key; directors are unit vectors.
UNITS = {
    "s": "m",
    "position": "m",
    "d1": "1",
    "d3": "1",
    "tip.position": "m",
    "tip.d1": "1",
    "tip.d3": "1",
    "field.B": "T",
    "runtime_s": "s",
    "discretization_error": "1 (relative: tip position over the rod length, bend forces over the largest)",
    "three_point_bend.deflection": "m",
    "three_point_bend.force": "N",
    "three_point_bend.support_contact_s": "m",
    "aim.tip_direction_error_rad": "rad",
    "aim.runtime_s": "s",
}
#: The units of the [advance] keys (contract section 12), listed only under [advance].
ADVANCE_UNITS = {"free_length": "m", "steps.free_length": "m", "steps.tip.position": "m", "steps.position": "m",
                 "steps.contacts.force": "N"}  # fmt: skip
#: The units of the contact keys (contract section 12), listed only in solutions that have them.
CONTACT_UNITS = {
    "contacts.s": "m",
    "contacts.position": "m",
    "contacts.force": "N",
    "contacts.gap_min": "m",
    "contact_tolerance": "m",
}


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
        "units": dict(UNITS),
    }
    doc["field"] = {"B": _floats(sol.scene.loads.B)}  # the field used (solved for under [aim])
    if "aim" in sol.extra:
        doc["aim"] = dict(sol.extra["aim"])
    doc["warnings"] = list(sol.extra.get("warnings", []))
    if "contacts" in sol.extra:  # contract section 12
        doc["contacts"] = [dict(c) for c in sol.extra["contacts"]]
        doc["contact_tolerance"] = float(sol.extra["contact_tolerance"])
        doc["units"].update(CONTACT_UNITS)
    if sol.three_point_bend is not None:
        doc["three_point_bend"] = {key: _floats(value) for key, value in sol.three_point_bend.items()}
    if "steps" in sol.extra:  # [advance]: the top level is the last step (contract section 12)
        doc["free_length"] = float(sol.extra["free_length"])
        doc["steps"] = [dict(step) for step in sol.extra["steps"]]
        doc["units"].update(ADVANCE_UNITS)
    if sol.discretization_error is not None:
        doc["discretization_error"] = float(sol.discretization_error)  # relative, Richardson
        doc["error_estimate"] = sol.extra.get("error_estimate", {})
    return doc


def _floats(a: object) -> list:
    return np.asarray(a, dtype=float).tolist()


def shape_png(sol: Solution, *, dpi: int = 120, name: str = "") -> bytes:
    """PNG of the deformed centreline (mm), the undeformed rod dashed, the tip marked, the loads
    drawn (the field's direction and strength, magnets, tip and point forces); ``name``: the
    scene's, in the title.

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
    else:
        _loads(axes[0], sol, 0)
        _contacts(axes[0], sol, 0)
        if panels == 2:
            _centreline(axes[1], sol, 1, "y")
            _loads(axes[1], sol, 1)
            _contacts(axes[1], sol, 1)
    warned = bool(sol.extra.get("warnings"))
    title = shape_title(sol, name)
    fig.suptitle(title, color="C3" if warned else "black", fontsize=9 if warned else None)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


def shape_title(sol: Solution, name: str = "") -> str:
    """The picture's title: scene name and kind, model, mesh, the field; the first strain warning
    and how many more."""
    kind = sol.scene.kind.replace("_", " ")
    B = np.asarray(sol.scene.loads.B, dtype=float)
    field = f", |B| = {np.linalg.norm(B) * 1e3:.4g} mT" if B.any() else ""
    mesh = f"{sol.model} model, {sol.elements} {sol.element} elements"
    title = f"{name + ': ' if name else ''}{kind}, {mesh}{field}"
    warnings = sol.extra.get("warnings", [])
    if warnings:  # never silent (contract section 9); wrapped to the width of one panel
        more = f" (+{len(warnings) - 1} more)" if len(warnings) > 1 else ""
        title += "\n" + textwrap.fill(f"WARNING: {warnings[0]}{more}", width=72)
    return title


def _centreline(ax, sol: Solution, component: int, name: str) -> None:
    """The projection of the centreline onto the (z, component) plane, equal aspect."""
    z, v = sol.position[:, 2] * MM, sol.position[:, component] * MM
    ax.plot(sol.s * MM, np.zeros_like(sol.s), "--", color="0.6", lw=1, label="straight reference")
    steps = sol.extra.get("steps", [])[:-1]  # [advance]: the earlier steps, faded (contract section 12)
    for k, step in enumerate(steps):
        P = np.asarray(step["position"]) * MM
        label = f"earlier steps ({len(steps)})" if k == 0 else None
        ax.plot(P[:, 2], P[:, component], "-", color=f"C{k % 10}", lw=1.2, alpha=0.45, label=label)
    ax.plot(z, v, "-", color="C0", lw=2, label="deformed" if not steps else "last step")
    end = "rod end (s = L)" if sol.scene.kind == "three_point_bend" else "tip (s = L)"  # a bend has no tip
    ax.plot(z[-1], v[-1], "o", color="C3", ms=5, label=end)
    ax.set_xlabel("z [mm]")
    ax.set_ylabel(f"{name} [mm]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize=8)


def _loads(ax, sol: Solution, component: int) -> None:
    """The loads in the (z, component) view: the field's direction as an arrow in the corner,
    lumped magnets as squares, tip and point forces as arrows at their points (length: a fifth
    of the rod for the largest)."""
    loads, L = sol.scene.loads, sol.scene.rod.length
    B = np.asarray(loads.B, dtype=float)
    if B.any() and np.hypot(B[2], B[component]) > 1e-12 * np.linalg.norm(B):
        u = np.array([B[2], B[component]]) / np.linalg.norm(B)
        arrow = {"arrowstyle": "->", "color": "C2", "lw": 1.5}
        tip = (0.12 + 0.08 * u[0], 0.85 + 0.08 * u[1])
        ax.annotate("", xy=tip, xytext=(0.12, 0.85), xycoords="axes fraction", arrowprops=arrow)
        ax.text(0.12, 0.95, f"B {np.linalg.norm(B) * 1e3:.3g} mT", transform=ax.transAxes, color="C2",
                fontsize=7, ha="center")  # fmt: skip
    where = lambda s: int(np.argmin(np.abs(sol.s - s)))  # noqa: E731
    for k, (start, end, _) in enumerate(loads.magnetization):
        inside = (sol.s >= start) & (sol.s <= end)
        ax.plot(sol.position[inside, 2] * MM, sol.position[inside, component] * MM, "-", color="C2",
                lw=5, alpha=0.45, label="magnetised" if k == 0 else None)  # fmt: skip
    for at, _ in loads.magnets:
        i = where(at)
        ax.plot(sol.position[i, 2] * MM, sol.position[i, component] * MM, "s", color="C2", ms=6,
                label="magnet" if at == loads.magnets[0][0] else None)  # fmt: skip
    forces = [(L, np.asarray(loads.tip_force, dtype=float))] if any(loads.tip_force) else []
    forces += [(at, np.asarray(F, dtype=float)) for at, F, _ in loads.point_loads if any(F)]
    largest = max((np.linalg.norm(F) for _, F in forces), default=0.0)
    for k, (at, F) in enumerate(forces):
        i, scale = where(at), 0.2 * L / largest
        z, v = sol.position[i, 2], sol.position[i, component]
        tail = ((z - F[2] * scale) * MM, (v - F[component] * scale) * MM)
        ax.annotate(
            "", xy=(z * MM, v * MM), xytext=tail, arrowprops={"arrowstyle": "->", "color": "C1", "lw": 1.5}
        )
        if k == 0:
            ax.plot([], [], "-", color="C1", label="dead force (arrow: direction)")
    if loads.magnets or loads.magnetization or forces:
        ax.legend(loc="best", fontsize=8)


def _contacts(ax, sol: Solution, component: int) -> None:
    """Walls (their trace in the view, grey), the lumen's centreline and its two walls in the view,
    and the contact forces as red arrows (length: a fifth of the rod for the largest)."""
    scene, L = sol.scene, sol.scene.rod.length
    if not scene.walls and scene.lumen is None:
        return
    fixed = {"scalex": False, "scaley": False}
    view = ax.dataLim.frozen()  # the rod's steps set the view (with a margin), not the boundaries
    for k, wall in enumerate(scene.walls):
        p, n = np.asarray(wall.point) * MM, np.asarray(wall.normal)
        t = np.array([-n[component], n[2]])  # along the wall in the (z, component) view
        if np.hypot(*t) < 1e-12:
            continue
        t = t / np.hypot(*t)
        span = 2.0 * L * MM
        zs, vs = p[2] + span * np.array([-t[0], t[0]]), p[component] + span * np.array([-t[1], t[1]])
        ax.plot(zs, vs, "-", color="0.4", lw=3, alpha=0.5, label="wall" if k == 0 else None, **fixed)
    if scene.lumen is not None:
        for k, (c, walls) in enumerate(_lumen_view(scene.lumen, component, L)):
            ax.plot(
                c[:, 0],
                c[:, 1],
                ":",
                color="0.4",
                lw=1,
                label="lumen centreline" if k == 0 else None,
                **fixed,
            )
            for w in walls:
                ax.plot(
                    w[:, 0],
                    w[:, 1],
                    "-",
                    color="0.4",
                    lw=2,
                    alpha=0.5,
                    label="lumen" if k == 0 and w is walls[0] else None,
                    **fixed,
                )
    earlier = [(c, 0.4) for step in sol.extra.get("steps", [])[:-1] for c in step["contacts"]]
    contacts = sol.extra.get("contacts", [])
    drawn = earlier + [(c, 1.0) for c in contacts]
    largest = max((np.linalg.norm(c["force"]) for c, _ in drawn), default=0.0)
    for c, alpha in drawn:
        P, Fv = np.asarray(c["position"]), np.asarray(c["force"]) * 0.2 * L / max(largest, 1e-300)
        ax.annotate("", xy=((P[2] + Fv[2]) * MM, (P[component] + Fv[component]) * MM),
                    xytext=(P[2] * MM, P[component] * MM),
                    arrowprops={"arrowstyle": "->", "color": "C3", "lw": 2, "alpha": alpha})  # fmt: skip
    if drawn:
        ax.plot([], [], "-", color="C3", label="contact force")
    pad = 0.15 * max(view.width, view.height)
    ax.dataLim.set(view)
    ax.update_datalim([(view.x0 - pad, view.y0 - pad), (view.x1 + pad, view.y1 + pad)])
    ax.autoscale_view()
    ax.legend(loc="best", fontsize=8)


def _lumen_view(lumen, component: int, L: float) -> list[tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]]:
    """Per piece of the lumen's centreline (its straight pieces, the first and last continued by L as
    the vessel is open, and its arcs), the (z, component) view in mm of the centreline and of its two
    walls: offset by the radius across the piece's direction in the view (a tube's outline)."""
    line = lumen.line()
    pieces = []
    last = len(line.lines) - 1
    for k, (a, b) in enumerate(line.lines):
        t = (b - a) / np.linalg.norm(b - a)
        pieces.append(np.linspace(a - (L * t if k == 0 else 0.0), b + (L * t if k == last else 0.0), 40))
    for centre, Rc, A, B, axis in line.arcs:
        u0 = (A - centre) / Rc
        w0 = np.cross(axis, u0)
        span = np.arctan2(np.cross(u0, B - centre) @ axis, u0 @ (B - centre))
        phi = np.linspace(0.0, span, 60)
        pieces.append(centre + Rc * (np.outer(np.cos(phi), u0) + np.outer(np.sin(phi), w0)))
    out = []
    for P in pieces:
        c = P[:, [2, component]] * MM
        t = np.gradient(c, axis=0)
        norm = np.hypot(t[:, 0], t[:, 1])
        if norm.min() < 1e-12 * max(1.0, float(np.abs(c).max())):  # seen end-on: its outline is a circle
            continue
        n = np.column_stack([-t[:, 1], t[:, 0]]) / norm[:, None] * lumen.radius * MM
        out.append((c, (c + n, c - n)))
    return out


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
