"""Lines of text on the PDF pages, drawn for a third of matplotlib's cost and byte for byte the same.

Every line of the PDF report is a matplotlib Text placed at its bottom-left corner. Drawn by
:meth:`matplotlib.text.Text.draw`, each string is laid out three times: ``set_text`` for its
extent (``Text._get_layout``), then raqm's layout and one ``load_glyph`` per character inside
``RendererPdf.draw_text``. That was four fifths of the PDF's time (profiled on the demo report).

For one line, unrotated and aligned at its bottom left, the extent only sets the baseline:
``bottom + max(descent, the font's typographic descent)``, the ascent entering through the
same floating-point expression matplotlib evaluates. :class:`PageText` gets the extent from the
one raqm layout it draws with (the control boxes of its glyphs, cached per glyph and size) and
writes the operators of ``RendererPdf.draw_text`` itself (one write per line), the font-subset
lookups and each distinct line's layout and operators cached per PDF file. Any other case (another
renderer, several lines, rotation, other alignment, a path effect, a box, a link, the PDF core
fonts) goes through ``Text.draw`` unchanged; tests/test_report_pdftext.py compares pages drawn
both ways byte for byte.
"""

from __future__ import annotations

import math
import unicodedata
import weakref
from typing import NamedTuple

import matplotlib as mpl
from matplotlib import colors as mcolors
from matplotlib.backends.backend_mixed import MixedModeRenderer
from matplotlib.backends.backend_pdf import Op, RendererPdf, _fill, pdfRepr
from matplotlib.font_manager import fontManager, get_font
from matplotlib.text import Text

try:  # matplotlib >= 3.11; older versions draw every line with Text.draw (same pages, slower)
    from matplotlib.font_manager import FontPath
    from matplotlib.ft2font import FT2Font, LoadFlags

    SUPPORTED = all(
        hasattr(owner, name)
        for owner, name in ((FT2Font, "_layout"), (Text, "get_fontfeatures"), (Text, "get_language"))
    )
except ImportError:
    SUPPORTED = False

#: Per PDF file: (font file, face, char, glyph) -> (subset, code), and (font file, face, subset) -> name.
_TRACKED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class PageText(Text):
    """A Text whose plain one-line case is drawn by :func:`draw_line` (see the module docstring)."""

    def draw(self, renderer) -> None:
        if not self._plain(renderer):
            return super().draw(renderer)
        if renderer is not None:
            self._renderer = renderer
        if not self.get_visible() or self.get_text() == "":
            return
        posx, posy = self.get_transform().transform((float(self._x), float(self._y)))
        if not (math.isfinite(posx) and math.isfinite(posy)):
            return super().draw(renderer)
        renderer.open_group("text", self.get_gid())
        gc = renderer.new_gc()
        gc.set_foreground(mcolors.to_rgba(self.get_color()), isRGBA=True)
        gc.set_alpha(self.get_alpha())
        gc.set_url(self._url)
        gc.set_antialiased(self._antialiased)
        gc.set_snap(self.get_snap())
        self._set_gc_clip(gc)
        dpi = self.get_figure(root=True).dpi
        if not draw_line(_pdf(renderer), gc, posx, posy, self.get_text(), self._fontproperties, dpi):
            gc.restore()
            renderer.close_group("text")
            return super().draw(renderer)
        gc.restore()
        renderer.close_group("text")
        self.stale = False

    def _plain(self, renderer) -> bool:
        return (
            SUPPORTED
            and isinstance(_pdf(renderer), RendererPdf)
            and not mpl.rcParams["pdf.use14corefonts"]
            and "\n" not in self.get_text()
            and self.get_rotation() == 0
            and self.get_horizontalalignment() == "left"
            and self.get_verticalalignment() == "bottom"
            and self.get_rotation_mode() != "anchor"
            and not self.get_usetex()
            and not self.get_parse_math()
            and not self.get_wrap()
            and self._linespacing == "normal"
            and self._bbox_patch is None
            and not self.get_path_effects()
            and self._url is None
            and self.get_fontfeatures() is None
            and self.get_language() is None
        )


def _pdf(renderer):
    """The PDF renderer behind PdfPages' MixedModeRenderer (outside a rasterised artist)."""
    return renderer._renderer if isinstance(renderer, MixedModeRenderer) else renderer


def draw_line(renderer: RendererPdf, gc, x: float, bottom: float, s: str, prop, dpi: float) -> bool:
    """``Text.draw`` of the one-line text ``s`` whose bottom-left corner is at (x, bottom), in points.

    False (and nothing drawn) when the font has no table to read its typographic extent from.
    """
    extent = _font_extent(prop, dpi)
    if extent is None:
        return False
    min_ascent, min_descent = extent
    font = renderer._get_font_ttf(prop)  # sized to prop
    size = prop.get_size_in_points()
    fonttype = mpl.rcParams["pdf.fonttype"]
    drawn = _LINES.setdefault(renderer.file, {})
    key = (font, size, fonttype, s)  # the font object itself: the items refer to it (and its fallbacks)
    if key not in drawn:
        items = _monospaced(font, s, size) or list(
            font._layout(s, LoadFlags.NO_HINTING, features=None, language=None)
        )
        drawn[key] = (*_ybox(items, size), _body(renderer, items, size, fonttype))
    y_min, y_max, body = drawn[key]
    h, d = (y_max - y_min) / 64, -y_min / 64
    # Text._get_layout for one line with linespacing "normal", then the bottom alignment
    a = max(h - d, min_ascent)
    d = max(d, min_descent)
    top = 0.0
    top -= a
    y = bottom + (top - (top - d))
    renderer.check_gc(gc, gc._rgb)
    renderer.file.write(_GSAVE + _fill([*_UNROTATED, pdfRepr(x), pdfRepr(y), _CM]) + b"\n" + body)
    return True


#: Per PDF file: (font, size, pdf.fonttype, text) -> the line's box (bottom, top in 1/64 point)
#: and its text operators after the position; a third of the report's lines repeat one drawn
#: before (a header, the footer of every page, a table's header row).
_LINES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _ybox(items, size: float) -> tuple[int, int]:
    """Bottom and top of the glyphs' control boxes, as ``FT2Font.set_text`` unites them."""
    if not items:
        return 0, 0
    y_min, y_max = 32000, -32000  # FT2Font.set_text's empty box, in 1/64 point
    boxes, boxes_ft = {}, None
    for item in items:
        ft = item.ft_object
        if ft is not boxes_ft:
            boxes, boxes_ft = _GLYPH_YBOX.setdefault((ft.fname, ft.face_index, size), {}), ft
        box = boxes.get(item.glyph_index)
        if box is None:
            box = boxes[item.glyph_index] = _glyph_ybox(ft, item.glyph_index)
        if box[0] < y_min:
            y_min = box[0]
        if box[1] > y_max:
            y_max = box[1]
    return y_min, y_max


def _body(renderer: RendererPdf, items, fontsize: float, fonttype: int) -> bytes:
    """The text operators of ``RendererPdf.draw_text`` (TrueType/Type 3 branch, angle 0) after
    the position: each ``PdfFile.output`` call's line (``_fill`` of the pdfRepr of its operands,
    then a newline). The glyphs are tracked for the file's font subsets here."""
    file = renderer.file
    tracked = _TRACKED.setdefault(file, {})
    lines = [_BEGIN]
    values: list = []  # the TJ array: glyph strings and the kerns between them
    codes: list[int] = []  # glyph codes of the string not yet in it

    def flush() -> None:
        if codes:
            values.append(renderer._encode_glyphs(codes, fonttype))
            codes.clear()
        if values:
            lines.append(_fill([_Array(values).pdfRepr(), _TJ]) + b"\n")
            values.clear()

    previous, start_x = None, 0
    names: dict = {}  # font object -> (file name, face index)
    for item in items:
        ft = item.ft_object
        name = names.get(ft)
        if name is None:
            name = names[ft] = (ft.fname, ft.face_index)
        key = (*name, item.char, item.glyph_index)
        found = tracked.get(key)
        if found is None:
            found = tracked[key] = file._character_tracker.track_glyph(ft, item.char, item.glyph_index)
        subset, charcode = found
        if previous is None or previous[0] is not ft or previous[1] != subset:
            flush()
            select = (*name, subset, fontsize)
            if select not in tracked:
                font_name = file.fontName(FontPath(*name), subset)
                tracked[select] = _fill([pdfRepr(font_name), pdfRepr(fontsize), _TF]) + b"\n"
            lines.append(tracked[select])
            lines.append(_fill([pdfRepr(item.x - start_x), _ZERO, _TD]) + b"\n")
            previous, start_x = (ft, subset), item.x
        if item.y:
            flush()
            lines.append(_fill([pdfRepr(item.y), _TS]) + b"\n")
        if item.prev_kern:
            if codes:
                values.append(renderer._encode_glyphs(codes, fonttype))
                codes.clear()
            values.append(-1000 * item.prev_kern / fontsize)
        codes.append(charcode)
        if item.y:
            flush()
            lines.append(_RISE0)
    flush()
    lines.append(_END)
    return b"".join(lines)


#: The operators and constant operands draw_line writes, as PdfFile.output writes them.
_GSAVE, _BEGIN = Op.gsave.value + b"\n", Op.begin_text.value + b"\n"
_END = Op.end_text.value + b"\n" + Op.grestore.value + b"\n"
_CM, _TF, _TD, _TS, _TJ = (
    op.value for op in (Op.concat_matrix, Op.selectfont, Op.textpos, Op.textrise, Op.showkern)
)
_UNROTATED = [pdfRepr(v) for v in (math.cos(0.0), math.sin(0.0), -math.sin(0.0), math.cos(0.0))]
_ZERO = pdfRepr(0 - 0)  # the y of RendererPdf._setup_textpos: 0 - 0
_RISE0 = _fill([pdfRepr(0), _TS]) + b"\n"


#: pdfRepr of the kerns and glyph strings met so far (a table row repeats a few of them);
#: emptied when it reaches _REPR_MAX entries, so a long batch process does not grow it without end.
_REPR: dict[object, bytes] = {}
_REPR_MAX = 50_000


class _Array:
    """A TJ array, written as ``pdfRepr(list)`` writes it, each element's repr looked up once."""

    __slots__ = ("values",)

    def __init__(self, values: list) -> None:
        self.values = values

    def pdfRepr(self) -> bytes:  # noqa: N802 -- the name backend_pdf.pdfRepr looks for
        parts = [b"["]
        for value in self.values:
            key = (type(value), value)  # (float, 0.0) would also find -0.0: zero kerns are never written
            if key not in _REPR:
                if len(_REPR) >= _REPR_MAX:
                    _REPR.clear()
                _REPR[key] = pdfRepr(value)
            parts.append(_REPR[key])
        parts.append(b"]")
        return _fill(parts)


class _Item(NamedTuple):
    """The fields of raqm's LayoutItem that drawing reads."""

    ft_object: object
    char: str
    glyph_index: int
    x: float
    y: float
    prev_kern: float


#: Left to right without shaping: the bidi classes of Latin text, digits, punctuation, symbols, space.
_SIMPLE_BIDI = frozenset({"L", "EN", "ES", "ET", "CS", "ON", "WS"})
_MONO_FILES = ("DejaVuSansMono.ttf", "DejaVuSansMono-Bold.ttf")
_MONO_STEP: dict[tuple, tuple[float, float]] = {}
_MONO_GLYPH: dict[tuple, int] = {}


def _monospaced(font, s: str, size: float) -> list[_Item] | None:
    """raqm's layout of ``s`` in DejaVu Sans Mono at ``size`` points, without raqm: the same advance
    for every character and the same (rounding) kern between any two, read off raqm once per
    font and size. None for another font, or a character that is missing, combining or
    right-to-left (raqm lays those out). tests/test_report_pdftext.py compares the two."""
    if not font.fname.endswith(_MONO_FILES):
        return None
    glyphs = []
    for char in s:
        key = (font.fname, char)
        if key not in _MONO_GLYPH:
            simple = unicodedata.bidirectional(char) in _SIMPLE_BIDI and not unicodedata.combining(char)
            _MONO_GLYPH[key] = font.get_char_index(ord(char)) if simple and char.isprintable() else 0
        if not _MONO_GLYPH[key]:
            return None
        glyphs.append(_MONO_GLYPH[key])
    key = (font.fname, font.face_index, size)
    if key not in _MONO_STEP:
        second = list(font._layout("00", LoadFlags.NO_HINTING, features=None, language=None))[1]
        _MONO_STEP[key] = (second.x, second.prev_kern)
    step, kern = _MONO_STEP[key]
    return [
        _Item(font, char, glyph, i * step, 0.0, kern if i else 0.0)
        for i, (char, glyph) in enumerate(zip(s, glyphs, strict=True))
    ]


#: (font file, face, size) -> glyph -> bottom and top of its control box
_GLYPH_YBOX: dict[tuple, dict[int, tuple[int, int]]] = {}
_FONT_EXTENT: dict[tuple, tuple[float, float] | None] = {}


def _glyph_ybox(ft, glyph: int) -> tuple[int, int]:
    """Bottom and top of a glyph's control box in 1/64 point at the font's size, as
    ``FT2Font.set_text`` unites them."""
    box = ft.load_glyph(glyph, flags=LoadFlags.NO_HINTING).bbox
    return box[1], box[3]


def _font_extent(prop, dpi: float) -> tuple[float, float] | None:
    """The font's typographic ascent and descent at this size, as ``Text._get_layout`` reads them."""
    key = (
        tuple(prop.get_family()), prop.get_style(), prop.get_variant(), prop.get_weight(),
        prop.get_stretch(), prop.get_size_in_points(), prop.get_file(), prop.get_math_fontfamily(), dpi,
    )  # fmt: skip
    if key not in _FONT_EXTENT:
        _FONT_EXTENT[key] = None
        font = get_font(fontManager._find_fonts_by_props(prop))
        for table_name, ascent_key, descent_key in (
            ("OS/2", "sTypoAscender", "sTypoDescender"),
            ("hhea", "ascent", "descent"),
        ):
            table = font.get_sfnt_table(table_name)
            if table is not None:
                scale = 1 / font.get_sfnt_table("head")["unitsPerEm"] * prop.get_size_in_points() * dpi / 72
                _FONT_EXTENT[key] = (table[ascent_key] * scale, -table[descent_key] * scale)
                break
    return _FONT_EXTENT[key]
