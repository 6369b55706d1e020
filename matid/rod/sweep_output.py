"""Present a sweep: ``sweep.csv``, ``sweep.json`` and ``workspace.png`` (contract section 13).

The rows are :func:`matid.rod.sweeps.rows` (SI, units in the column names). The picture draws the
tip positions (mm) and tip directions d3 of every converged state in the x-z and y-z views,
coloured by the first swept key (a vector key by its index in the list), the states along the
last key joined by a line; failed states are listed in the title.
"""

from __future__ import annotations

import csv
import io
import math
import textwrap

import numpy as np
from matplotlib.figure import Figure

from matid.rod.sweeps import Axis
from matid.units import SI_UNITS

MM = 1e3


def sweep_csv(rows: list[dict]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: "" if v is None else v for k, v in row.items()})
    return buffer.getvalue()


def sweep_json(axes: list[Axis], rows: list[dict]) -> dict:
    """Keys and their SI values, then the rows (NaN written as null)."""
    clean = [{k: None if isinstance(v, float) and math.isnan(v) else v for k, v in r.items()} for r in rows]
    keys = [
        {"key": a.key, "unit": a.columns()[0].split("[")[-1][:-1], "values": list(a.values)} for a in axes
    ]
    failed = sum(not r["converged"] for r in rows)
    return {"sweep": keys, "states": len(rows), "failed": failed, "rows": clean}


def workspace_png(axes: list[Axis], rows: list[dict], *, name: str = "", dpi: int = 120) -> bytes:
    buffer = io.BytesIO()
    workspace_figure(axes, rows, name=name).savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


def workspace_figure(axes: list[Axis], rows: list[dict], *, name: str = "") -> Figure:
    """The tips and d3 of a sweep's states, one panel per plane (x-z, and y-z when any tip leaves
    the x-z plane), coloured by the first key, the last key's states joined."""
    first = axes[0]
    colour = np.array(
        [list(first.values).index(v) if first.vector else v for v in _combos(axes, rows, 0)], float
    )
    tip = np.array([[r[f"tip_{c} [m]"] for c in "xyz"] for r in rows], float) * MM
    d3 = np.array([[r[f"d3_{c}"] for c in "xyz"] for r in rows], float)
    ok = np.array([r["converged"] for r in rows])
    views = (0, 1) if np.nanmax(np.abs(tip[:, 1]), initial=0.0) > 1e-9 * span_of(tip) else (0,)
    fig = Figure(figsize=(5.8 * len(views) + 1, 4.6), layout="constrained")
    panels = fig.subplots(1, len(views), squeeze=False)[0]
    span = span_of(tip)
    zoom, arrow = view(tip[ok], span)
    lane = len(axes[-1].values)
    for ax, c in zip(panels, views, strict=True):
        for start in range(0, len(rows), lane):  # the last key's states joined
            part = slice(start, start + lane)
            ax.plot(tip[part, c], tip[part, 2], color="0.8", lw=0.8, zorder=1)
        points = ax.scatter(tip[ok, c], tip[ok, 2], c=colour[ok], cmap="viridis", s=14, zorder=3)
        ax.quiver(
            tip[ok, c],
            tip[ok, 2],
            d3[ok, c],
            d3[ok, 2],
            colour[ok],
            cmap="viridis",
            angles="xy",
            scale_units="xy",
            scale=1.0 / arrow,
            width=0.003,
            zorder=2,
        )
        if not zoom:
            ax.plot([0], [0], "ks", ms=6)
        ax.set_xlabel(f"tip {'xy'[c]} (mm)")
        ax.set_ylabel("tip z (mm)")
        _frame(ax, tip[ok][:, [c, 2]], arrow * d3[ok][:, [c, 2]], clamp=not zoom)
        ax.grid(alpha=0.3)
    label = f"{first.key} ({'index in its list' if first.vector else SI_UNITS[first.kind]})"
    fig.colorbar(points, ax=panels, label=label)
    failed = int((~ok).sum())
    title = f"{name}: {len(rows)} states of {' x '.join(a.key for a in axes)}: tips and d3"
    title += f" (grey: along {axes[-1].key})"
    title += "; zoomed on the tips (the clamp, at 0, is outside the view)" if zoom else ""
    title += f"; {failed} failed (not drawn)" if failed else ""
    fig.suptitle(textwrap.fill(title, 60 * len(views)), color="C3" if failed else "k", fontsize=9)
    return fig


def _frame(ax, tip: np.ndarray, arrow: np.ndarray, *, clamp: bool) -> None:
    """Equal-aspect limits that hold every tip, the end of every d3 arrow (and the clamp when it is
    drawn), with a margin: the axes box takes the aspect (with ``adjustable="datalim"`` matplotlib
    trimmed the x range of a zoomed bent-lumen sweep, tips and arrows cut at the right edge)."""
    points = np.vstack([tip, tip + arrow] + ([np.zeros((1, 2))] if clamp else []))
    points = points[np.all(np.isfinite(points), axis=1)]
    if points.size:
        lo, hi = points.min(axis=0), points.max(axis=0)
        pad = 0.05 * max(float(np.max(hi - lo)), 1e-9)
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")


#: Tips spread over less than this share of their distance from the clamp are drawn zoomed in.
ZOOM = 0.1


def view(tip: np.ndarray, span: float) -> tuple[bool, float]:
    """(whether to zoom on the tips, the d3 arrows' length in mm): tips (mm) that spread over less
    than ZOOM of their distance ``span`` from the clamp (a lumen, a wall) are drawn without the
    clamp, with arrows scaled to their spread; else the clamp is shown and arrows scale with span."""
    finite = tip[np.all(np.isfinite(tip), axis=1)]
    extent = float(np.max(np.ptp(finite, axis=0))) if finite.size else 0.0
    zoom = 0.0 < extent < ZOOM * span
    return zoom, 0.08 * (2.0 * extent if zoom else span)


def span_of(tip: np.ndarray) -> float:
    """The largest tip coordinate (mm) of the converged states, 1 when none converged."""
    finite = np.abs(tip[np.isfinite(tip)])
    return float(finite.max()) if finite.size else 1.0


def _combos(axes: list[Axis], rows: list[dict], which: int) -> list:
    """The values of axis ``which`` in each row (the product order, last fastest)."""
    inner = math.prod(len(a.values) for a in axes[which + 1 :])
    values = axes[which].values
    return [values[(i // inner) % len(values)] for i in range(len(rows))]
