"""The PDF's figures (matid.report.layout.Picture): the bytes an Axes showing the PNG wrote."""

from __future__ import annotations

import dataclasses
import io
from datetime import datetime

import matplotlib.image
import numpy as np
import PIL.Image
import pytest
from matplotlib.backends.backend_pdf import PdfPages
from test_report import bend_result, make_result

from matid.report import layout, render_report
from matid.report.figures import DPI, png_size
from matid.report.imagejob import Pending
from matid.report.images import rgba_pixels

pytestmark = pytest.mark.filterwarnings("ignore:Glyph .* missing from font")


def _imread(png: bytes) -> np.ndarray:
    return matplotlib.image.imread(io.BytesIO(png), format="png")


def _as_rgba(png: bytes) -> np.ndarray:
    with PIL.Image.open(io.BytesIO(png)) as image:
        return np.asarray(image.convert("RGBA"))


def _axes_image(self, png, *, max_height: float = 5.0, read=_imread) -> None:
    """Flow.image as it was: an Axes per figure showing the PNG's pixels (``read(png)``), unresampled."""
    png = png.result() if isinstance(png, Pending) else png
    px_w, px_h = png_size(png)
    width = min(px_w / DPI, self.width)
    height = width * px_h / px_w
    if height > max_height:
        width, height = width * max_height / height, max_height
    self.need(height)
    left = layout.MARGIN_X + (self.width - width) / 2
    page_w, page_h = layout.PAGE
    ax = self.fig.add_axes((left / page_w, (self.y - height) / page_h, width / page_w, height / page_h))
    ax.imshow(read(png), interpolation="none")
    ax.set_axis_off()
    self.y -= height


@pytest.mark.parametrize("make", [make_result, bend_result], ids=["kinds", "bend"])
def test_report_pictures_write_what_an_imshow_axes_wrote(monkeypatch, make):
    result = dataclasses.replace(make(), started="2024-11-26T10:00:00+01:00")  # a fixed CreationDate
    drawn = []
    real_draw = layout.Picture.draw
    monkeypatch.setattr(layout.Picture, "draw", lambda self, r: drawn.append(self) or real_draw(self, r))
    fast = render_report(result)["report.pdf"]
    assert drawn  # the report's figures went through Picture
    monkeypatch.setattr(layout.Flow, "image", _axes_image)
    assert render_report(result)["report.pdf"] == fast


def _png(width: int, height: int, seed: int, mode: str) -> bytes:
    rng = np.random.default_rng(seed)
    pixels = rng.integers(0, 256, (height, width, len(mode)), dtype=np.uint8)
    buffer = io.BytesIO()
    PIL.Image.fromarray(pixels.squeeze(), mode).save(buffer, format="png")
    return buffer.getvalue()


def _pages(image) -> bytes:
    """Pages of PNGs of assorted sizes, modes and height limits placed by ``image(flow, png, max_height)``."""
    buffer = io.BytesIO()
    with PdfPages(buffer, metadata={"CreationDate": datetime(2024, 1, 1)}) as pdf:
        flow = layout.Flow(pdf, footer="pictures")
        flow.new_page()
        sizes = [(750, 320), (133, 97), (1200, 300), (400, 900), (61, 61), (998, 1001)]
        for k, (width, height) in enumerate(sizes):
            for mode in ("RGBA", "RGB", "L"):
                flow.paragraph(f"{width} x {height} {mode}")
                image(flow, _png(width, height, k, mode), max_height=(5.0, 2.37, 1.1)[k % 3])
        flow.close()
    return buffer.getvalue()


def test_pictures_of_any_size_and_mode_write_what_an_imshow_axes_wrote():
    fast = _pages(lambda flow, png, max_height: flow.image(png, max_height=max_height))
    assert fast.count(b"/Subtype /Image") >= 18
    old = _pages(lambda flow, png, max_height: _axes_image(flow, png, max_height=max_height, read=_as_rgba))
    assert fast == old


def test_rgba_pixels_are_the_png_as_8_bit_rgba():
    for mode in ("RGBA", "RGB", "L"):
        png = _png(37, 23, 5, mode)
        pixels = rgba_pixels(png)
        assert pixels.dtype == np.uint8 and pixels.shape == (23, 37, 4)
        floats = _imread(png)
        want = np.round(floats * 255).astype(np.uint8)
        if want.ndim == 2:
            want = np.stack([want] * 3, axis=-1)
        np.testing.assert_array_equal(pixels[..., : want.shape[-1]], want)
