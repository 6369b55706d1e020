"""Page layout for the PDF report: blocks flowing down A4 pages drawn with matplotlib.

:class:`Flow` places content one block below the other like a word processor: headings,
wrapped paragraphs, boxes, monospaced tables and PNG images (the figures). A block that does
not fit on the page starts the next one; long tables repeat their
header, long boxes continue on the next page. Text is measured with the advance widths of
the glyphs of the DejaVu fonts bundled with matplotlib, so wrapping needs no renderer.
Positions are in inches from the bottom left of the page.
"""

from __future__ import annotations

import textwrap
from functools import lru_cache

import numpy as np
from matplotlib import cbook
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure, _stale_figure_callback
from matplotlib.font_manager import FontProperties
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle
from matplotlib.textpath import TextToPath

from matid.report.content import Table
from matid.report.figures import DPI, png_size
from matid.report.imagejob import Pending
from matid.report.images import Picture
from matid.report.pdftext import PageText

PAGE = (8.27, 11.69)  # A4 portrait, inches
MARGIN_X, MARGIN_TOP, MARGIN_BOTTOM = 0.65, 0.6, 0.75
SANS, MONO = "DejaVu Sans", "DejaVu Sans Mono"
#: A word longer than this may be split across lines in a table cell.
WORD_CAP = 24
MONO_ADVANCE = 0.602  # advance width of DejaVu Sans Mono, in em


class Flow:
    """Places blocks one below the other on A4 pages, starting new pages as needed."""

    def __init__(self, pdf: PdfPages, *, footer: str) -> None:
        self.pdf, self.footer = pdf, footer
        self.fig: Figure | None = None
        self._pending: list[Picture] = []  # figures of this page waiting for their pixels
        #: id of a figure's pixels -> (the pixels, their Pending), for the PDF's image streams (pdf.py)
        self.sources: dict[int, tuple[np.ndarray, Pending]] = {}
        self._styles: dict = {}  # the texts to copy (see add_text), under the rcParams of this Flow
        self.page = 0
        self.y = 0.0  # inches from the bottom of the page to the next free line

    @property
    def width(self) -> float:
        return PAGE[0] - 2 * MARGIN_X

    def room(self) -> float:
        return self.y - MARGIN_BOTTOM if self.fig is not None else 0.0

    def new_page(self) -> None:
        self._finish()
        self.fig = Figure(figsize=PAGE)
        self.page += 1
        self.y = PAGE[1] - MARGIN_TOP
        self._text(MARGIN_X, MARGIN_BOTTOM * 0.5, self.footer, size=7, color="#777777")
        add_text(
            self.fig,
            1 - MARGIN_X / PAGE[0],
            MARGIN_BOTTOM * 0.5 / PAGE[1],
            f"page {self.page}",
            ha="right",
            va="bottom",
            size=7,
            color="#777777",
            family=SANS,
            styles=self._styles,
        )

    def need(self, height: float) -> None:
        if height > self.room():
            self.new_page()

    def space(self, height: float) -> None:
        if self.fig is not None:
            self.y -= height

    def close(self) -> None:
        self._finish()

    def _finish(self) -> None:
        if self.fig is not None:
            for picture in self._pending:  # the pixels of the page's figures, waited for now
                picture.fetch()
                self.sources[id(picture.rgba)] = (picture.rgba, picture.png)
            self._pending.clear()
            self.pdf.savefig(self.fig)
            self.fig = None

    def _text(self, x: float, y: float, text: str, **style) -> None:
        style.setdefault("family", SANS)
        add_text(
            self.fig,
            x / PAGE[0],
            y / PAGE[1],
            text,
            va="bottom",
            parse_math=False,
            styles=self._styles,
            **style,
        )

    # -- text -------------------------------------------------------------------------------

    def heading(self, text: str, level: int = 1) -> None:
        size = {0: 18, 1: 14, 2: 11.5, 3: 9.5}[level]
        line = size * 1.3 / 72
        lines = wrap(text, self.width, size, mono=False, bold=True)
        self.need(len(lines) * line + 1.2)  # keep a heading with what follows
        self.space(0.15 if level <= 1 else 0.08)
        self.lines(lines, size=size, weight="bold", mono=False)
        if level == 1:
            self._rule(self.y + 0.03, "#c8ccd2", 1.2)
            self.y -= 0.08

    def paragraph(self, text: str, *, size: float = 8.5, mono: bool = False, **style) -> None:
        indent = style.pop("indent", 0.0)
        self.lines(
            wrap(text, self.width - indent, size, mono=mono), size=size, mono=mono, indent=indent, **style
        )

    def lines(
        self,
        lines: list[str],
        *,
        size: float,
        mono: bool,
        indent: float = 0.0,
        box: tuple[str, str] | None = None,
        bold: int = 0,
        **style,
    ) -> None:
        """Draw lines top-down, the first ``bold`` in bold; a box (face, edge colour) is drawn
        behind each page's share of the lines."""
        step = size * 1.35 / 72
        pad = 0.08 if box else 0.0
        i = 0
        while i < len(lines):
            self.need(step + 2 * pad)
            count = max(1, int((self.room() - 2 * pad) // step))
            chunk = lines[i : i + count]
            top = self.y
            self.y -= pad
            x = MARGIN_X + indent + (0.12 if box else 0.0)
            for k, text in enumerate(chunk, start=i):
                self.y -= step
                weight = "bold" if k < bold else style.get("weight", "normal")
                font = {**style, "weight": weight, "size": size, "family": MONO if mono else SANS}
                self._text(x, self.y + 0.25 * step, text, **font)
            self.y -= pad
            if box:
                self._box(top, self.y, *box)
            i += count

    def box(self, title: str, items: list[str], colours: tuple[str, str], *, size: float = 8.5) -> None:
        """A titled list in a coloured box (the warnings box)."""
        inner = self.width - 0.3
        lines = wrap(title, inner, size, mono=False, bold=True)
        body = [line for item in items for line in wrap(item, inner - 0.15, size, mono=False, bullet=True)]
        self.need((len(lines) + min(len(body), 4)) * size * 1.4 / 72 + 0.3)
        self.lines([*lines, *body], size=size, mono=False, box=colours, bold=len(lines))
        self.space(0.12)

    def _box(self, top: float, bottom: float, face: str, edge: str) -> None:
        self._rect(top, bottom, face, edge=edge)
        self._rect(top, bottom, edge, width=0.05)  # the accent bar on the left

    def _rule(self, y: float, colour: str, width: float, x0: float = 0.0, x1: float | None = None) -> None:
        x1 = self.width if x1 is None else x1
        xs = [(MARGIN_X + x0) / PAGE[0], (MARGIN_X + x1) / PAGE[0]]
        self.fig.add_artist(
            Line2D(xs, [y / PAGE[1]] * 2, transform=self.fig.transFigure, color=colour, linewidth=width)
        )

    # -- tables and figures -----------------------------------------------------------------

    def table(self, table: Table, *, size: float = 7.0) -> None:
        """A monospaced table; cells wrap within their column, the header repeats on new pages."""
        char = size * MONO_ADVANCE / 72
        widths = column_widths(table, int(self.width / char) - 2 * (len(table.header) - 1))
        header = _wrap_row(table.header, widths)
        rows = [_wrap_row(row, widths) for row in table.rows]
        step = size * 1.3 / 72
        self.need((_height(header) + (_height(rows[0]) if rows else 0)) * step + 0.15)
        self._table_header(header, widths, table.numeric, size, step)
        for i, row in enumerate(rows):
            height = _height(row) * step + 0.04
            if height > self.room():
                self.new_page()
                self._table_header(header, widths, table.numeric, size, step)
            if i % 2:
                self._shade(self.y, self.y - height, "#f3f4f6")
            self._row(row, widths, table.numeric, size, step)
            self.y -= 0.04
        self.space(0.12)

    def _table_header(self, header: list[list[str]], widths, numeric, size, step) -> None:
        top = self.y
        self._shade(top, top - _height(header) * step - 0.04, "#e6e9ee")
        self._row(header, widths, numeric, size, step, weight="bold")
        self.y -= 0.04
        self._rule(self.y, "#8a94a6", 0.6)
        self.y -= 0.02

    def _row(self, cells: list[list[str]], widths, numeric, size, step, weight="normal") -> None:
        """One table row; each of its lines is drawn as one monospaced string (a text per cell
        would multiply the PDF's text objects, its slowest part, by the number of columns)."""
        top = self.y
        for k in range(_height(cells)):
            parts = []
            for lines, width, right in zip(cells, widths, numeric, strict=True):
                text = lines[k] if k < len(lines) else ""
                parts.append(text.rjust(width) if right else text.ljust(width))
            line = "  ".join(parts).rstrip()
            if line:
                y = top - (k + 1) * step + 0.25 * step
                self._text(MARGIN_X, y, line, size=size, family=MONO, weight=weight)
        self.y = top - _height(cells) * step

    def _shade(self, top: float, bottom: float, colour: str) -> None:
        self._rect(top, bottom, colour)

    def _rect(self, top: float, bottom: float, face: str, *, edge: str = "none", width: float = 0.0) -> None:
        """A filled rectangle behind the text, from the left margin, ``width`` inches wide (0: full)."""
        size = (width or self.width) / PAGE[0], (top - bottom) / PAGE[1]
        self.fig.add_artist(
            Rectangle(
                (MARGIN_X / PAGE[0], bottom / PAGE[1]),
                *size,
                transform=self.fig.transFigure,
                facecolor=face,
                edgecolor=edge,
                linewidth=0.8,
                zorder=-1,
            )
        )

    def image(self, png: bytes | Pending, *, max_height: float = 5.0) -> None:
        """A PNG scaled to the text width (never enlarged beyond its size at the report's dpi).

        A :class:`~matid.report.imagejob.Pending` PNG is placed at its known size now and its
        pixels put in when the page is saved.
        """
        px_w, px_h = (png.width, png.height) if isinstance(png, Pending) else png_size(png)
        width = min(px_w / DPI, self.width)
        height = width * px_h / px_w
        if height > max_height:
            width, height = width * max_height / height, max_height
        self.need(height)
        left = MARGIN_X + (self.width - width) / 2
        picture = Picture(
            (left / PAGE[0], (self.y - height) / PAGE[1], width / PAGE[0], height / PAGE[1]), png
        )
        self.fig.add_artist(picture)
        if isinstance(png, Pending):
            self._pending.append(picture)
        else:
            picture.fetch()
        self.y -= height


# -- layout helpers ---------------------------------------------------------------------------


def add_text(fig: Figure, x: float, y: float, text: str, *, styles: dict | None = None, **style) -> PageText:
    """``fig.text(x, y, text, **style)`` as a :class:`~matid.report.pdftext.PageText` (same place,
    same bytes in the PDF, a fraction of the drawing time); ``styles``: texts made so far, by
    style, to copy (made under the same rcParams, which fill in what a style leaves out)."""
    artist = PageText(**style) if styles is None else _styled(styles, style)
    artist._x, artist._y, artist._text = x, y, "" if text is None else str(text)
    artist.set_transform(fig.transSubfigure)
    artist.set_figure(fig)
    artist.stale_callback = _stale_figure_callback
    fig.texts.append(artist)
    artist._remove_method = fig.texts.remove
    fig.stale = True
    return artist


def _styled(styles: dict, style: dict) -> PageText:
    """A new PageText in ``style``: a copy of the one ``styles`` holds for it (Text.__init__
    checks and sets each property, a tenth of the PDF's time for a report's lines), with its own
    callbacks; the font properties, never changed after, are shared."""
    try:
        key = tuple(style.items())
        template = styles.get(key)
    except TypeError:  # an unhashable value: made as asked
        return PageText(**style)
    if template is None:
        template = styles[key] = PageText(**style)
    artist = PageText.__new__(PageText)
    artist.__dict__.update(template.__dict__)
    artist._callbacks = cbook.CallbackRegistry(signals=["pchanged"])
    return artist


def wrap(
    text: str, width_in: float, size: float, *, mono: bool, bold: bool = False, bullet: bool = False
) -> list[str]:
    """Split ``text`` into lines that fit ``width_in`` inches at ``size`` points.

    Greedy by words, measured with the font's advance widths; a word longer than a line
    (a checksum, a path) is broken where the line is full.
    """
    limit = 0.98 * width_in * 72 / size  # in em, with a margin for kerning and rounding
    lines: list[str] = []
    for k, paragraph in enumerate(str(text).splitlines() or [""]):
        line = "• " if bullet and k == 0 else ("  " if bullet else "")
        rest, empty = ("  " if bullet else ""), True
        for word in paragraph.split():
            candidate = word if empty else f"{line} {word}"
            if not empty and _em(candidate, mono, bold) > limit:
                lines.append(line)
                line, empty = rest, True
            if empty:
                while _em(line + word, mono, bold) > limit and len(word) > 1:
                    cut = _fitting(line, word, limit, mono, bold)
                    lines.append(line + word[:cut])
                    line, word = rest, word[cut:]
                line, empty = line + word, False
            else:
                line = candidate
        lines.append(line)
    return lines


def _fitting(prefix: str, word: str, limit: float, mono: bool, bold: bool) -> int:
    """How many leading characters of ``word`` fit on a line after ``prefix`` (at least 1)."""
    used = _em(prefix, mono, bold)
    for i, char in enumerate(word):
        used += _advance(char, mono, bold)
        if used > limit:
            return max(i, 1)
    return len(word)


def _em(text: str, mono: bool, bold: bool) -> float:
    return sum(_advance(char, mono, bold) for char in text)


_TEXT_TO_PATH = TextToPath()


@lru_cache(maxsize=4096)
def _advance(char: str, mono: bool, bold: bool) -> float:
    """Advance width of one character in em (DejaVu fonts, bundled with matplotlib)."""
    prop = FontProperties(family=MONO if mono else SANS, weight="bold" if bold else "normal", size=100)
    return _TEXT_TO_PATH.get_text_width_height_descent(char, prop, ismath=False)[0] / 100


def column_widths(table: Table, available: int) -> list[int]:
    """Natural column widths in characters, narrowed widest-first until they fit."""
    columns = list(zip(table.header, *table.rows, strict=True))
    widths = [max(len(line) for cell in col for line in (str(cell).splitlines() or [""])) for col in columns]
    widths = [max(w, 1) for w in widths]
    floors = [
        min(w, max(8, max(len(word) for word in h.split() or [""])))
        for w, h in zip(widths, table.header, strict=True)
    ]
    words = [  # first narrow down to the longest word of each column, so no word is split if it can be helped
        max(f, min(w, WORD_CAP, max(len(word) for cell in col for word in str(cell).split() or [""])))
        for f, w, col in zip(floors, widths, columns, strict=True)
    ]
    for limit in (words, floors):
        while sum(widths) > available:
            candidates = [j for j in range(len(widths)) if widths[j] > limit[j]]
            if not candidates:
                break
            j = max(candidates, key=lambda k: widths[k])
            widths[j] -= 1
    return widths


def _height(cells: list[list[str]]) -> int:
    """Lines of the tallest cell of a wrapped row."""
    return max(len(lines) for lines in cells)


def _wrap_row(row: tuple[str, ...], widths: list[int]) -> list[list[str]]:
    return [
        textwrap.wrap(str(cell), width, break_long_words=True, break_on_hyphens=False) or [""]
        for cell, width in zip(row, widths, strict=True)
    ]
