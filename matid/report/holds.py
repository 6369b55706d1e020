"""Force against time for extension runs (ramp, ramp-hold, relaxation) with the model and residuals.

The extension fitter leaves the time base of its runs in ``TestFit.info["plot_data"]
["force_time"]``: per run name ``{"time_s", "force_N", "model_N", "used"}`` (arrays, SI); a
fitter may instead give ``info["force_time"]``, a list of ``{"label", "time", "force",
"model" (optional), "used" (optional)}``. Against strain a hold is a vertical line (the
strain stands still while the force relaxes); against time the relaxation shows, and with
it whether the model follows it: the residual panel below shows force minus model.

The model drawn is the one that gives E_e: the SLS, or the Prony series when the fit's BIC
prefers it (``prony_N`` per run and the model's name in ``plot_data["model"]``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from matid.model.results import TestFit
from matid.report.figures import (
    COLOURS,
    EXCLUDED,
    FIT_SIZE,
    Drawing,
    Rect,
    axis_unit,
    data_axes,
    quiet_legend,
    style_axes,
)

TITLE = "Force against time"


def hold_drawings(fit: TestFit, units: str = "SI") -> list[Drawing]:
    """The force-against-time drawing of ``fit`` (none without time-based plot data)."""
    runs = _runs_of(fit.info)
    if not runs:
        return []
    checked = [_run(r, i) for i, r in enumerate(runs)]
    model = any(r["model"] is not None for r in checked)
    fitted = (
        f" and the {model_name(fit.info)} (lines), residuals (measured minus model) below" if model else ""
    )
    caption = (
        f"Measured force against time (markers){fitted}; one colour per run; hollow grey points are left out "
        f"of the fit. Force in {'dyn' if units == 'cgs' else 'N'}, time in s."
    )
    alt = f"Force against time of the extension runs, specimen {fit.specimen}"
    draw = partial(draw_force_time, runs=checked, units=units)
    return [Drawing(TITLE, caption, alt, (FIT_SIZE[0], 4.2 if model else 3.2), draw)]


def model_name(info: Mapping) -> str:
    """Which model the drawn curve is: the SLS, or the Prony series BIC preferred."""
    plot = info.get("plot_data")
    if isinstance(plot, Mapping) and plot.get("model"):
        return f"fitted {plot['model']}"
    choice = info.get("model_choice")
    arms = choice.get("arms_preferred") if isinstance(choice, Mapping) else None
    if isinstance(arms, int) and arms > 1:
        return f"fitted SLS model (BIC prefers a {arms}-arm Prony series, whose curve the fit does not give)"
    return "fitted SLS model (standard linear solid)"


def _runs_of(info: Mapping) -> list[Mapping]:
    """The runs of ``info["force_time"]`` or of the fitter's ``info["plot_data"]["force_time"]``."""
    if info.get("force_time"):
        return list(info["force_time"])
    plot = info.get("plot_data")
    runs = plot.get("force_time") if isinstance(plot, Mapping) else None
    if not isinstance(runs, Mapping):
        return []
    return [
        {
            "label": name,
            "time": r["time_s"],
            "force": r["force_N"],
            "model": r.get("prony_N", r.get("model_N")),  # the model that gives E_e
            "model_name": plot.get("model", "SLS model fit"),
            "used": r.get("used"),
        }
        for name, r in runs.items()
        if isinstance(r, Mapping) and {"time_s", "force_N"} <= r.keys()
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
    label = str(raw.get("label", f"run {index + 1}"))
    name = str(raw.get("model_name", "SLS model fit"))
    return {"label": label, "t": t, "F": f, "model": model, "model_name": name, "used": used}


def draw_force_time(fig: Figure, rect: Rect, *, runs: Sequence[dict], units: str = "SI") -> None:
    force = axis_unit("force [N]", units)
    model = any(r["model"] is not None for r in runs)
    ax, ax_res = data_axes(fig, rect, model)
    handles, labels = [], []
    for i, r in enumerate(runs):
        colour = COLOURS[i % len(COLOURS)]
        used, y = r["used"], r["F"] * force.factor
        ax.plot(r["t"][used], y[used], "o", color=colour, markersize=2.5, alpha=0.75)
        ax.plot(r["t"][~used], y[~used], "o", mfc="none", mec=EXCLUDED, markersize=2.5)
        if r["model"] is not None:
            ax.plot(r["t"], r["model"] * force.factor, "-", color=colour, linewidth=1.4)
            residual = (r["F"] - r["model"]) * force.factor
            ax_res.plot(r["t"][used], residual[used], "o", color=colour, markersize=2, alpha=0.75)
        handles.append(Line2D([], [], color=colour, marker="o", markersize=4, linestyle="none"))
        labels.append(r["label"])
    if model:
        handles.append(Line2D([], [], color="#333333", linewidth=1.4))
        labels.append(next(r["model_name"] for r in runs if r["model"] is not None))
    if any((~r["used"]).any() for r in runs):
        handles.append(Line2D([], [], linestyle="none", marker="o", mfc="none", mec=EXCLUDED))
        labels.append("left out of the fit")
    quiet_legend(ax, handles, labels, fontsize=7, framealpha=0.9)
    ax.set_ylabel(force.label)
    (ax_res or ax).set_xlabel("time [s]")
    if ax_res is not None:
        ax_res.axhline(0.0, color="#555555", linewidth=0.8)
        ax_res.set_ylabel(f"residual [{force.unit}]")
        ax.tick_params(labelbottom=False)
        style_axes(ax_res)
    style_axes(ax)
