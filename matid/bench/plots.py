"""Figures of the bench (PNG bytes), drawn on :class:`matplotlib.figure.Figure` (no pyplot state)."""

from __future__ import annotations

import io

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

STYLE = {
    ("P2", "2-point Gauss"): ("C0", "o-"),
    ("P2", "3-point Gauss"): ("C1", "s--"),
    ("P1", "2-point Gauss"): ("C2", "^:"),
}


def _png(fig: Figure) -> bytes:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    return buffer.getvalue()


def _series(rows: list[dict]) -> dict[str, dict[tuple[str, str], list[dict]]]:
    out: dict[str, dict[tuple[str, str], list[dict]]] = {}
    for row in rows:
        if row.get("error") is None or row["error"] <= 0:
            continue
        out.setdefault(row["scene"], {}).setdefault((row["element"], row["quadrature"]), []).append(row)
    return out


def convergence_figure(rows: list[dict], x: str) -> bytes:
    """Error against ``x`` ("runtime_s" or "elements"): a panel per scene, a line per element/quadrature."""
    scenes = _series(rows)
    rows_of_panels = max(1, -(-len(scenes) // 2))
    fig = Figure(figsize=(10, 3.75 * rows_of_panels), layout="constrained")
    axes = fig.subplots(rows_of_panels, 2, squeeze=False).ravel()
    for ax, (scene, series) in zip(axes, scenes.items(), strict=False):
        for (element, quad), pts in series.items():
            colour, style = STYLE.get((element, quad), ("C3", "x-"))
            ax.loglog(
                [p[x] for p in pts],
                [p["error"] for p in pts],
                style,
                color=colour,
                ms=4,
                label=f"{element}, {quad}",
            )
        if x == "elements":
            n = np.array([p["elements"] for p in series.get(("P2", "2-point Gauss"), [])], float)
            if n.size:
                e0 = series[("P2", "2-point Gauss")][0]["error"]
                ax.loglog(n, e0 * (n / n[0]) ** -4.0, color="0.6", lw=0.8, label="slope -4")
        ax.xaxis.set_minor_formatter(NullFormatter())  # narrow ranges would print overlapping minor labels
        _label_narrow_log_axis(ax)
        ax.set_title(scene, fontsize=10)
        ax.set_xlabel("run time [s] (best of 3)" if x == "runtime_s" else "elements")
        ax.set_ylabel("error (relative)")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7)
    for ax in axes[len(scenes) :]:
        ax.set_visible(False)
    title = "error against run time" if x == "runtime_s" else "error against elements"
    fig.suptitle(f"Convergence: {title}")
    return _png(fig)


def _label_narrow_log_axis(ax) -> None:
    """Label 1, 2, 3 and 5 times the decades, as plain numbers, when the x range spans less than
    two decades: the decade labels alone would leave such an axis with one label or none."""
    low, high = ax.get_xlim()
    if low > 0 and high / low < 100:
        ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 3.0, 5.0)))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))


def penalty_figure(rows: list[dict]) -> bytes | None:
    """Raw-quaternion variant: error and Newton iterations against c_u."""
    raw = [r for r in rows if r["family"] == "raw-quaternion penalty" and r.get("error") is not None]
    if not raw:
        return None
    c_u = np.array([r["parameters"]["c_u (scaled)"] for r in raw])
    fig = Figure(figsize=(7, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.loglog(c_u, [r["error"] for r in raw], "o-", color="C0", label="raw q: tip error vs normalised")
    ax.loglog(c_u, 1.4 / c_u, "--", color="0.6", lw=0.8, label="1.4 / c_u")
    ax.set_xlabel("c_u (scaled)")
    ax.set_ylabel("tip error / L")
    ax.grid(True, which="both", lw=0.3)
    twin = ax.twinx()
    twin.semilogx(c_u, [r["newton_iterations"] for r in raw], "s:", color="C3", label="Newton iterations")
    twin.set_ylabel("Newton iterations", color="C3")
    lines = ax.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
    ax.legend(lines, [h.get_label() for h in lines], fontsize=8, loc="upper center")
    fig.suptitle("Paper's raw-quaternion penalty (3D scene, 16 elements)")
    return _png(fig)
