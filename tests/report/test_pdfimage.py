"""The PDF's figures (matid.report.layout.Picture): the bytes an Axes showing the PNG wrote."""

from __future__ import annotations

import dataclasses
import io
from datetime import datetime

import matplotlib
import matplotlib.image
import numpy as np
import PIL.Image
import pytest
from matplotlib.backends.backend_pdf import PdfPages

from matid.report import imagejob, layout, render_report
from matid.report import pdf as pdf_module
from matid.report.figures import DPI, png_size
from matid.report.imagejob import Pending
from matid.report.images import pdf_image, rgba_pixels
from tests.report.test_report import bend_result, make_result

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


class _Prepared:
    """Stands in for a Pending whose child prepared the PDF image stream of its pixels."""

    def __init__(self, rgba: np.ndarray) -> None:
        self.rgba, self.asked = rgba, 0

    def stream(self):
        self.asked += 1
        return pdf_image(self.rgba)


def _image_pages(compression: int, prepare: bool) -> tuple[bytes, list[_Prepared]]:
    """A page of PNGs (noise, a few colours, with transparency), their streams prepared or not."""
    few = np.zeros((40, 60, 4), np.uint8)
    few[..., 3], few[10:30, 20:40, :3] = 255, (200, 30, 90)
    buffer = io.BytesIO()
    prepared = []
    pngs = [_png(300, 200, 1, "RGB"), _png(120, 80, 2, "RGBA"), PIL.Image.fromarray(few)]
    with matplotlib.rc_context({"pdf.compression": compression}):
        with PdfPages(buffer, metadata={"CreationDate": datetime(2024, 1, 1)}) as pdf:
            flow = layout.Flow(pdf, footer="prepared")
            if prepare:
                pdf_module._prepared_images(pdf, flow)
            flow.new_page()
            for png in pngs:
                if isinstance(png, PIL.Image.Image):
                    out = io.BytesIO()
                    png.save(out, format="png")
                    png = out.getvalue()
                flow.image(png, max_height=2.0)
                picture = flow.fig.artists[-1]
                if prepare:
                    prepared.append(_Prepared(picture.rgba))
                    flow.sources[id(picture.rgba)] = (picture.rgba, prepared[-1])
            flow.close()
    return buffer.getvalue(), prepared


@pytest.mark.parametrize("compression", [6, 0])
def test_prepared_image_streams_are_the_bytes_the_pdf_writes(compression):
    plain, _ = _image_pages(compression, prepare=False)
    fast, prepared = _image_pages(compression, prepare=True)
    assert [p.asked for p in prepared] == [1, 1, 1]
    assert [pdf_image(p.rgba) is None for p in prepared] == [False, True, False]  # transparency: a mask
    assert fast == plain


def test_the_report_uses_the_streams_the_child_prepared(monkeypatch):
    """The child draws every figure (the parent steals none) and the PDF, asking for the streams
    once the child is done, takes each one prepared: the same bytes as drawn in one process."""
    result = dataclasses.replace(bend_result(), started="2024-11-26T10:00:00+01:00")
    monkeypatch.setattr(imagejob, "_can_fork", lambda: False)
    want = render_report(result)
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    monkeypatch.setattr(imagejob.ImageJob, "_steal", lambda self, key: None)
    used = []
    real = imagejob.ImageJob.stream

    def stream(self, key):
        self._reader.join()  # the child has sent all it will send
        used.append(real(self, key))
        return used[-1]

    monkeypatch.setattr(imagejob.ImageJob, "stream", stream)
    assert render_report(result) == want
    assert used and all(stream is not None for stream in used)
