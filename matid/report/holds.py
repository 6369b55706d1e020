"""Force against time for extension runs with a hold (ramp-hold, relaxation).

A fitter that has the time base of its runs leaves it in ``TestFit.info["force_time"]``: a
list of ``{"label": str, "time": array [s], "force": array [N], "model": array [N]
(optional), "used": bool array (optional)}``, one entry per run. The strain plot hides a
hold (the strain stands still while the force relaxes); against time the relaxation shows,
and with it whether the model follows it. Runs without a hold are drawn too when given.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from matid.io.results import TestFit
from matid.report.figures import (
    COLOURS,
    EXCLUDED,
    FIT_SIZE,
    Drawing,
    Rect,
    axis_unit,
    quiet_legend,
    style_axes,
)

TITLE = "Force against time"


def hold_drawings(fit: TestFit, units: str = "SI") -> list[Drawing]:
    """The force-against-time drawing of ``fit`` (none without ``info["force_time"]``)."""
    runs = fit.info.get("force_time")
    if not runs:
        return []
    checked = [_run(r, i) for i, r in enumerate(runs)]
    model = any(r["model"] is not None for r in checked)
    caption = (
        "Measured force against time (markers)"
        + (" and the fitted model (lines)" if model else "")
        + ", one colour per run; hollow grey points are left out of the fit. "
        + f"Force in {'dyn' if units == 'cgs' else 'N'}, time in s."
    )
    return [
        Drawing(
            TITLE,
            caption,
            f"Force against time of the extension runs, specimen {fit.specimen}",
            (FIT_SIZE[0], 3.2),
            partial(draw_force_time, runs=checked, units=units),
        )
    ]


def _run(raw: Mapping, index: int) -> dict:
    where = f"force_time run {index + 1}"
    if not isinstance(raw, Mapping) or "time" not in raw or "force" not in raw:
        raise ValueError(f"{where} needs time and force")
    t, f = np.asarray(raw["time"], float).ravel(), np.asarray(raw["force"], float).ravel()
    model = None if raw.get("model") is None else np.asarray(raw["model"], float).ravel()
    used = np.ones(t.shape, bool) if raw.get("used") is None else np.asarray(raw["used"], bool).ravel()
    if not (t.size == f.size == used.size) or model is not None and model.size != t.size or t.size == 0:
        raise ValueError(f"{where}: time, force, model and used differ in length or are empty")
    return {"label": str(raw.get("label", f"run {index + 1}")), "t": t, "F": f, "model": model, "used": used}


def draw_force_time(fig: Figure, rect: Rect, *, runs: Sequence[dict], units: str = "SI") -> None:
    force = axis_unit("force [N]", units)
    left, bottom, right, top = rect
    ax = fig.add_axes((left, bottom, right - left, top - bottom))
    handles, labels = [], []
    for i, r in enumerate(runs):
        colour = COLOURS[i % len(COLOURS)]
        used, y = r["used"], r["F"] * force.factor
        ax.plot(r["t"][used], y[used], "o", color=colour, markersize=2.5, alpha=0.75)
        ax.plot(r["t"][~used], y[~used], "o", mfc="none", mec=EXCLUDED, markersize=2.5)
        if r["model"] is not None:
            ax.plot(r["t"], r["model"] * force.factor, "-", color=colour, linewidth=1.4)
        handles.append(Line2D([], [], color=colour, marker="o", markersize=4, linestyle="none"))
        labels.append(r["label"])
    if any(r["model"] is not None for r in runs):
        handles.append(Line2D([], [], color="#333333", linewidth=1.4))
        labels.append("model fit")
    quiet_legend(ax, handles, labels, fontsize=7, framealpha=0.9)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(force.label)
    style_axes(ax)
