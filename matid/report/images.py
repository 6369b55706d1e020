"""Every figure of the report rendered once to PNG, shared by the HTML page and the PDF.

Drawing a figure costs more than placing it: the fit plots and the bend drawings are
rendered here once, at :data:`~matid.report.figures.DPI`, and the HTML inlines the PNG
while the PDF embeds the same pixels unresampled.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np
import PIL.Image

from matid.report.content import KINDS, Block, Report
from matid.report.figures import (
    Drawing,
    axis_unit,
    caption,
    drawing_png,
    fit_figure,
    png_bytes,
    png_size,
)


@dataclass(frozen=True)
class Image:
    png: bytes  # empty when the figure could not be drawn
    width: int
    height: int
    alt: str
    caption: str
    title: str = ""
    error: str = ""  # why the figure could not be drawn


@dataclass(frozen=True)
class Images:
    plots: dict[str, Image]  # block anchor -> its fit plot
    drawings: dict[str, list[Image]]  # block anchor -> its drawings


def render_images(report: Report) -> Images:
    """The fit plot and the drawings of every block, as PNG."""
    plots = {
        block.anchor: fit_image(block, report.units, KINDS[section.kind][0])
        for section in report.sections
        for block in section.blocks
        if block.plot
    }
    drawings = {
        block.anchor: [drawing_image(d) for d in block.drawings]
        for section in report.sections
        for block in section.blocks
    }
    return Images(plots, drawings)


def fit_image(block: Block, units: str, title: str, *, png: bool = True) -> Image:
    """The fit plot of ``block``; with ``png=False`` only its texts (no pixels, size 0 x 0)."""
    fit = block.fit
    assert fit is not None
    data = png_bytes(fit_figure(fit, units)) if png else b""
    width, height = png_size(data) if png else (0, 0)
    names = ", ".join(s.label for s in fit.series)
    y_label, x_label = axis_unit(fit.y_label, units).label, axis_unit(fit.x_label, units).label
    text = caption(fit, units)
    alt = f"{title} of specimen {fit.specimen}: {y_label} against {x_label} for {names}. {text}"
    return Image(data, width, height, alt, text, f"{title}, specimen {fit.specimen}")


def drawing_image(drawing: Drawing) -> Image:
    try:
        png = drawing_png(drawing)
    except Exception as exc:  # a figure that cannot be drawn must not sink the report
        return Image(b"", 0, 0, drawing.alt, drawing.caption, drawing.title, f"{type(exc).__name__}: {exc}")
    width, height = png_size(png)
    return Image(png, width, height, drawing.alt, drawing.caption, drawing.title)


def rgba_pixels(png: bytes) -> np.ndarray:
    """The PNG's pixels as 8-bit RGBA, as the PDF embeds them (imread would make floats of them,
    which the PDF turns back into the same bytes)."""
    with PIL.Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGBA"))
