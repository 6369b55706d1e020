"""How a test-machine export is laid out: encoding, delimiter, preamble, header.

docs/contract.md section 7. The file is decoded (a BOM, else strict UTF-8,
else charset-normalizer's best guess among the encodings lab PCs write, or the
test's ``encoding``), split into lines, and the header found as the first row
that is followed (after an optional units row) by numeric rows of as many
cells, trying each delimiter ``\\t``, ``;``, ``,`` and runs of spaces. Lines
above the header are the preamble: ``# key: value``, ``key: value``,
``key,value``, ``"key:","value"`` and ``key<TAB>value`` lines become metadata,
the others are kept as text; both bounded (:data:`MAX_TEXT`, :data:`MAX_LINES`).
"""

from __future__ import annotations

import codecs
import csv
import re
from dataclasses import dataclass
from itertools import islice
from pathlib import Path

from matid.errors import DataError
from matid.io.ingest.spaced import kinds_of, spaced_names
from matid.io.study_keys import MAX_TEXT, bounded_text

#: Delimiters tried, in order of preference on a tie; " " means runs of whitespace.
DELIMITERS = ("\t", ";", ",", " ")
DELIMITER_NAMES = {"\t": "tab", ";": "';'", ",": "','", " ": "runs of spaces"}
#: Lines searched for the header, and preamble lines kept as metadata or text.
MAX_PREAMBLE = 500
#: Lines read by detection: the header's search range and the rows it looks at below a header.
HEAD_LINES = MAX_PREAMBLE + 16
MAX_LINES = 200
#: Encodings charset-normalizer chooses among when a file is neither BOM-marked nor UTF-8.
DETECTED = ["cp1252", "gb18030", "utf_16", "utf_16_le", "utf_16_be", "shift_jis"]
_MULTIBYTE = {"gb18030", "gbk", "gb2312", "shift_jis", "big5", "euc_kr", "euc_jp", "cp932", "cp949"}
#: Chinese or Japanese words are runs of ideographs/kana; one stray Latin-1 byte
#: (``°`` before ``]``) read as GBK is a lone ideograph amid ASCII.
_CJK_WORD = re.compile(r"[\u3040-\u30ff\u4e00-\u9fff]{2,}")
#: Byte-order marks: the codec that reads a file from its start (the mark included), and the
#: one that reads it from the middle (no mark there: :mod:`matid.io.ingest.frame`).
BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32", "utf-32-le"),
    (codecs.BOM_UTF32_BE, "utf-32", "utf-32-be"),
    (codecs.BOM_UTF8, "utf-8-sig", "utf-8"),
    (codecs.BOM_UTF16_LE, "utf-16", "utf-16-le"),
    (codecs.BOM_UTF16_BE, "utf-16", "utf-16-be"),
)
LINE_BREAK = re.compile(r"\r\n|\r|\n")
_WIDE_GAP = re.compile(r"\t|\s{2,}")
_NAME_UNIT = re.compile(r"^\S.*\s*[\[(][^\[\]()]*[\])]$")


@dataclass(frozen=True)
class Layout:
    """Where things are in one file; rows are 0-based line indices."""

    encoding: str
    delimiter: str
    header_at: int | None  # None: no header row (columns named by position)
    units_at: int | None
    data_at: int
    n_cells: int

    @property
    def decimal_comma(self) -> bool:
        return self.delimiter != ","

    def describe(self) -> str:
        """What was seen, for messages: encoding, delimiter, header row."""
        units = "" if self.units_at is None else f", units row {self.units_at + 1}"
        header = (
            f"no header row, data from row {self.data_at + 1}"
            if self.header_at is None
            else f"header row {self.header_at + 1}"
        )
        return f"read as {self.encoding}, {DELIMITER_NAMES[self.delimiter]}-delimited, {header}{units}"


def decode(raw: bytes, path: Path, encoding: str | None = None) -> tuple[str, str]:
    """The text of a file and the encoding used to read it."""
    if encoding is not None:
        try:
            return raw.decode(encoding), encoding
        except UnicodeDecodeError as exc:
            raise DataError(
                f"cannot be read as {encoding} (the test's encoding): byte {exc.start} is "
                f"{raw[exc.start : exc.start + 1]!r}; remove `encoding` to detect it",
                file=path,
            ) from None
        except UnicodeError as exc:  # a codec that reports no position (punycode, idna)
            raise DataError(
                f"cannot be read as {encoding} (the test's encoding): {exc}; remove `encoding` to detect it",
                file=path,
            ) from None
    for bom, name, _ in BOMS:
        if raw.startswith(bom):
            try:
                return raw.decode(name), name
            except UnicodeDecodeError as exc:
                raise DataError(
                    f"starts with a {name} byte-order mark but is not {name}: {exc}", file=path
                ) from None
    try:
        return raw.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        pass
    return _detected(raw)


def _detected(raw: bytes) -> tuple[str, str]:
    """charset-normalizer's candidates in its order of preference, a multi-byte one kept
    only when it reads as words (on a short, mostly ASCII file it cannot tell a lone
    ``°`` in cp1252 from half a GBK character); Latin-1 when none fits."""
    from charset_normalizer import from_bytes

    for match in from_bytes(raw, cp_isolation=DETECTED):
        text = str(match)
        if match.encoding in _MULTIBYTE and not _CJK_WORD.search(text):
            continue
        return text, match.encoding
    return raw.decode("latin-1"), "latin-1"


def nth_break(text: str, n: int) -> re.Match | None:
    """The ``n``-th line break of ``text`` (1-based); None when it has fewer."""
    return next(islice(LINE_BREAK.finditer(text), n - 1, None), None)


def lines_of(text: str, limit: int) -> list[str]:
    """The first ``limit`` lines (the head that layout detection reads), split on line breaks only
    (``str.splitlines`` would also split on \\x0c, \\x85, ... and shift the row numbers from what
    an editor shows); trailing blank lines dropped."""
    end = nth_break(text, limit)
    lines = LINE_BREAK.split(text if end is None else text[: end.start()])
    while lines and not lines[-1].strip():
        lines.pop()
    return lines


#: What separates cells of a space-delimited record: runs of spaces and tabs, as pandas' C reader
#: splits them (``sep=r"\s+"``); a no-break space or another Unicode space stays inside its cell.
_SPACES = re.compile(r"[ \t]+")


def spaced_cells(line: str) -> list[str]:
    """The cells of a space-delimited line, split where the reader of the rows splits them (so an
    error names the cell pandas read: '0.5<NBSP>7' is one cell, not a number, as it was read)."""
    line = line.strip(" \t\r\n")
    return _SPACES.split(line) if line else []


#: A quoted cell (kept whole) or a tab outside one (a separator, as pandas' ``\s+`` reads it).
_QUOTED_OR_TAB = re.compile(r'"[^"]*"|\t')


def split(line: str, delimiter: str) -> list[str]:
    """Cells of one line, stripped; trailing empty cells (a trailing delimiter) dropped.

    Raises csv.Error for a cell longer than csv's field limit.
    """
    if delimiter == " " and '"' not in line:
        cells = spaced_cells(line)
    elif delimiter == " ":  # quoted cells: csv splits at spaces, so tabs outside them become spaces
        spaced = _QUOTED_OR_TAB.sub(lambda m: " " if m.group() == "\t" else m.group(), line.strip())
        cells = next(csv.reader([spaced], delimiter=" ", skipinitialspace=True), [])
    else:
        cells = [c.strip() for c in next(csv.reader([line], delimiter=delimiter), [])]
    while cells and not cells[-1]:
        cells.pop()
    return cells


def _cells(line: str, delimiter: str) -> list[str] | None:
    """:func:`split`, or None for a line with a cell longer than csv's field limit."""
    try:
        return split(line, delimiter)
    except csv.Error:
        return None


#: A number with its thousands grouped and a decimal mark of the other kind, which reads one way
#: only: "1,006.28992" (Instron Bluehill), and "1.006,28992" where a comma may be decimal.
THOUSANDS_DOT = re.compile(r"^[+-]?\d{1,3}(,\d{3})+\.\d*$")
THOUSANDS_COMMA = re.compile(r"^[+-]?\d{1,3}(\.\d{3})+,\d*$")


def number(text: str, decimal_comma: bool) -> float:
    """A float from a cell; ValueError if it is not a plain number (thousands may be grouped,
    :data:`THOUSANDS_DOT`, :data:`THOUSANDS_COMMA`)."""
    if THOUSANDS_DOT.match(text):
        text = text.replace(",", "")
    elif decimal_comma and THOUSANDS_COMMA.match(text):
        text = text.replace(".", "")
    if decimal_comma and text.count(",") == 1 and "." not in text:
        text = text.replace(",", ".")
    if not text or "_" in text or len(text) > 64:
        raise ValueError(text[:64])
    return float(text)


def is_number(text: str, decimal_comma: bool) -> bool:
    try:
        number(text, decimal_comma)
    except ValueError:
        return False
    return True


def names(line: str, delimiter: str, n: int) -> list[str] | None:
    """Header or units cells; with whitespace, names may hold single spaces (``Axial Force``)."""
    if delimiter == " ":
        wide = [c.strip() for c in _WIDE_GAP.split(line.strip()) if c.strip()]
        if len(wide) == n:
            return wide
    return _cells(line, delimiter)


class Ambiguous(ValueError):
    """A header of single-spaced words over a units row that the words cannot be matched to."""


def header_names(lines: list[str], h: int, units_at: int | None, delimiter: str, n: int) -> list[str] | None:
    """Cells of header line ``h`` for ``n`` data cells; single-spaced names resolved by
    :func:`matid.io.ingest.spaced.spaced_names` with the units row. Raises :class:`Ambiguous`
    when a units row of ``n`` cells stands under more words than that that cannot be grouped."""
    cells = names(lines[h], delimiter, n)
    if delimiter != " " or cells is None or len(cells) <= n:
        return cells
    units = None if units_at is None else names(lines[units_at], delimiter, n)
    resolved = spaced_names(cells, n, units)
    if resolved is None and units is not None and len(units) == n and _units_like(units, n):
        raise Ambiguous(
            f"header row {h + 1} has {len(cells)} words separated by single spaces over {n} units; "
            "the names cannot be told apart by their units: export with tab or ',' delimiters"
        )
    return cells if resolved is None else resolved


def _is_data(line: str, delimiter: str) -> int:
    """Cell count of a numeric row (at least two cells and most of them numbers), else 0."""
    cells = _cells(line, delimiter) or []
    comma = delimiter != ","
    numeric = sum(is_number(c, comma) for c in cells)
    # A status or remark column ("ok") may hold text; most cells must be numbers.
    return len(cells) if numeric >= 2 and 2 * numeric > len(cells) else 0


def _width(line: str, delimiter: str) -> int:
    """Cell count of a line (0 when it does not split)."""
    return len(_cells(line, delimiter) or [])


def _candidate(lines: list[str], h: int, delimiter: str, encoding: str) -> Layout | None:
    """The layout if line ``h`` is a header for ``delimiter``, else None."""
    after = [i for i in range(h + 1, min(len(lines), h + 8)) if lines[i].strip()][:4]
    if not after:
        return None
    units_at = None
    n = _is_data(lines[after[0]], delimiter)
    if not n:
        if len(after) < 2 or not (n := _is_data(lines[after[1]], delimiter)):
            return None
        units_at, after = after[0], after[1:]
    # "followed by rows of numbers": a block of data, not one or two numeric-looking preamble
    # lines (a LabVIEW segment header's X0 and Delta_X before ***End_of_Header***); a row of
    # the block's width with a bad cell stays in it, for its message to name the cell
    if any(not _is_data(lines[i], delimiter) and _width(lines[i], delimiter) != n for i in after[1:3]):
        return None
    header = header_names(lines, h, units_at, delimiter, n)
    # Trailing columns may be empty in the data (a remark column): the header may be wider.
    if header is None or not n <= len(header) <= 2 * n or not _names(header, delimiter != ","):
        return None
    n = len(header)
    if units_at is not None and not _units_like(names(lines[units_at], delimiter, n), n):
        return None
    return Layout(encoding, delimiter, h, units_at, after[0], n)


def _names(header: list[str], decimal_comma: bool) -> bool:
    """A row of column names: no cell a number, but the first may be a whole number over names
    (Instron Bluehill writes the specimen number before its column row, ``1,Time,Force,...``)."""
    first, rest = header[0].strip(), header[1:]
    if any(is_number(c, decimal_comma) for c in rest):
        return False
    return not is_number(first, decimal_comma) or (first.isdigit() and sum(bool(c) for c in rest) >= 2)


def _units_like(cells: list[str] | None, n: int) -> bool:
    """A units row: at most n short cells, none a ``name (unit)`` header cell, one a unit
    (bracketed, or of a quantity but strain: a ratio such as mm/mm is not taken for a unit here)."""
    if cells is None or len(cells) > n or any(len(c) > 24 or _NAME_UNIT.match(c) for c in cells):
        return False
    return any(c != c.strip("()[] ") or c in ("%", "-", "1") or kinds_of(c) - {"strain"} for c in cells)


def detect(lines: list[str], path: Path, encoding: str, *, positions: bool = False) -> Layout:
    """The first line that is a header for some delimiter; the delimiter giving most columns.
    With ``positions`` (the test names its columns by number), a file without a header row is
    read from its first block of number rows."""
    for h in range(min(len(lines), MAX_PREAMBLE)):
        if not lines[h].strip() or lines[h].lstrip().startswith("#"):
            continue
        try:
            found = [c for d in DELIMITERS if (c := _candidate(lines, h, d, encoding)) is not None]
        except Ambiguous as exc:
            raise DataError(str(exc), file=path, row=h + 1) from None
        if found:
            layout = max(found, key=lambda c: c.n_cells)
            _no_data_above(lines, layout, path)
            return layout
    if positions and (layout := _headerless(lines, encoding)) is not None:
        return layout
    raise DataError(
        f"no header row found (read as {encoding}): expected a row of column names followed, "
        "after an optional units row, by rows of numbers with as many cells, separated by ',', "
        f"';', tab or spaces; looked at the first {min(len(lines), MAX_PREAMBLE)} lines. A file "
        "without a header row is read when the [[test]] names its columns by number (1 = the first) "
        'with their units: columns = { force = 3 }, units = { force = "kN" }',
        file=path,
    )


def _headerless(lines: list[str], encoding: str) -> Layout | None:
    """The layout of a file without a header row: the first line that starts three number rows
    of one width (the delimiter giving most columns); the lines above it are its preamble."""
    for d in range(min(len(lines), MAX_PREAMBLE)):
        rows = [i for i in range(d, min(len(lines), d + 8)) if lines[i].strip()][:3]
        if len(rows) < 3 or rows[0] != d:
            continue
        found = []
        for delimiter in DELIMITERS:
            widths = {_is_data(lines[i], delimiter) for i in rows}
            if len(widths) == 1 and 0 not in widths:
                found.append((widths.pop(), delimiter))
        if found:
            n, delimiter = max(found, key=lambda f: f[0])
            return Layout(encoding, delimiter, None, None, d, n)
    return None


def _no_data_above(lines: list[str], layout: Layout, path: Path) -> None:
    """A row of numbers as wide as the header above it is data the preamble would swallow
    silently: a header row or a second export's preamble pasted in among the first rows."""
    for i in range(layout.header_at):
        cells = _cells(lines[i], layout.delimiter) or []
        if 2 <= len(cells) <= layout.n_cells and all(is_number(c, layout.decimal_comma) for c in cells):
            raise DataError(
                f"row of numbers above the header row {layout.header_at + 1}: is a header row (or a "
                "second export) pasted in among the data? The rows above a header are not read as "
                "data; remove the repeated header, or split the file into one export each",
                file=path,
                row=i + 1,
            )


def preamble(lines: list[str], layout: Layout) -> tuple[dict[str, str], tuple[str, ...]]:
    """Metadata and free text of the lines above the header, both bounded."""
    metadata: dict[str, str] = {}
    text: list[str] = []
    for line in lines[: layout.data_at if layout.header_at is None else layout.header_at]:
        if not line.strip():
            continue
        if len(metadata) + len(text) >= MAX_LINES:
            text.append(f"[... further preamble lines not kept, at most {MAX_LINES}]")
            break
        pair = _key_value(line[: 4 * MAX_TEXT], layout.delimiter)
        if pair is None:
            text.append(bounded_text(line.strip()))
            continue
        key, value = bounded_text(pair[0], 200), bounded_text(pair[1])
        k, n = key, 1
        while k in metadata:
            n += 1
            k = f"{key} ({n})"
        metadata[k] = value
    return metadata, tuple(text)


def _key_value(line: str, delimiter: str) -> tuple[str, str] | None:
    """(key, value) of a metadata line, or None for free text."""
    text = line.strip()
    if text.startswith("#"):
        key, sep, value = text.lstrip("#").partition(":")
        return (key.strip(), value.strip()) if sep and key.strip() else None
    key, sep, value = text.partition(":")
    if sep and key.strip() and not any(ch in key for ch in ',;\t"|'):
        return key.strip(), value.strip(" \t,;\"'")
    for d in dict.fromkeys(("\t", delimiter, ",", ";")):
        if d == " ":
            continue
        cells = _cells(text, d)
        if cells is None:
            return None
        if len(cells) >= 2 and (first := cells[0].strip().rstrip(":").strip()):
            return first, " ".join(c for c in cells[1:] if c)
    return None
