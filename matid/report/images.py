"""Every figure of the report rendered once to PNG, shared by the HTML page and the PDF.

Drawing a figure costs more than placing it: the fit plots and the bend drawings are
rendered here once, at :data:`~matid.report.figures.DPI`, and the HTML inlines the PNG
while the PDF embeds the same pixels unresampled (:class:`Picture`, from the pixels the figure
was drawn with where they were kept; :func:`pdf_image`, the PDF's encoding of them).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import matplotlib as mpl
import numpy as np
import PIL.Image
from matplotlib.artist import Artist
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.backends.backend_pdf import PdfFile
from matplotlib.figure import Figure
from matplotlib.transforms import Affine2D, Bbox, TransformedBbox

from matid.report.content import KINDS, Block, Report
from matid.report.figures import (
    Drawing,
    axis_unit,
    caption,
    drawing_figure,
    fit_figure,
    png_bytes,
    png_size,
)

if TYPE_CHECKING:
    from matid.report.imagejob import Pending


@dataclass(frozen=True)
class Image:
    png: bytes  # empty when the figure could not be drawn
    width: int
    height: int
    alt: str
    caption: str
    title: str = ""
    error: str = ""  # why the figure could not be drawn
    #: the PNG's pixels as 8-bit RGBA, kept from drawing it (when asked for: the PDF's figures)
    pixels: np.ndarray | None = field(default=None, compare=False, repr=False)


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


def fit_image(block: Block, units: str, title: str, *, png: bool = True, pixels: bool = False) -> Image:
    """The fit plot of ``block``; with ``png=False`` only its texts (no pixels, size 0 x 0); with
    ``pixels`` also the PNG's pixels (:attr:`Image.pixels`)."""
    fit = block.fit
    assert fit is not None
    data, rgba = _png(fit_figure(fit, units), pixels) if png else (b"", None)
    width, height = png_size(data) if png else (0, 0)
    names = ", ".join(s.label for s in fit.series)
    y_label, x_label = axis_unit(fit.y_label, units).label, axis_unit(fit.x_label, units).label
    text = caption(fit, units)
    alt = f"{title} of specimen {fit.specimen}: {y_label} against {x_label} for {names}. {text}"
    return Image(data, width, height, alt, text, f"{title}, specimen {fit.specimen}", pixels=rgba)


def drawing_image(drawing: Drawing, *, pixels: bool = False) -> Image:
    """A drawing as PNG (:func:`matid.report.figures.drawing_png`), with ``pixels`` also its pixels."""
    try:
        png, rgba = _png(drawing_figure(drawing), pixels)
    except Exception as exc:  # a figure that cannot be drawn must not sink the report
        return Image(b"", 0, 0, drawing.alt, drawing.caption, drawing.title, f"{type(exc).__name__}: {exc}")
    width, height = png_size(png)
    return Image(png, width, height, drawing.alt, drawing.caption, drawing.title, pixels=rgba)


def _png(fig: Figure, pixels: bool) -> tuple[bytes, np.ndarray | None]:
    """The figure as PNG (:func:`~matid.report.figures.png_bytes`) and, if asked, the pixels it
    holds: Agg's buffer, left on the figure's canvas by the drawing (the decoded PNG, not decoded)."""
    canvas = FigureCanvasAgg(fig) if pixels else None  # the canvas savefig would make and drop
    png = png_bytes(fig)
    if canvas is None:
        return png, None
    rgba = np.asarray(canvas.buffer_rgba())
    return png, (rgba if rgba.shape[1::-1] == png_size(png) else rgba_pixels(png))


def rgba_pixels(png: bytes) -> np.ndarray:
    """The PNG's pixels as 8-bit RGBA, as the PDF embeds them (imread would make floats of them,
    which the PDF turns back into the same bytes)."""
    with PIL.Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGBA"))


class Picture(Artist):
    """A PNG filling ``rect`` (left, bottom, width, height in figure fractions), unresampled: the
    PDF holds the PNG's own 8-bit RGBA pixels, scaled by the viewer. It writes what an Axes
    showing the PNG with ``imshow(interpolation="none")``, axis off, wrote: the image clipped to
    its box, without building an Axes (tests/test_report_pdfimage.py compares the two).
    Only for renderers that scale images themselves (``option_scale_image``), as the PDF's does."""

    def __init__(self, rect: tuple[float, float, float, float], png: bytes | Pending) -> None:
        super().__init__()
        self.rect, self.png = rect, png
        self.rgba: np.ndarray | None = None

    def fetch(self) -> None:
        """The pixels, decoded now (for a Pending PNG: waited for; Relayout if it cannot be shown)."""
        if self.rgba is None:
            self.rgba = rgba_pixels(self.png) if isinstance(self.png, bytes) else self.png.pixels()

    def draw(self, renderer) -> None:
        if not self.get_visible():
            return
        if not renderer.option_scale_image():
            raise TypeError(f"{type(renderer).__name__} does not scale images: draw the PNG with imshow")
        self.fetch()
        box = TransformedBbox(Bbox.from_bounds(*self.rect), self.get_figure(root=False).transSubfigure)
        gc = renderer.new_gc()
        gc.set_clip_rectangle(box)
        gc.set_alpha(1.0)
        x, y, width, height = box.bounds
        # the unit square the PDF maps an image onto, flipped: its first row on top
        flip = Affine2D(np.array([[width, 0.0, 0.0], [0.0, -height, height], [0.0, 0.0, 1.0]]))
        renderer.draw_image(gc, x, y, self.rgba, flip)
        gc.restore()
        self.stale = False


def pdf_image(rgba: np.ndarray) -> tuple | None:
    """What matplotlib's PDF writer writes for an opaque image of these pixels (``PdfFile._writeImg``,
    whose work depends on the pixels and ``pdf.compression`` alone): (pdf.compression, stream
    dictionary, PNG parameters, data); None for pixels with transparency (written with a mask),
    or where this matplotlib's private writer takes other arguments (the PDF then encodes them)."""
    try:
        rgb, alpha = PdfFile._unpack(None, rgba)
        if alpha is not None:
            return None
        capture = _Capture()
        PdfFile._writeImg(capture, rgb, None)  # type: ignore[arg-type]
    except (AttributeError, TypeError, ValueError):  # another matplotlib's internals
        return None
    return mpl.rcParams["pdf.compression"], capture.extra, capture.png, b"".join(capture.data)


class _Capture:
    """Stands in for the PdfFile in ``PdfFile._writeImg``: keeps the stream it would write."""

    _writePng = PdfFile._writePng  # noqa: N815 -- the name _writeImg calls

    def __init__(self) -> None:
        self.extra, self.png, self.data = None, None, []
        self.currentstream = self

    def reserveObject(self, name: str) -> None:  # noqa: N802 -- PdfFile's names
        return None

    def beginStream(self, id, len, extra=None, png=None) -> None:  # noqa: N802, A002
        self.extra, self.png = extra, png

    def write(self, data: bytes) -> None:
        self.data.append(data)

    def endStream(self) -> None:  # noqa: N802
        pass
