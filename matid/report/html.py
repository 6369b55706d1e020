"""The HTML report: one self-contained file, plots inlined as base64 PNG, no script, no assets.

The page is ``templates/report.html`` rendered by jinja2 with autoescape on, so every piece
of user text (study name, notes, metadata, warnings) is escaped.
"""

from __future__ import annotations

import base64
from dataclasses import dataclass

import jinja2

from matid.report.content import KINDS, Block, Report
from matid.report.figures import (
    DPI,
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
    src: str  # data: URI
    width: int
    height: int
    alt: str
    caption: str
    title: str = ""
    error: str = ""  # why the figure could not be drawn (src empty)


def render_html(report: Report) -> bytes:
    """The report page as UTF-8 bytes."""
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("matid.report", "templates"),
        autoescape=True,
        trim_blocks=True,
        lstrip_blocks=True,
        undefined=jinja2.StrictUndefined,
    )
    plots = {
        block.anchor: _fit_image(block, report.units, KINDS[section.kind][0])
        for section in report.sections
        for block in section.blocks
        if block.plot
    }
    drawings = {
        block.anchor: [_drawing_image(d) for d in block.drawings]
        for section in report.sections
        for block in section.blocks
    }
    page = env.get_template("report.html").render(
        report=report, plots=plots, drawings=drawings, data_uri=data_uri
    )
    return page.encode("utf-8")


def data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _fit_image(block: Block, units: str, title: str) -> Image:
    fit = block.fit
    assert fit is not None
    png = png_bytes(fit_figure(fit, units), DPI)
    width, height = png_size(png)
    names = ", ".join(s.label for s in fit.series)
    y_label, x_label = axis_unit(fit.y_label, units).label, axis_unit(fit.x_label, units).label
    alt = (
        f"{title} of specimen {fit.specimen}: {y_label} against {x_label} for {names}. {caption(fit, units)}"
    )
    text = caption(fit, units)
    text = f"{title}, specimen {fit.specimen}: {text[0].lower()}{text[1:]}"
    return Image(data_uri(png), width, height, alt, text)


def _drawing_image(drawing: Drawing) -> Image:
    try:
        png = drawing_png(drawing)
    except Exception as exc:  # a figure that cannot be drawn must not sink the report
        return Image("", 0, 0, drawing.alt, drawing.caption, drawing.title, f"{type(exc).__name__}: {exc}")
    width, height = png_size(png)
    return Image(data_uri(png), width, height, drawing.alt, drawing.caption, drawing.title)
