"""Every figure of the report rendered once to PNG, shared by the HTML page and the PDF.

Drawing a figure costs more than placing it: the fit plots and the bend drawings are drawn
by matplotlib (public API only: ``Figure.savefig`` into a buffer, :func:`png_bytes`) once, at
:data:`~matid.report.figures.DPI`; the HTML inlines the PNG and the PDF embeds the same image.
"""

from __future__ import annotations

from dataclasses import dataclass

from matid.model.results import TestFit
from matid.report.content import Report
from matid.report.figures import Drawing, axis_unit, caption, drawing_figure, fit_figure, png_bytes, png_size


@dataclass(frozen=True)
class Image:
    png: bytes  # empty when the figure could not be drawn
    width: int  # pixels
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
    blocks = [(section.title, block) for section in report.sections for block in section.blocks]
    plots = {block.anchor: fit_image(block.fit, report.units, title) for title, block in blocks if block.plot}
    drawings = {block.anchor: [drawing_image(d) for d in block.drawings] for _, block in blocks}
    return Images(plots, drawings)


def fit_image(fit: TestFit, units: str, title: str) -> Image:
    """The fit plot of ``fit`` with its caption and alternative text."""
    png = png_bytes(fit_figure(fit, units))
    names = ", ".join(s.label for s in fit.series)
    y_label, x_label = axis_unit(fit.y_label, units).label, axis_unit(fit.x_label, units).label
    text = caption(fit, units)
    alt = f"{title} of specimen {fit.specimen}: {y_label} against {x_label} for {names}. {text}"
    return Image(png, *png_size(png), alt, text, f"{title}, specimen {fit.specimen}")


def drawing_image(drawing: Drawing) -> Image:
    """A drawing as PNG, or why it could not be drawn (a broken drawing must not sink the report)."""
    try:
        png = png_bytes(drawing_figure(drawing))
    except Exception as exc:  # noqa: BLE001 -- shown in the report in place of the figure
        return Image(b"", 0, 0, drawing.alt, drawing.caption, drawing.title, f"{type(exc).__name__}: {exc}")
    return Image(png, *png_size(png), drawing.alt, drawing.caption, drawing.title)
