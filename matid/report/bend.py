"""Figures of the three-point bend (E_s) fit, drawn from ``TestFit.info["plot_data"]``.

The E_s fitter leaves, per bend test (span), the measured loading branch ``d``, ``F``, the
fitted rod-model force ``model``, the Timoshenko force ``timoshenko`` at the fitted E_b and
E_s, the rod-model force ``plus10`` with E_s raised by 10 %, and the deformed ``shape`` at
the largest deflection (centreline ``z``, ``x`` with z along the span and x up, the tube's
outer radius, the support and nose cylinders as ``((z, x), radius)``), plus the residual
standard deviation ``noise_N``. This module only draws them:

Force against deflection
    measured points, the fitted rod model (line) and the Timoshenko formula with the same
    E_b and E_s (dashed), one colour per span: how far the fit is from the small-deflection
    formula used to start it.
Sensitivity to E_s
    ``plus10 - model`` against the deflection over bands of one and two noise standard
    deviations: where the curve leaves the bands, the data can tell a 10 % change of E_s.
Deformed shape at the largest deflection
    the tube (centreline and the outline at +-outer radius along the normal), the two
    supports and the nose, equal aspect, in mm.

Deflections and shapes are in mm in both unit systems; forces in N (SI) or dyn (cgs).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Polygon
from matplotlib.ticker import LogFormatter, NullFormatter

from matid.model.results import TestFit
from matid.report.figures import (
    COLOURS,
    DRAWING_MARGINS,
    FIT_SIZE,
    Drawing,
    Rect,
    axis_unit,
    data_axes,
    printable,
    quiet_legend,
    style_axes,
)
from matid.report.summary import SUPERSCRIPT

MM = 1e3
TUBE, CYLINDER, CYLINDER_EDGE = "#0072B2", "#d9dce1", "#555555"
PANEL_TITLE, PANEL_GAP = 0.22, 0.55  # inches above a shape panel for its title; between panels
ARRAYS = ("d", "F", "model", "timoshenko", "plus10")  # per curve, one value per loading point
TITLES = (
    "Force against deflection",
    "Sensitivity to E_s",
    "Deformed shape at the largest deflection",
)


@dataclass(frozen=True)
class Shape:
    z: np.ndarray  # m, along the span from mid-span
    x: np.ndarray  # m, up
    outer_radius: float
    deflection: float
    cylinders: tuple[tuple[float, float, float], ...]  # (z, x, radius): supports, then the nose
    support_contact_s: float | None


@dataclass(frozen=True)
class Curve:
    label: str
    span: float
    d: np.ndarray
    F: np.ndarray
    model: np.ndarray
    timoshenko: np.ndarray
    plus10: np.ndarray
    shape: Shape | None


@dataclass(frozen=True)
class BendPlots:
    curves: tuple[Curve, ...]
    noise: float | None


def bend_plots(plot_data: Mapping) -> BendPlots:
    """``info["plot_data"]`` checked and as arrays; ``ValueError`` names what is wrong."""
    raw = plot_data.get("curves")
    if not isinstance(raw, Sequence) or not raw:
        raise ValueError("plot_data has no curves")
    noise = plot_data.get("noise_N")
    noise = float(noise) if noise is not None and np.isfinite(noise) and noise > 0 else None
    return BendPlots(tuple(_curve(c, i) for i, c in enumerate(raw)), noise)


def _curve(raw: Mapping, index: int) -> Curve:
    where = f"plot_data curve {index + 1}"
    missing = [k for k in (*ARRAYS, "span") if k not in raw]
    if missing:
        raise ValueError(f"{where} has no {', '.join(missing)}")
    arrays = {k: np.asarray(raw[k], dtype=float).ravel() for k in ARRAYS}
    sizes = {a.size for a in arrays.values()}
    if len(sizes) != 1 or 0 in sizes:
        raise ValueError(f"{where}: d, F, model, timoshenko and plus10 differ in length or are empty")
    order = np.argsort(arrays["d"], kind="stable")
    arrays = {k: a[order] for k, a in arrays.items()}
    shape = _shape(raw["shape"], where) if raw.get("shape") else None
    return Curve(str(raw.get("label", f"test {index + 1}")), float(raw["span"]), shape=shape, **arrays)


def _shape(raw: Mapping, where: str) -> Shape:
    missing = [k for k in ("z", "x", "outer_radius", "deflection", "supports", "nose") if k not in raw]
    if missing:
        raise ValueError(f"{where}: shape has no {', '.join(missing)}")
    z, x = np.asarray(raw["z"], dtype=float), np.asarray(raw["x"], dtype=float)
    if z.shape != x.shape or z.ndim != 1 or z.size < 2 or not np.all(np.isfinite(z) & np.isfinite(x)):
        raise ValueError(f"{where}: shape z and x must be finite 1-d arrays of equal length")
    cylinders = tuple((float(c[0][0]), float(c[0][1]), float(c[1])) for c in [*raw["supports"], raw["nose"]])
    contact = raw.get("support_contact_s")
    contact = None if contact is None else float(contact)
    return Shape(z, x, float(raw["outer_radius"]), float(raw["deflection"]), cylinders, contact)


# -- the drawings ------------------------------------------------------------------------------


def bend_drawings(fit: TestFit, units: str = "SI") -> list[Drawing]:
    """The three bend figures of a three-point-bend ``fit`` (none without ``info["plot_data"]``)."""
    if not isinstance(fit.info.get("plot_data"), Mapping):
        return []
    plots = bend_plots(fit.info["plot_data"])

    def drawing(title: str, caption: str, alt: str, height: float, draw) -> Drawing:
        return Drawing(title, caption, f"{alt}, specimen {fit.specimen}", (FIT_SIZE[0], height), draw)

    draw = partial(draw_force, plots=plots, units=units)
    drawings = [drawing(TITLES[0], _force_caption(plots, units), "Force against nose deflection", 3.3, draw)]
    caption = _sensitivity_caption(plots, fit, units)
    draw = partial(draw_sensitivity, plots=plots, units=units)
    drawings.append(drawing(TITLES[1], caption, "Sensitivity to E_s", 3.0, draw))
    est = fit.estimate("E_s")
    fe = (est.extra.get("fe") if est else None) or {}
    if fe.get("levels"):
        stat = est.stderr / est.value if est.stderr else None  # relative statistical error of E_s
        alt = "Discretisation error of E_s against run time"
        draw = partial(draw_fe_levels, levels=fe["levels"], stat=stat)
        drawings.append(drawing("Error against run time", _fe_caption(fe, stat), alt, 2.8, draw))
    shaped = tuple(c for c in plots.curves if c.shape is not None)
    if shaped:
        alt = "Deformed tube at the largest deflection"
        draw = partial(draw_shapes, curves=shaped)
        drawings.append(drawing(TITLES[2], _shape_caption(shaped), alt, shape_height(shaped), draw))
    return drawings


class PowerFormatter(LogFormatter):
    """Log-axis labels as plain text, ``2×10⁻⁶``: the labels matplotlib's LogFormatter picks
    (decades; between them where an axis spans little), without mathtext, whose parsing made
    this figure cost twice another."""

    def __call__(self, x, pos=None) -> str:
        label = super().__call__(x, pos).replace("\N{MINUS SIGN}", "-")
        match = re.fullmatch(r"(\d(?:\.\d+)?)e([+-]?\d+)", label)
        if match is None:
            return label
        mantissa, power = match.group(1), "10" + str(int(match.group(2))).translate(SUPERSCRIPT)
        return power if mantissa == "1" else f"{mantissa}×{power}"


def draw_fe_levels(fig: Figure, rect: Rect, *, levels: Sequence[Mapping], stat: float | None) -> None:
    """Estimated relative error of E_s against the run time of one cold solve, per mesh level."""
    ax = data_axes(fig, rect, residuals=False)[0]
    t = [float(lv["runtime_s"]) for lv in levels]
    e = [max(float(lv["discretization_error"]), 1e-16) for lv in levels]
    ax.semilogy(t, e, "o-", color=COLOURS[0], linewidth=1.4, markersize=4)
    ax.yaxis.set_major_formatter(PowerFormatter())
    ax.yaxis.set_minor_formatter(PowerFormatter())
    for lv, ti, ei in zip(levels, t, e, strict=True):
        ax.annotate(f"{lv['elements']} P2", (ti, ei), textcoords="offset points", xytext=(5, 4), fontsize=7)
    if stat:  # the statistical error and the FE target, a tenth of it
        lines = {
            "statistical error of E_s (relative)": (stat, "#999999", "--"),
            "FE target: a tenth of it": (0.1 * stat, "#bbbbbb", ":"),
        }
        for level, colour, style in lines.values():
            ax.axhline(level, color=colour, linestyle=style, linewidth=1)
        handles = [Line2D([], [], color=colour, linestyle=style) for _, colour, style in lines.values()]
        quiet_legend(ax, handles, list(lines), fontsize=7, loc="upper right", framealpha=0.9)
    if max(t) > 20 * min(t):  # run times over decades: a log axis, labelled at the decades
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(PowerFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlim(min(t) / 1.5, max(t) * 1.5)
    else:  # a linear axis keeps its tick labels over a narrow range
        pad = max(0.5 * (max(t) - min(t)), 0.1 * max(t))
        ax.set_xlim(max(min(t) - pad, 0.0), max(t) + pad)
    ax.set_xlabel("run time of one solve of all curves [s]")
    ax.set_ylabel("discretisation error of E_s")
    style_axes(ax)


def _fe_caption(fe: Mapping, stat: float | None) -> str:
    rows = "; ".join(
        f"{lv['elements']} elements: error {float(lv['discretization_error']):.1e}, "
        f"{float(lv['runtime_s']):.3f} s"
        for lv in fe["levels"]
    )
    target = (
        f" The fit kept the mesh where the error is below a tenth of the statistical error ({stat:.1e})."
        if stat
        else ""
    )
    return (
        f"Richardson estimate (P2, order 4) of the relative discretisation error of E_s on each mesh "
        f"level, against the time of one solve of all force curves from scratch: {rows}.{target}"
    )


def _span(curve: Curve) -> str:
    return f"span {curve.span * MM:.4g} mm"


def draw_force(fig: Figure, rect: Rect, *, plots: BendPlots, units: str = "SI") -> None:
    """Measured points, the rod model and the Timoshenko formula against the deflection."""
    force = axis_unit("force [N]", units)
    ax = data_axes(fig, rect, residuals=False)[0]
    handles, labels = [], []
    for i, c in enumerate(plots.curves):
        colour = COLOURS[i % len(COLOURS)]
        d = c.d * MM
        ax.plot(d, c.F * force.factor, "o", color=colour, markersize=3, alpha=0.75)
        ax.plot(d, c.model * force.factor, "-", color=colour, linewidth=1.6)
        ax.plot(d, c.timoshenko * force.factor, "--", color=colour, linewidth=1.1)
        handles.append(Line2D([], [], color=colour, marker="o", markersize=4, linestyle="none"))
        labels.append(f"{c.label} ({_span(c)})")
    handles += [
        Line2D([], [], color="#333333", linewidth=1.6),
        Line2D([], [], color="#333333", linestyle="--"),
    ]
    labels += ["rod model, fitted E_s", "Timoshenko formula, same E_b and E_s"]
    quiet_legend(ax, handles, labels, fontsize=7, loc="upper left", framealpha=0.9)
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.set_xlabel("nose deflection [mm]")
    ax.set_ylabel(force.label.replace("force", "nose force"))
    style_axes(ax)


def draw_sensitivity(fig: Figure, rect: Rect, *, plots: BendPlots, units: str = "SI") -> None:
    """F(1.1 E_s) - F(E_s) against the deflection over bands of the residual noise."""
    force = axis_unit("force change [N]", units)
    ax = data_axes(fig, rect, residuals=False)[0]
    d_max = max(float(c.d.max()) for c in plots.curves) * MM
    bands = ((1, "#d5d9e0", "±1 σ of the residual noise"), (2, "#eceef2", "±2 σ")) if plots.noise else ()
    for k, shade, _ in reversed(bands):  # the wide band first, under the narrow one
        ax.axhspan(-k * plots.noise * force.factor, k * plots.noise * force.factor, color=shade, linewidth=0)
    handles = [Patch(color=shade) for _, shade, _ in bands]
    labels = [label for *_, label in bands]
    ax.axhline(0.0, color="#555555", linewidth=0.8)
    for i, c in enumerate(plots.curves):
        style = {"color": COLOURS[i % len(COLOURS)], "markersize": 2.5, "linewidth": 1.4}
        handles += ax.plot(c.d * MM, (c.plus10 - c.model) * force.factor, "o-", **style)
        labels.append(f"E_s + 10 %, {_span(c)}")
    quiet_legend(ax, handles, labels, fontsize=7, loc="upper left", framealpha=0.9)
    ax.set_xlim(0, d_max * 1.02)
    ax.set_xlabel("nose deflection [mm]")
    ax.set_ylabel(force.label)
    style_axes(ax)


def draw_shapes(fig: Figure, rect: Rect, *, curves: Sequence[Curve]) -> None:
    """One panel per span: the deformed tube, the supports and the nose, equal aspect, mm."""
    left, bottom, right, top = rect
    top -= PANEL_TITLE / fig.get_figheight()  # room for the first panel's title
    n = len(curves)
    axes_height = ((top - bottom) * fig.get_figheight() - (n - 1) * PANEL_GAP) / n
    grid = fig.add_gridspec(
        n, 1, left=left, right=right, bottom=bottom, top=top, hspace=PANEL_GAP / max(axes_height, 0.1)
    )
    for k, c in enumerate(curves):
        ax = fig.add_subplot(grid[k])
        _draw_shape(ax, c.shape, COLOURS[k % len(COLOURS)] if len(curves) > 1 else TUBE)
        title = f"{c.label}: {_span(c)}, nose deflection {c.shape.deflection * MM:#.3g} mm (arrow)"
        ax.set_title(printable(title), fontsize=8, loc="left", parse_math=False)
        ax.set_xlabel("z along the span [mm]" if k == len(curves) - 1 else "")
        ax.set_ylabel("x [mm]")
        style_axes(ax)
        ax.set_axisbelow(True)


def _draw_shape(ax, shape: Shape, colour: str) -> None:
    z, x, R = shape.z * MM, shape.x * MM, shape.outer_radius * MM
    ax.axhline(0.0, color="#9a9a9a", linewidth=0.8, linestyle=(0, (4, 3)), zorder=1)
    for cz, cx, r in shape.cylinders:
        centre = (cz * MM, cx * MM)
        ax.add_patch(Circle(centre, r * MM, fc=CYLINDER, ec=CYLINDER_EDGE, lw=0.9, zorder=2))
        ax.plot(*centre, "+", color=CYLINDER_EDGE, markersize=4, zorder=2)
    upper, lower = outline(z, x, R)
    tube = np.vstack([upper, lower[::-1]])
    ax.add_patch(Polygon(tube, closed=True, fc=colour, alpha=0.25, ec=colour, lw=0.9, zorder=3))
    ax.plot(z, x, "-", color=colour, linewidth=1.4, zorder=4)
    if shape.deflection > 0:  # the nose deflection, from the undeformed to the deformed centreline
        nose_z = shape.cylinders[-1][0] * MM
        arrow = {"arrowstyle": "->", "color": "#222222", "linewidth": 1.1, "shrinkA": 0, "shrinkB": 0}
        ax.annotate("", xy=(nose_z, -shape.deflection * MM), xytext=(nose_z, 0.0), arrowprops=arrow, zorder=5)
    (z0, z1), (x0, x1) = _extent(shape)
    ax.update_datalim([(z0, x0), (z1, x1)])
    ax.margins(0.03)
    ax.set_aspect("equal", adjustable="datalim")  # fill the panel: the spare room goes to the limits
    ax.autoscale_view()


def outline(z: np.ndarray, x: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The two edges of the tube, ``radius`` either side of the centreline along its normal."""
    tz, tx = np.gradient(z), np.gradient(x)
    norm = np.hypot(tz, tx)
    normal = np.column_stack([-tx, tz]) / np.where(norm == 0, 1.0, norm)[:, None]
    centre = np.column_stack([z, x])
    return centre + radius * normal, centre - radius * normal


def _extent(shape: Shape) -> tuple[tuple[float, float], tuple[float, float]]:
    """z and x limits (mm) holding the tube and the cylinders."""
    R = shape.outer_radius
    zs = [shape.z.min() - R, shape.z.max() + R] + [c[0] + s * c[2] for c in shape.cylinders for s in (-1, 1)]
    xs = [shape.x.min() - R, shape.x.max() + R] + [c[1] + s * c[2] for c in shape.cylinders for s in (-1, 1)]
    return (min(zs) * MM, max(zs) * MM), (min(xs) * MM, max(xs) * MM)


def shape_height(curves: Sequence[Curve]) -> float:
    """Figure height (inches) that gives every panel its equal-aspect height at the HTML width."""
    left, bottom, right, top = DRAWING_MARGINS
    width = FIT_SIZE[0] - left - right
    panels = 0.0
    for c in curves:
        (z0, z1), (x0, x1) = _extent(c.shape)
        panels += min(max(width * (x1 - x0) / (z1 - z0), 1.0), 4.0)
    return bottom + top + PANEL_TITLE + panels + PANEL_GAP * (len(curves) - 1)


# -- captions ----------------------------------------------------------------------------------


def _force_caption(plots: BendPlots, units: str) -> str:
    spans = "one colour per span; " if len(plots.curves) > 1 else ""
    return (
        f"Measured nose force on the loading branch (markers), the rod model at the fitted E_s (line) "
        f"and the Timoshenko small-deflection formula with the same E_b and E_s (dashed); {spans}"
        f"the gap between line and dashes is what the rod model adds to the small-deflection formula. "
        f"Deflection in mm, force in {'dyn' if units == 'cgs' else 'N'}."
    )


def _sensitivity_caption(plots: BendPlots, fit: TestFit, units: str) -> str:
    text = "Change of the model force when E_s is raised by 10 %, against the deflection"
    if plots.noise:
        sigma = f"{plots.noise * 1e5:.3g} dyn" if units == "cgs" else f"{plots.noise * 1e3:.3g} mN"
        text += (
            f", over bands of one and two standard deviations of the residual noise (σ = {sigma}). "
            "Where the curve leaves the ±2 σ band the data resolve a 10 % change of E_s; inside the "
            "band they cannot"
        )
    ratio = fit.info.get("sensitivity_to_noise")
    if isinstance(ratio, (int, float)) and np.isfinite(ratio):
        text += f". RMS force change / noise = {ratio:.3g}"
    return text + "."


def _shape_caption(curves: Sequence[Curve]) -> str:
    text = (
        "The deformed tube at the largest deflection from the fitted rod model (centreline and outline "
        "at the outer radius), the supports and the nose (grey), equal scales in mm; the dashed line "
        "is the undeformed centreline."
    )
    contacts = [c for c in curves if c.shape.support_contact_s is not None]
    if contacts:
        where = "; ".join(
            f"{c.shape.support_contact_s * MM:.3g} mm from mid-span (half span {c.span * MM / 2:.3g} mm)"
            for c in contacts
        )
        text += f" The tube touches each support at {where}."
    return text
