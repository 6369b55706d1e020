"""Figures of the report: each fit's data and model with the residuals below, and extra figures.

Figures are built on :class:`matplotlib.figure.Figure` directly, never through pyplot, so the
report touches no global plotting state and needs no interactive backend.

The fit plot
    One colour per :class:`~matid.model.results.Series`: markers for the measured ``y``, a line for
    ``y_fit`` over the points in the fit (dashed and light over points outside it), points with
    ``used == False`` hollow grey, labelled "excluded from fit". The residual ``y - y_fit``
    sits below on a shared x axis. Axis labels come from ``TestFit.x_label`` / ``y_label``
    (``"name [unit]"`` in SI); for ``units="cgs"`` the units with a plain cgs counterpart
    (N, N m, N m^2, N s, m, 1/m) are converted, units common to both systems (s, rad, deg,
    mm, ...) stay, and anything else stays SI and the caption says so.

Extra figures: the ``TestFit.info["figures"]`` hook
    A fitter may attach figures of its own (error against run time, say). The preferred form
    is a list of ``(title, png_bytes)`` pairs::

        info["figures"] = [("Error against run time", png_bytes), ...]

    where ``png_bytes`` is a whole PNG file (about 7.5 in wide at 110 dpi renders best; the
    report scales it to the page). Also accepted: ``(title, callable)`` or a bare callable
    that takes no argument and returns a ``matplotlib.figure.Figure`` (called once per
    report), and ``(title, Figure)`` or a bare ``Figure``. An entry of another type, bytes
    that are not PNG, or a callable that raises, is shown in the report as "figure could not
    be drawn" with the reason: an extra figure never makes the report fail. The ``figures``
    key is not listed among the fit's info items.

Drawings
    Figures the report draws itself from arrays a fitter leaves in ``info`` (the bend
    figures of :mod:`matid.report.bend`) are :class:`Drawing` objects: a function that draws
    into a rectangle of a Figure, rendered once to PNG (:mod:`matid.report.images`) and placed on
    the HTML page and the PDF page alike.
"""

from __future__ import annotations

import io
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from matid.model.results import Series, TestFit

DPI = 110
FIT_SIZE = (7.5, 5.0)  # inches, for the HTML image
#: Okabe-Ito colours (colour-blind safe), yellow left out for contrast on white.
COLOURS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")
EXCLUDED = "#9a9a9a"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

#: SI unit -> (cgs unit, factor) for axis units with a plain cgs counterpart.
CGS_AXIS_UNITS: dict[str, tuple[str, float]] = {
    "N": ("dyn", 1e5),
    "mN": ("dyn", 1e2),
    "N m": ("dyn cm", 1e7),
    "mN m": ("dyn cm", 1e4),
    "N mm": ("dyn cm", 1e4),
    "N m^2": ("dyn cm^2", 1e9),
    "N s": ("dyn s", 1e5),
    "m": ("cm", 1e2),
    "1/m": ("1/cm", 1e-2),
    "rad/m": ("rad/cm", 1e-2),
}
#: Units that read the same in SI and cgs: never converted, never flagged.
NEUTRAL_UNITS = {"", "1", "-", "%", "s", "ms", "min", "rad", "deg", "mm", "um", "T", "mT", "G"}


@dataclass(frozen=True)
class AxisUnit:
    label: str  # the label to print
    factor: float  # multiply SI data by this
    kept_si: str | None = None  # the SI unit left unconverted in a cgs report
    unit: str = ""  # the unit printed in the label


#: Units shown with a smaller prefix when the data are small: (unit, below this peak, prefixed, factor).
#: Lengths are always in mm, like the other figures of the report.
PREFIXES: tuple[tuple[str, float, str, float], ...] = (
    ("m", float("inf"), "mm", 1e3),
    ("cm", float("inf"), "mm", 10.0),
    ("N m", 0.1, "mN m", 1e3),
    ("N m^2", 1e-2, "N mm^2", 1e6),
    ("N", 1e-2, "mN", 1e3),
)


def _prefixed(name: str, unit: str, factor: float, peak: float | None) -> AxisUnit:
    for base, below, prefixed, scale in PREFIXES:
        if unit == base and (peak is None and below == float("inf") or peak is not None and peak < below):
            return AxisUnit(f"{name} [{prefixed}]", factor * scale, None, prefixed)
    return AxisUnit(f"{name} [{unit}]", factor, None, unit)


@dataclass(frozen=True)
class ExtraFigure:
    """An extra figure of a fit, rendered to PNG (or the reason it could not be)."""

    title: str
    png: bytes | None
    error: str | None = None


Rect = tuple[float, float, float, float]  # left, bottom, right, top, figure fractions


@dataclass(frozen=True)
class Drawing:
    """A figure the report draws itself: ``draw(fig, rect)`` fills ``rect`` of ``fig``."""

    title: str
    caption: str
    alt: str
    size: tuple[float, float]  # inches, for the HTML image; the PDF keeps the height
    draw: Callable[[Figure, Rect], None] = field(compare=False, repr=False)


#: Room around the axes of a drawing, inches: left (y labels), bottom (x label), right, top.
DRAWING_MARGINS = (0.85, 0.5, 0.15, 0.12)


def drawing_figure(drawing: Drawing) -> Figure:
    """The drawing drawn on a figure of its size, inside the report's margins."""
    width, height = drawing.size
    left, bottom, right, top = DRAWING_MARGINS
    fig = Figure(figsize=drawing.size)
    drawing.draw(fig, (left / width, bottom / height, 1 - right / width, 1 - top / height))
    return fig


def style_axes(*axes) -> None:
    """Tick and label sizes and the light grid of the report's plots."""
    for ax in axes:
        ax.grid(True, color="#e6e6e6", linewidth=0.6)
        ax.tick_params(labelsize=8)
        ax.yaxis.label.set_size(9)
        ax.xaxis.label.set_size(9)


#: Characters a figure's font has no glyph for (tab and newline included): written as \xNN.
_UNPRINTABLE = re.compile(r"[\x00-\x1f\x7f-\x9f]")


def printable(text: str) -> str:
    """``text`` as a figure can draw it: every control character written as ``\\xNN`` (file names
    and labels come from the user's files; matplotlib would draw a missing-glyph box and warn)."""
    return _UNPRINTABLE.sub(lambda m: f"\\x{ord(m.group()):02x}", text)


def quiet_legend(ax, *args, **kwargs):
    """A legend whose texts are not parsed as mathtext (labels carry file names, dollars) and show
    control characters escaped (:func:`printable`)."""
    legend = ax.legend(*args, **kwargs)
    for text in legend.get_texts():
        text.set_parse_math(False)
        text.set_text(printable(text.get_text()))
    return legend


def axis_unit(label: str, units: str, peak: float | None = None) -> AxisUnit:
    """Convert an SI axis label ``"name [unit]"`` to the report's unit system.

    With ``peak`` (the largest magnitude of the SI data), small torques and stiffnesses get a
    prefixed unit (mN m, N mm^2) so that ticks read without a power of ten; lengths are mm.
    """
    match = re.fullmatch(r"(.*?)\s*\[([^\]]*)\]\s*", label)
    if match is None:
        return AxisUnit(label, 1.0)
    name, unit = match.group(1), match.group(2).strip()
    spaced = unit.replace("**", "^").replace("·", " ").replace("*", " ")
    key = " ".join(spaced.split()).replace(" ^", "^").replace("^ ", "^")
    if units == "SI":
        return _prefixed(name, key, 1.0, peak)
    if key in CGS_AXIS_UNITS:
        cgs, factor = CGS_AXIS_UNITS[key]
        if cgs == "cm":
            return _prefixed(name, cgs, factor, peak)
        return AxisUnit(f"{name} [{cgs}]", factor, None, cgs)
    return AxisUnit(label, 1.0, None if key in NEUTRAL_UNITS else unit, unit)


def has_plot(fit: TestFit) -> bool:
    return any(np.size(s.x) and np.size(s.y) for s in fit.series)


def unit_note(fit: TestFit, units: str) -> str:
    """A caption sentence naming the units on the axes, as the plot labels them."""
    x = axis_unit(fit.x_label, units, _peak(s.x for s in fit.series))
    y = axis_unit(fit.y_label, units, _peak(s.y for s in fit.series))
    kept = [a.kept_si for a in (x, y) if a.kept_si]
    note = f" ({', '.join(kept)} kept in SI)" if units != "SI" and kept else ""
    return f"Horizontal axis: {x.label}; vertical: {y.label}{note}."


def caption(fit: TestFit, units: str) -> str:
    """What the fit plot shows, in words (the figure caption)."""
    model = any(s.y_fit is not None for s in fit.series)
    excluded = any(s.used is not None and not np.all(s.used) for s in fit.series)
    fitted = " and fitted model (lines)" if model else ""
    hollow = "; hollow grey points are excluded from the fit" if excluded else ""
    below = ". Residuals (measured minus model) below" if model else ""
    return (
        f"Measured points (markers){fitted}, one colour per data set{hollow}{below}. {unit_note(fit, units)}"
    )


def data_axes(fig: Figure, rect: Rect, residuals: bool) -> tuple:
    """The data axes filling ``rect`` (l, b, r, t), with a residual axes a third of their height
    below them on a shared x when ``residuals`` (else None)."""
    left, bottom, right, top = rect
    rows = [3, 1] if residuals else [1]
    grid = fig.add_gridspec(
        len(rows), 1, height_ratios=rows, left=left, right=right, bottom=bottom, top=top, hspace=0.16
    )
    ax = fig.add_subplot(grid[0])
    return ax, fig.add_subplot(grid[1], sharex=ax) if residuals else None


def draw_fit(fig: Figure, fit: TestFit, units: str = "SI", *, rect: Rect = (0.11, 0.1, 0.97, 0.97)) -> None:
    """Draw the data + fit axes and the residual axes of ``fit`` into ``rect`` (l, b, r, t)."""
    x_unit = axis_unit(fit.x_label, units, _peak(s.x for s in fit.series))
    y_unit = axis_unit(fit.y_label, units, _peak(s.y for s in fit.series))
    residuals = any(s.y_fit is not None for s in fit.series)
    ax, ax_res = data_axes(fig, rect, residuals)
    any_excluded = False
    for i, series in enumerate(fit.series):
        colour = COLOURS[i % len(COLOURS)]
        any_excluded |= _draw_series(ax, ax_res, series, colour, x_unit.factor, y_unit.factor)
    ax.set_ylabel(y_unit.label, parse_math=False)
    _legend(ax, fit.series, residuals, any_excluded)
    (ax_res or ax).set_xlabel(x_unit.label, parse_math=False)
    if ax_res is not None:
        ax_res.axhline(0.0, color="#555555", linewidth=0.8)
        ax_res.set_ylabel(f"residual [{y_unit.unit}]" if y_unit.unit else "residual", parse_math=False)
        ax.tick_params(labelbottom=False)
    axes = [a for a in (ax, ax_res) if a is not None]
    for axis in axes:
        axis.ticklabel_format(style="plain", useOffset=False)  # no "1e-5" above an axis
    style_axes(*axes)


def _peak(arrays) -> float | None:
    peaks = [float(np.nanmax(np.abs(a))) for a in arrays if np.size(a)]
    return max(peaks) if peaks else None


#: Rows drawn per series at most: a longer record is drawn every k-th row (its fit used them all;
#: 10^7 drawn points cost seconds and gigabytes for a picture of the same cloud).
MAX_DRAWN = 20_000


def _drawn(series: Series) -> tuple[np.ndarray, ...]:
    """x, y, used and y_fit (or None) of the rows drawn: all, or every k-th of a long record."""
    step = max(1, -(-len(series.x) // MAX_DRAWN))
    x, y = np.asarray(series.x, dtype=float)[::step], np.asarray(series.y, dtype=float)[::step]
    used = np.ones(x.shape, bool) if series.used is None else np.asarray(series.used, bool)[::step]
    y_fit = None if series.y_fit is None else np.asarray(series.y_fit, dtype=float)[::step]
    return x, y, used, y_fit


def _draw_series(ax, ax_res, series: Series, colour: str, fx: float, fy: float) -> bool:
    x, y, used, y_fit = _drawn(series)
    x, y = x * fx, y * fy
    heavy = x.size > 1000  # rasterise dense point clouds to keep the PDF light
    marker = {"linestyle": "none", "marker": "o", "markersize": 3 if x.size < 300 else 2}
    ax.plot(x[used], y[used], color=colour, alpha=0.75, rasterized=heavy, **marker)
    ax.plot(x[~used], y[~used], mfc="none", mec=EXCLUDED, rasterized=heavy, **marker)
    if y_fit is not None:
        y_fit = y_fit * fy
        if _outside(x, used).any():  # the model carried on over the points past the fit
            ax.plot(x, y_fit, color=colour, linewidth=0.9, linestyle="--", alpha=0.45)
        ax.plot(x, np.where(used, y_fit, np.nan), color=colour, linewidth=1.6)
        residual = y - y_fit
        ax_res.plot(x[used], residual[used], color=colour, alpha=0.75, rasterized=heavy, **marker)
        ax_res.plot(x[~used], residual[~used], mfc="none", mec=EXCLUDED, rasterized=heavy, **marker)
    return not used.all()


def _outside(x: np.ndarray, used: np.ndarray) -> np.ndarray:
    """Points beyond the x range of the fitted points (where a dashed model line shows)."""
    if not used.any():
        return np.zeros(x.shape, bool)
    return (x < x[used].min()) | (x > x[used].max())


def _legend(ax, series: Sequence[Series], fitted: bool, excluded: bool) -> None:
    """One entry per series as it is drawn: a series left out whole is hollow grey, not its colour."""
    handles, labels = [], []
    for i, s in enumerate(series):
        whole = s.used is not None and not np.asarray(s.used, bool).any()
        style = {"mfc": "none", "mec": EXCLUDED} if whole else {"color": COLOURS[i % len(COLOURS)]}
        handles.append(Line2D([], [], marker="o", markersize=4, linestyle="none", **style))
        labels.append(f"{s.label} (left out)" if whole else s.label)
    if fitted:
        handles.append(Line2D([], [], color="#333333", linewidth=1.6))
        labels.append("model fit")
    if excluded:
        handles.append(Line2D([], [], linestyle="none", marker="o", mfc="none", mec=EXCLUDED))
        labels.append("excluded from fit")
        if fitted and any(_series_outside(s) for s in series):
            handles.append(Line2D([], [], color="#333333", linewidth=0.9, linestyle="--", alpha=0.45))
            labels.append("model outside the fit")
    quiet_legend(ax, handles, labels, fontsize=7, ncol=2 if len(labels) > 5 else 1, framealpha=0.9)


def _series_outside(series: Series) -> bool:
    if series.y_fit is None or series.used is None:
        return False
    return bool(_outside(np.asarray(series.x, float), np.asarray(series.used, bool)).any())


def fit_figure(fit: TestFit, units: str = "SI") -> Figure:
    fig = Figure(figsize=FIT_SIZE)
    draw_fit(fig, fit, units)
    return fig


def png_bytes(fig: Figure, dpi: int = DPI, *, tight: bool = False) -> bytes:
    buffer = io.BytesIO()
    extra = {"bbox_inches": "tight", "pad_inches": 0.1} if tight else {}
    fig.savefig(buffer, format="png", dpi=dpi, metadata={"Software": None}, **extra)
    return buffer.getvalue()


def png_size(png: bytes) -> tuple[int, int]:
    """Width and height in pixels from the PNG header."""
    return int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")


def extra_figures(fit: TestFit) -> list[ExtraFigure]:
    """The fit's ``info["figures"]`` entries as PNG (see the module docstring)."""
    entries = fit.info.get("figures") or []
    if not isinstance(entries, (list, tuple)):
        return [ExtraFigure("extra figures", None, f"info['figures'] is a {type(entries).__name__}")]
    return [_extra(entry, i) for i, entry in enumerate(entries)]


def _extra(entry: object, index: int) -> ExtraFigure:
    title, item = f"figure {index + 1}", entry
    if isinstance(entry, tuple) and len(entry) == 2 and isinstance(entry[0], str):
        title, item = entry
    elif callable(entry) and not isinstance(entry, Figure):
        title = _callable_title(entry) or title
    try:
        if isinstance(item, (bytes, bytearray)):
            if not bytes(item[:8]) == PNG_MAGIC:
                raise ValueError("bytes are not a PNG file")
            return ExtraFigure(title, bytes(item))
        if callable(item) and not isinstance(item, Figure):
            item = item()
        if isinstance(item, Figure):
            data = png_bytes(item, tight=True)  # a foreign layout: do not clip its labels
            _close(item)
            return ExtraFigure(title, data)
        raise TypeError(f"expected PNG bytes or a Figure, got {type(item).__name__}")
    except Exception as exc:  # a broken extra figure must not sink the report
        return ExtraFigure(title, None, f"{type(exc).__name__}: {exc}")


def _callable_title(func: Callable) -> str:
    doc = (getattr(func, "__doc__", None) or "").strip()
    if doc and type(func).__doc__ != func.__doc__:
        return doc.splitlines()[0].rstrip(".")
    return getattr(func, "__name__", "").replace("_", " ").strip("< >")


def _close(fig: Figure) -> None:
    """Release a figure a callable made through pyplot (only if pyplot is already in use)."""
    pyplot = sys.modules.get("matplotlib.pyplot")
    if pyplot is not None:
        pyplot.close(fig)
