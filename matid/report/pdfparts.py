"""The pieces the PDF report is typeset from, on reportlab's platypus (public API only).

Fonts: DejaVu Sans and Sans Mono, the TrueType fonts matplotlib ships
(``matplotlib.get_data_path()/fonts/ttf``), registered with reportlab as subset-embedded
``TTFont``: they have the Greek letters, ``±``, ``°``, ``µ``, ``×10⁻⁵`` and ``⚠`` the report
prints, and reportlab writes a ToUnicode map for them, so the PDF's text is searchable.

Every piece of user text goes through :func:`para`, which escapes it for platypus'
paragraph markup. Tables repeat their header row on each page they run over; their columns
share the width by their natural text widths (:func:`column_widths`). A :class:`Heading`
with an outline ``key`` adds a bookmark and a PDF outline entry where it is drawn.
"""

from __future__ import annotations

import contextlib
import functools
import io
from collections.abc import Iterator, Sequence
from pathlib import Path
from xml.sax.saxutils import escape

import matplotlib
from reportlab import rl_config
from reportlab.lib import colors
from reportlab.lib.enums import TA_RIGHT
from reportlab.lib.styles import ParagraphStyle
from reportlab.pdfbase import pdfmetrics
from reportlab.pdfbase.ttfonts import TTFont
from reportlab.platypus import Flowable, Image, KeepTogether, Paragraph, Spacer, Table, TableStyle

from matid.report.figures import DPI, png_size

SANS, SANS_BOLD, MONO, MONO_BOLD = "DejaVuSans", "DejaVuSans-Bold", "DejaVuSansMono", "DejaVuSansMono-Bold"
INK, MUTED, RULE = colors.HexColor("#1d1d1f"), colors.HexColor("#5f6368"), colors.HexColor("#c8ccd2")
HEAD_FACE, ZEBRA = colors.HexColor("#e6e9ee"), colors.HexColor("#f3f4f6")
AMBER = (colors.HexColor("#fff4d6"), colors.HexColor("#e0a800"))
GREY = (colors.HexColor("#f3f4f6"), colors.HexColor("#8a94a6"))
GREEN = (colors.HexColor("#eaf6ec"), colors.HexColor("#3d9a4b"))
PAD = 3.0  # points of cell padding, left and right
WORD_SHARE = 0.4  # the most of a table's width one column may claim to keep its longest word whole


@contextlib.contextmanager
def binary_streams() -> Iterator[None]:
    """reportlab's documented setting ``rl_config.useA85`` off while a PDF is built (restored
    after): streams are written binary, Flate-compressed, without the ASCII-85 layer for 7-bit
    channels, which reportlab encodes in Python. On the demo report: 0.42 -> 0.32 s CPU for the
    PDF, 816 -> 674 kB. A PDF built meanwhile in another thread may get some streams ASCII-85
    encoded: each stream names its filters, so both are valid PDFs."""
    before = rl_config.useA85
    rl_config.useA85 = 0
    try:
        yield
    finally:
        rl_config.useA85 = before


@functools.cache
def register_fonts() -> None:
    """Register the DejaVu fonts (once per process) as one family: <b> selects the bold face."""
    folder = Path(matplotlib.get_data_path()) / "fonts" / "ttf"
    for name in (SANS, SANS_BOLD, MONO, MONO_BOLD):
        pdfmetrics.registerFont(TTFont(name, str(folder / f"{name}.ttf")))
    pdfmetrics.registerFontFamily(SANS, normal=SANS, bold=SANS_BOLD, italic=SANS, boldItalic=SANS_BOLD)
    pdfmetrics.registerFontFamily(MONO, normal=MONO, bold=MONO_BOLD, italic=MONO, boldItalic=MONO_BOLD)


@functools.cache
def style(
    size: float = 8.5,
    *,
    bold: bool = False,
    mono: bool = False,
    right: bool = False,
    muted: bool = False,
    space: float = 0.0,
    keep: bool = False,
) -> ParagraphStyle:
    """A paragraph style: ``size`` points, leading 1.25 x size, ``space`` points after it;
    ``keep``: kept on the page of the flowable that follows (headings)."""
    font = (MONO_BOLD if bold else MONO) if mono else (SANS_BOLD if bold else SANS)
    return ParagraphStyle(
        f"{font}-{size}-{right}-{muted}-{space}-{keep}",
        fontName=font,
        fontSize=size,
        leading=1.25 * size,
        textColor=MUTED if muted else INK,
        alignment=TA_RIGHT if right else 0,
        spaceAfter=space,
        keepWithNext=int(keep),
    )


def markup(text: object) -> str:
    """``text`` as platypus paragraph markup: escaped, line breaks kept."""
    return escape(str(text)).replace("\n", "<br/>")


def para(text: object, size: float = 8.5, **kwargs) -> Paragraph:
    """A paragraph of plain (escaped) text in :func:`style` ``(size, **kwargs)``."""
    return Paragraph(markup(text), style(size, **kwargs))


class Heading(Paragraph):
    """A heading paragraph; with an outline ``key`` it adds a bookmark and an outline entry at
    ``level`` where it is drawn (so the outline follows the pages as laid out). Made by
    :func:`heading`; constructed as a Paragraph, since platypus makes the parts of a split one so."""

    key: str | None = None
    level: int = 0
    title: str = ""

    def split(self, availWidth, availHeight):  # noqa: N803 -- platypus' names
        parts = super().split(availWidth, availHeight)
        if parts:  # the outline entry goes with the first part
            parts[0].key, parts[0].level, parts[0].title = self.key, self.level, self.title
        return parts

    def draw(self) -> None:
        if self.key is not None:
            self.canv.bookmarkHorizontal(self.key, 0, self.height)
            self.canv.addOutlineEntry(self.title, self.key, level=self.level, closed=False)
        super().draw()


def heading(text: str, size: float, *, key: str | None = None, level: int = 0) -> Heading:
    """A bold heading of ``size`` points, kept with what follows it; in the outline under ``key``."""
    made = Heading(markup(text), style(size, bold=True, keep=True, space=0.35 * size))
    made.title, made.key, made.level = str(text), key, level
    return made


def space(points: float) -> Spacer:
    return Spacer(1, points)


# -- tables -------------------------------------------------------------------------------------


def column_widths(
    header: Sequence[str], rows: Sequence[Sequence[str]], fonts: Sequence[str], size: float, available: float
) -> list[float]:
    """Column widths in points: each column's natural width (its widest line) when they fit in
    ``available``; else each gets its longest word (at most :data:`WORD_SHARE` of the width:
    a checksum or a path is split rather), and the rest of the width is shared out
    equally, no column beyond its natural width (narrow columns stay whole, long texts wrap).
    Where even the longest words do not fit, all shrink alike (platypus then splits them)."""
    natural, least = [], []
    for j, font in enumerate(fonts):
        cells = [(header[j], SANS_BOLD), *((str(row[j]), font) for row in rows)]
        natural.append(max(pdfmetrics.stringWidth(c, f, size) for c, f in cells) + 2 * PAD + 1)
        words = [pdfmetrics.stringWidth(w, f, size) for c, f in cells for w in c.split()] or [0.0]
        least.append(min(natural[-1], max(words) + 2 * PAD + 1, WORD_SHARE * available))
    if sum(natural) <= available:
        return natural
    if sum(least) >= available:
        return [w * available / sum(least) for w in least]
    widths, spare = least, available - sum(least)
    while spare > 1e-6:  # share what is left equally among the columns still short of their width
        short = [j for j, w in enumerate(widths) if w < natural[j]]
        step = spare / len(short)
        for j in short:
            grant = min(step, natural[j] - widths[j])
            widths[j] += grant
            spare -= grant
    return widths


def table(
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    numeric: Sequence[bool],
    *,
    width: float,
    size: float = 7.0,
    mono: Sequence[bool] = (),
) -> Table:
    """A table of text: header row repeated on every page it runs over, zebra rows, numeric
    columns right-aligned, cells wrapped in their column; ``mono`` columns in the monospaced font.

    A cell that fits its column on one line is a plain string (drawn in the column's font),
    the others paragraphs wrapped to the column (a paragraph's markup is parsed and its lines
    broken: about a third of the PDF's time on the demo when every cell was one)."""
    mono = tuple(mono) or (False,) * len(header)
    fonts = [MONO if m else SANS for m in mono]
    widths = column_widths(header, rows, fonts, size, width)
    data = [[_cell(h, SANS_BOLD, size, w, right=r) for h, w, r in zip(header, widths, numeric, strict=True)]]
    data += [
        [_cell(str(c), f, size, w, right=r) for c, f, w, r in zip(row, fonts, widths, numeric, strict=True)]
        for row in rows
    ]
    return Table(
        data,
        colWidths=widths,
        repeatRows=1,
        splitInRow=1,  # a row taller than a page (a long reason) continues on the next
        hAlign="LEFT",
        style=_table_style(numeric, mono, size, len(data)),
    )


def _table_style(numeric: Sequence[bool], mono: Sequence[bool], size: float, n_rows: int) -> TableStyle:
    """Fonts (monospaced columns), right-aligned numbers, the header's shade and rule, zebra rows."""
    commands = [
        ("FONT", (0, 0), (-1, -1), SANS, size, 1.25 * size),
        ("FONT", (0, 0), (-1, 0), SANS_BOLD, size, 1.25 * size),
        ("TEXTCOLOR", (0, 0), (-1, -1), INK),
        ("BACKGROUND", (0, 0), (-1, 0), HEAD_FACE),
        ("LINEBELOW", (0, 0), (-1, 0), 0.6, GREY[1]),
        ("VALIGN", (0, 0), (-1, -1), "TOP"),
        ("LEFTPADDING", (0, 0), (-1, -1), PAD),
        ("RIGHTPADDING", (0, 0), (-1, -1), PAD),
        ("TOPPADDING", (0, 0), (-1, -1), 1.5),
        ("BOTTOMPADDING", (0, 0), (-1, -1), 1.5),
    ]
    commands += [("FONT", (j, 1), (j, -1), MONO, size, 1.25 * size) for j, m in enumerate(mono) if m]
    commands += [("ALIGN", (j, 0), (j, -1), "RIGHT") for j, r in enumerate(numeric) if r]
    if n_rows > 2:
        commands.append(("ROWBACKGROUNDS", (0, 1), (-1, -1), [colors.white, ZEBRA]))
    return TableStyle(commands)


def _cell(text: str, font: str, size: float, width: float, *, right: bool) -> str | Paragraph:
    """``text`` as it is if it fits ``width`` on one line, else a paragraph wrapped to it."""
    if "\n" not in text and pdfmetrics.stringWidth(text, font, size) + 2 * PAD <= width:
        return text
    return para(text, size, bold=font in (SANS_BOLD, MONO_BOLD), mono=font in (MONO, MONO_BOLD), right=right)


def box(title: Paragraph, items: Sequence[str], colours: tuple, *, width: float) -> Table:
    """A coloured box with an accent bar on its left: a title, then one bulleted row per item
    (so that a long box continues on the next page between its items)."""
    face, edge = colours
    rows = [[title]] + [[Paragraph(markup(item), style(8.5), bulletText="•")] for item in items]
    commands = [
        ("BACKGROUND", (0, 0), (-1, -1), face),
        ("LINEBEFORE", (0, 0), (0, -1), 3, edge),
        ("LEFTPADDING", (0, 0), (-1, -1), 9),
        ("RIGHTPADDING", (0, 0), (-1, -1), 6),
        ("TOPPADDING", (0, 0), (-1, -1), 2),
        ("BOTTOMPADDING", (0, 0), (-1, -1), 2),
        ("TOPPADDING", (0, 0), (-1, 0), 5),
        ("BOTTOMPADDING", (0, -1), (-1, -1), 5),
    ]
    return Table(rows, colWidths=[width], hAlign="LEFT", splitInRow=1, style=TableStyle(commands))


# -- figures ------------------------------------------------------------------------------------


def picture(png: bytes, *, width: float, max_height: float) -> Image:
    """A PNG at the report's dpi, shrunk to ``width`` and ``max_height`` points (never enlarged)."""
    w, h = (pixels * 72 / DPI for pixels in png_size(png))
    scale = min(1.0, width / w, max_height / h)
    return Image(io.BytesIO(png), width=w * scale, height=h * scale, mask=None, hAlign="CENTER")


class Together(list):
    """Flowables to keep on one page; the headings just before them join them (:func:`assemble`)."""


def assemble(story: Sequence[Flowable | Together]) -> list[Flowable]:
    """The story for platypus: each :class:`Together` as one KeepTogether with the flowables
    kept with it (headings: ``keepWithNext``) just before it."""
    out: list[Flowable] = []
    pending: list[Flowable] = []
    for item in story:
        if isinstance(item, Together):
            out.append(KeepTogether([*pending, *item]))
            pending = []
        elif item.getKeepWithNext():
            pending.append(item)
        else:
            out += [*pending, item]
            pending = []
    return out + pending


def figure(title: str | None, image: Image, caption: str) -> Together:
    """A figure kept on one page with its title above and its caption below."""
    parts = [heading(title, 9.5)] if title else []
    return Together([*parts, image, space(2), para(caption, 7.5, muted=True, space=6)])
