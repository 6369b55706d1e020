"""The PDF's lines of text (matid.report.pdftext): the same bytes as matplotlib's own Text.draw."""

from __future__ import annotations

import dataclasses
import io
import itertools
import weakref
from datetime import datetime

import pytest
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from matid.report import pdftext, render_report
from matid.report.layout import MONO, SANS, add_text
from tests.report.test_report import bend_result, make_result

pytestmark = pytest.mark.filterwarnings("ignore:Glyph .* missing from font")

#: Plain text, kerning pairs, Latin-1, symbols the report prints, a glyph from a fallback font,
#: right-to-left text, dollars (no mathtext here), a tab, descenders only, and nothing below the line.
STRINGS = (
    "Stiffness identification report",
    "AVAWAY To Ty Yo LT 'quoted' \"double\" fi fl ffi",
    "E_e = 119.97 ± 0.046 N   sls_eta 450.5 N s   ⚠ [2]   µm  °C  ×10⁻⁵  ≤ ≥ → …",
    "Çàéîõü ßÆØå ñ ¿¡ § ¶ © ®",
    "price $5 and $x^2$ stay text",
    "tab\there",
    "gjpqy",
    "---",
    "· ·",
    "עברית and العربية mixed",
    "批次 2611 样品",
    "a" * 300,
)


def _pages(draw) -> bytes:
    """Two A4 pages with every string in every style, drawn by ``draw(fig, x, y, text, **style)``."""
    buffer = io.BytesIO()
    with PdfPages(buffer, metadata={"CreationDate": datetime(2024, 1, 1)}) as pdf:
        for family in (SANS, MONO):
            fig = Figure(figsize=(8.27, 11.69))
            y = 0.97
            for size in (6.5, 8.5, 14):
                for weight in ("normal", "bold"):
                    for k, text in enumerate(STRINGS):
                        style = {
                            "family": family,
                            "size": size,
                            "weight": weight,
                            "color": "#5f6368" if k % 2 else "k",
                        }
                        draw(fig, 0.05 + 0.0001 * k, y, text, va="bottom", parse_math=False, **style)
                        y -= 0.0125
            pdf.savefig(fig)
    return buffer.getvalue()


def _spy(monkeypatch) -> list[bool]:
    """What draw_line returned each time: True where the one-line path drew the text itself."""
    drawn, real = [], pdftext.draw_line

    def spy(*args):
        drawn.append(bool(real(*args)))
        return drawn[-1]

    monkeypatch.setattr(pdftext, "draw_line", spy)
    return drawn


@pytest.mark.skipif(not pdftext.SUPPORTED, reason="matplotlib < 3.11: every line goes through Text.draw")
def test_page_text_writes_the_bytes_of_text_draw(monkeypatch):
    drawn = _spy(monkeypatch)
    fast = _pages(add_text)
    slow = _pages(lambda fig, x, y, text, **style: fig.text(x, y, text, **style))
    assert fast == slow
    assert drawn and all(drawn)  # the fast path drew every line: the equality is not Text.draw's own


def test_page_text_other_cases_fall_back_to_text_draw(monkeypatch):
    """Right-aligned, rotated or several lines: drawn by matplotlib, and still the same bytes."""
    calls = []
    monkeypatch.setattr(pdftext, "draw_line", lambda *a: calls.append(a) or False)

    def cases(draw) -> bytes:
        buffer = io.BytesIO()
        with PdfPages(buffer, metadata={"CreationDate": datetime(2024, 1, 1)}) as pdf:
            fig = Figure(figsize=(8.27, 11.69))
            draw(fig, 0.9, 0.1, "page 3", ha="right", va="bottom", size=7)
            draw(fig, 0.5, 0.5, "rotated", rotation=30, va="bottom")
            draw(fig, 0.1, 0.3, "two\nlines", va="bottom")
            draw(fig, 0.1, 0.6, "centred", va="center")
            pdf.savefig(fig)
        return buffer.getvalue()

    assert cases(add_text) == cases(lambda fig, x, y, text, **style: fig.text(x, y, text, **style))
    assert calls == []  # none of them took the one-line path


def test_without_the_private_apis_every_line_goes_through_text_draw(monkeypatch):
    """matplotlib < 3.11 lacks FontPath/LoadFlags/FT2Font._layout: SUPPORTED is False there and
    PageText must never reach draw_line (it would fail on the missing APIs)."""
    calls = []
    monkeypatch.setattr(pdftext, "SUPPORTED", False)
    monkeypatch.setattr(pdftext, "draw_line", lambda *a: calls.append(a) or False)
    assert _pages(add_text) == _pages(lambda fig, x, y, text, **style: fig.text(x, y, text, **style))
    assert calls == []


@pytest.mark.parametrize("make", [make_result, bend_result])
def test_report_pdf_is_the_same_with_matplotlib_text(monkeypatch, make):
    result = dataclasses.replace(make(), started="2024-11-26T10:00:00+01:00")  # a fixed CreationDate
    drawn = _spy(monkeypatch)
    fast = render_report(result)["report.pdf"]
    assert any(drawn) or not pdftext.SUPPORTED  # the fast path drew lines of the report
    monkeypatch.setattr(pdftext.PageText, "_plain", lambda self, renderer: False)
    slow = render_report(result)["report.pdf"]
    assert fast == slow


def test_monospaced_layout_is_raqms():
    """Table rows in DejaVu Sans Mono are laid out without raqm: the same glyphs, positions and kerns."""
    import random
    import string

    from matplotlib.backends.backend_pdf import PdfFile, RendererPdf
    from matplotlib.font_manager import FontProperties
    from matplotlib.ft2font import LoadFlags

    rng = random.Random(7)
    alphabet = string.ascii_letters + string.digits + string.punctuation + " " * 10 + "±µ°×éàüßÆØñ§·–—…≤≥→⚠©¿"
    renderer = RendererPdf(PdfFile(io.BytesIO()), 72, 8.27, 11.69)
    taken = 0
    for size in (6.5, 7, 7.5, 8, 9.5, 14):
        for weight in ("normal", "bold"):
            font = renderer._get_font_ttf(FontProperties(family=MONO, size=size, weight=weight))
            texts = ["".join(rng.choice(alphabet) for _ in range(rng.randint(1, 150))) for _ in range(150)]
            for text in [*texts, "fi fl ffi --> <= != ==", "a\u0301 combining", "עברית", "tab\there", "批次"]:
                ours = pdftext._monospaced(font, text, size)
                if ours is None:
                    continue
                taken += 1
                theirs = font._layout(text, LoadFlags.NO_HINTING, features=None, language=None)
                assert [tuple(item) for item in ours] == [
                    (i.ft_object, i.char, i.glyph_index, i.x, i.y, i.prev_kern) for i in theirs
                ], text
    assert taken == 12 * 151  # every random text and the ligature candidates; none of the other four


def test_repr_cache_is_bounded(monkeypatch):
    """The TJ-array cache is emptied at its bound and the bytes do not change."""
    monkeypatch.setattr(pdftext, "_REPR_MAX", 3)
    monkeypatch.setattr(pdftext, "_REPR", {})
    assert _pages(add_text) == _pages(lambda fig, x, y, text, **style: fig.text(x, y, text, **style))
    assert len(pdftext._REPR) <= 3


@pytest.mark.skipif(not pdftext.SUPPORTED, reason="matplotlib < 3.11: every line goes through Text.draw")
def test_repeated_lines_are_laid_out_once_per_file_and_write_the_same_bytes(monkeypatch):
    """A line drawn again (another page, place, colour) reuses its layout and operators, per font and size."""
    monkeypatch.setattr(pdftext, "_LINES", weakref.WeakKeyDictionary())
    shaped = []

    def pages(draw) -> bytes:
        buffer = io.BytesIO()
        with PdfPages(buffer, metadata={"CreationDate": datetime(2024, 1, 1)}) as pdf:
            for page in range(3):
                fig = Figure(figsize=(8.27, 11.69))
                y = 0.95
                styles = itertools.product((SANS, MONO), (7.5, 8.5, 7.5), ("normal", "bold"))
                for family, size, weight in styles:
                    for text in STRINGS[:4]:
                        style = {"family": family, "size": size, "weight": weight, "color": "kr"[page % 2]}
                        draw(fig, 0.05 + 0.01 * page, y, text, va="bottom", parse_math=False, **style)
                        y -= 0.01
                pdf.savefig(fig)
            shaped.extend(len(cache) for cache in pdftext._LINES.values())
        return buffer.getvalue()

    fast = pages(add_text)
    assert shaped == [2 * 2 * 2 * 4]  # (family, size, weight, text): each laid out once in the file
    assert fast == pages(lambda fig, x, y, text, **style: fig.text(x, y, text, **style))


def test_texts_copied_by_style_write_the_bytes_of_text_draw():
    """add_text with a ``styles`` cache copies one text per style: the pages do not change."""
    styles: dict = {}
    fast = _pages(lambda fig, x, y, text, **style: add_text(fig, x, y, text, styles=styles, **style))
    assert 0 < len(styles) <= 2 * 3 * 2 * 2  # family, size, weight, colour: one text made for each
    assert fast == _pages(lambda fig, x, y, text, **style: fig.text(x, y, text, **style))
