"""The numbers of an export, read by pandas' C engine once the layout is known (contract 7, 10).

:mod:`matid.io.ingest.detect` finds encoding, delimiter, header and units row on
the first lines; the data rows, from the first one to the end of the file, are
then parsed by ``pandas.read_csv(engine="c")`` with the detected delimiter
(runs of spaces as ``\\s+``), decimal mark and encoding, from the byte where the
first data row starts. Blank rows stay in the parse and are dropped after it,
so row k of the parse is file line ``data_at + k + 1`` and every message names
the line an editor shows. pandas' default converter gives the double Python's
``float`` gives for the cell (tests/io/test_ingest.py checks it on random cells).

A cell pandas does not read as a number (text, an empty cell of a used column,
a decimal comma in a ``.`` file) is looked at alone, by the same rule as a short
file: :func:`matid.io.ingest.detect.number`, so the message is the same.
"""

from __future__ import annotations

import codecs
import contextlib
import csv
import io
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from matid.errors import DataError
from matid.io.ingest.detect import (
    BOMS,
    LINE_BREAK,
    THOUSANDS_COMMA,
    THOUSANDS_DOT,
    Layout,
    nth_break,
    number,
    spaced_cells,
    split,
)
from matid.io.study_keys import bounded_text

if TYPE_CHECKING:  # pandas is imported when a record is read, so `import matid` stays light
    import pandas as pd


@dataclass(frozen=True, eq=False)
class Rows:
    """The data rows as parsed: ``frame`` columns 0..n-1 (blank rows dropped), and each row's
    1-based file line; ``raw`` is the file, to quote a line in a message."""

    frame: pd.DataFrame
    lines: pd.Index
    raw: bytes
    layout: Layout
    path: Path


@dataclass(frozen=True)
class Start:
    """Where the data rows start in the file's bytes, and their decimal mark."""

    offset: int
    decimal: str


def locate(raw: bytes, text: str, layout: Layout) -> Start:
    """The byte offset of the first data row and the decimal mark, from the decoded ``text``
    (which the caller may then drop: the rows are parsed from ``raw``)."""
    start = _line_start(text, layout.data_at)
    return Start(_offset(raw, text[:start], layout.encoding), _decimal(text, start, layout))


def _offset(raw: bytes, head: str, encoding: str) -> int:
    """The byte of ``raw`` where its decoded start ``head`` ends (after a byte-order mark if ``head`` is
    empty). ``head`` encoded again gives it, with the mark's length, when that gives back the file's
    bytes; where it does not, the bytes are decoded one by one until ``head`` is read: a mark the codec
    keeps as U+FEFF (a UTF-8 file with a mark read as "utf-8": it was counted twice, and the first row
    lost its first character), or iso2022_jp's redundant escapes."""
    codec, bom = _tail_codec(raw, encoding)
    if not head:
        return bom
    with contextlib.suppress(UnicodeError):
        guess = bom + len(head.encode(codec))
        if raw[:guess].decode(encoding) == head:
            return guess
    decoder, chars = codecs.getincrementaldecoder(encoding)(), 0
    for end in range(1, len(raw) + 1):
        chars += len(decoder.decode(raw[end - 1 : end]))
        if chars >= len(head):
            return end
    return len(raw)


def read_rows(raw: bytes, start: Start, layout: Layout, path: Path) -> Rows:
    """Parse the data rows of ``raw`` from ``start`` with pandas' C engine.

    Rows of unequal length (a short first row, a trailing delimiter on some rows) are parsed
    again with as many columns as the longest row has fields, after checking that no row holds
    more cells than the header.
    """
    import pandas as pd

    try:
        frame = _parse(raw, start, layout, None)
    except pd.errors.ParserError:
        _first_bad_row(raw, layout, path)
        try:
            frame = _parse(raw, start, layout, _widest(raw, layout))
        except pd.errors.ParserError as exc:  # not a width: a quote that never closes, say
            raise _unparsable(raw, layout, path, exc) from None
    if not all(pd.api.types.is_numeric_dtype(t) for t in frame.dtypes):
        frame = frame.apply(_blank_as_na)
    blank = frame.isna().all(axis=1).to_numpy()
    if blank.any():
        frame = frame[~blank]
    lines = frame.index + (layout.data_at + 1)  # a RangeIndex (no memory) when no row was blank
    return Rows(_check_width(frame, lines, raw, layout, path), lines, raw, layout, path)


def without_trailing(rows: Rows, indices: list[int]) -> Rows:
    """``rows`` without the rows at the end where every column of ``indices`` is empty: the lines
    after one record ends in a file of records side by side (a Shimadzu Trapezium export of several
    specimens writes each one's columns next to the others', the shorter ones ending first). An
    empty cell before the last value of the record stays an empty cell."""
    present = rows.frame.reindex(columns=indices).notna().any(axis=1).to_numpy()
    if present.size == 0 or present[-1]:
        return rows
    keep = int(np.flatnonzero(present)[-1]) + 1 if present.any() else 0
    return Rows(rows.frame.iloc[:keep], rows.lines[:keep], rows.raw, rows.layout, rows.path)


def _parse(raw: bytes, start: Start, layout: Layout, width: int | None) -> pd.DataFrame:
    """``pandas.read_csv(engine="c")`` of the bytes from ``start``; ``width`` columns when given."""
    import pandas as pd

    buffer = io.BytesIO(raw)  # shares raw's bytes; no copy of a long record
    buffer.seek(start.offset)
    try:
        return pd.read_csv(
            buffer,
            sep=r"\s+" if layout.delimiter == " " else layout.delimiter,
            header=None,
            names=None if width is None else range(width),
            index_col=None if width is None else False,
            engine="c",
            encoding=_tail_codec(raw, layout.encoding)[0],
            decimal=start.decimal,
            skip_blank_lines=False,
            quotechar='"',
            **_exact_floats(pd.__version__),
        )
    except pd.errors.EmptyDataError:
        return pd.DataFrame()


def _exact_floats(version: str) -> dict[str, str]:
    """read_csv's option for the double Python's float() reads from each cell: pandas before 3
    reads some cells an ulp off with its default converter (seen on 2.0.0, our lowest pin), its
    round-trip one is exact; pandas 3's default is exact, and it deprecates the option."""
    return {} if int(version.split(".")[0]) >= 3 else {"float_precision": "round_trip"}


def _widest(raw: bytes, layout: Layout) -> int:
    """An upper bound of the fields of any data row (delimiters + 1, empty trailing cells counted)."""
    rows = _data_lines(raw, layout)
    if layout.delimiter == " ":
        return max((len(spaced_cells(r)) for r in rows), default=1)
    return max((r.count(layout.delimiter) + 1 for r in rows), default=1)


def _blank_as_na(series: pd.Series) -> pd.Series:
    """A text column with cells of spaces only as missing (a line of spaces is a blank row)."""
    import pandas as pd

    if pd.api.types.is_numeric_dtype(series):
        return series
    text = series.astype("string").str.strip()
    return series.where(text.ne("").fillna(False))


def column(rows: Rows, index: int, name: str, *, required: bool) -> np.ndarray | None:
    """Column ``index`` as floats; a bad cell of a ``required`` column raises a DataError at its row,
    another column with a bad cell is None (dropped)."""
    import pandas as pd

    frame = rows.frame
    series = frame[index] if index in frame.columns else pd.Series(np.nan, index=frame.index)
    if not pd.api.types.is_numeric_dtype(series):
        text = _ungrouped(series.astype("string").str.strip(), rows.layout.decimal_comma)
        if rows.layout.decimal_comma:  # "1,5" is 1.5 where a comma may be decimal (detect.number)
            comma = text.str.count(",").eq(1) & ~text.str.contains(".", regex=False)
            _grouped(rows, text, comma.fillna(False).to_numpy(), index, name)
            text = text.where(~comma.fillna(False), text.str.replace(",", ".", regex=False))
        series = pd.to_numeric(text, errors="coerce")
    values = series.to_numpy(dtype=float, na_value=np.nan)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size == 0:
        return values
    if required:
        _cell_error(rows, int(bad[0]), index, name)
    return None


def _ungrouped(text: pd.Series, decimal_comma: bool) -> pd.Series:
    """Cells with their thousands grouped (``THOUSANDS_DOT``, ``THOUSANDS_COMMA`` of
    :mod:`matid.io.ingest.detect`) without the grouping marks, as :func:`number` reads them."""
    dot = text.str.match(THOUSANDS_DOT.pattern).fillna(False)
    text = text.where(~dot, text.str.replace(",", "", regex=False))
    if decimal_comma:
        comma = text.str.match(THOUSANDS_COMMA.pattern).fillna(False)
        text = text.where(~comma, text.str.replace(".", "", regex=False))
    return text


#: A cell that reads two ways where a column mixes decimal marks: "1,012" (1.012 or 1012).
_GROUPED = r"^[+-]?[1-9]\d{0,2}[.,]\d{3}$"


def _grouped(rows: Rows, text: pd.Series, comma: np.ndarray, index: int, name: str) -> None:
    """A column with both ',' and '.' as decimal mark has no one reading of a cell such as
    "1,012" or "1.250" (a thousands separator or a decimal mark): raise at the first one."""
    dot = text.str.contains(".", regex=False).fillna(False).to_numpy() & ~comma
    if not (dot.any() and comma.any()):
        return
    ambiguous = np.flatnonzero(text.str.match(_GROUPED).fillna(False).to_numpy())
    if ambiguous.size:
        k = int(ambiguous[0])
        cell = str(text.iloc[k])
        raise DataError(
            f"'{cell}' reads as {cell.replace(',', '.')} (a decimal mark) or "
            f"{cell.replace(',', '').replace('.', '')} (a thousands separator), and this column "
            "has both ',' and '.' as decimal mark: export with one decimal mark and no thousands separator",
            file=rows.path,
            row=int(rows.lines[k]),
            column=name,
        )


def _decimal(text: str, start: int, layout: Layout) -> str:
    """',' when the delimiter allows a decimal comma and the first data row uses one, else '.'."""
    if not layout.decimal_comma:
        return "."
    end = LINE_BREAK.search(text, start)
    first = text[start : end.start() if end else len(text)]
    cells = split(first, layout.delimiter)
    return "," if any("," in c and "." not in c for c in cells) else "."


def _line_start(text: str, line: int) -> int:
    """Character offset of 0-based ``line`` (as :func:`matid.io.ingest.detect.lines_of` counts)."""
    if line == 0:
        return 0
    match = nth_break(text, line)
    return len(text) if match is None else match.end()


def _tail_codec(raw: bytes, encoding: str) -> tuple[str, int]:
    """(codec for bytes after the start, length of the byte-order mark the start has)."""
    family = codecs.lookup(encoding).name
    for bom, name, codec in BOMS:  # a mark of this codec's own (UTF-16 LE text may start FF FE 00 00)
        if raw.startswith(bom) and family in (name, codec):
            return codec, len(bom)
    return {"utf-8-sig": "utf-8", "utf-16": "utf-16-le", "utf-32": "utf-32-le"}.get(family, family), 0


def _data_lines(raw: bytes, layout: Layout) -> list[str]:
    """The decoded lines from the first data row on (for messages and a re-parse only: not kept)."""
    text = raw.decode(layout.encoding, errors="replace")
    return LINE_BREAK.split(text[_line_start(text, layout.data_at) :])


def _cells(lines: list[str], k: int, layout: Layout, path: Path) -> list[str]:
    """The cells of ``lines[k]``, file line ``data_at + k + 1`` (a line past the end has none)."""
    try:
        return split(lines[k] if k < len(lines) else "", layout.delimiter)
    except csv.Error:
        raise DataError(
            f"a cell is longer than {csv.field_size_limit()} characters",
            file=path,
            row=layout.data_at + k + 1,
        ) from None


def _too_many_cells(cells: list[str], layout: Layout, path: Path, row: int) -> DataError:
    return DataError(f"row has {len(cells)} cells, header has {layout.n_cells}", file=path, row=row)


def _check_width(
    frame: pd.DataFrame, lines: pd.Index, raw: bytes, layout: Layout, path: Path
) -> pd.DataFrame:
    """The frame without cells beyond the header's (empty: a trailing delimiter); a row with
    values there has more cells than the header and is an error."""
    extra = [c for c in frame.columns if c >= layout.n_cells]
    if not extra:
        return frame
    wide = np.flatnonzero(frame[extra].notna().any(axis=1).to_numpy())
    if wide.size:
        line = int(lines[wide[0]])
        cells = _cells(_data_lines(raw, layout), line - layout.data_at - 1, layout, path)
        raise _too_many_cells(cells, layout, path, line)
    return frame.drop(columns=extra)


def _first_bad_row(raw: bytes, layout: Layout, path: Path) -> None:
    """Raise the DataError of the first row pandas could not parse (a row wider than the header)."""
    lines = _data_lines(raw, layout)
    for k in range(len(lines)):
        cells = _cells(lines, k, layout, path)
        if len(cells) > layout.n_cells:
            raise _too_many_cells(cells, layout, path, layout.data_at + k + 1)


def _unparsable(raw: bytes, layout: Layout, path: Path, exc: Exception) -> DataError:
    """The DataError of rows pandas cannot tokenise at any width: the first line with an odd number of
    quotes opens a quoted cell that never closes (the parser then reads to the end of the file)."""
    lines = _data_lines(raw, layout)
    k = next((k for k, line in enumerate(lines) if line.count('"') % 2), None)
    if k is None:
        return DataError(f"the data rows cannot be read: {bounded_text(str(exc), 80)}", file=path)
    return DataError('a quote (") opens a cell and is never closed', file=path, row=layout.data_at + k + 1)


def _cell_error(rows: Rows, k: int, index: int, name: str) -> None:
    """Raise the DataError of row ``k``'s cell ``index``, as a short file's reader words it."""
    line = int(rows.lines[k])
    cells = _cells(_data_lines(rows.raw, rows.layout), line - rows.layout.data_at - 1, rows.layout, rows.path)
    if index >= len(cells):
        raise _too_many_cells(cells, rows.layout, rows.path, line)
    if not cells[index]:
        raise DataError("empty cell", file=rows.path, row=line, column=name)
    text = cells[index]
    try:
        number(text, rows.layout.decimal_comma)
        if not text.strip().isascii():  # float() reads '١٢' and '０.５', pandas (which reads rows) not
            raise ValueError(text)
    except ValueError:
        raise DataError(
            f"not a number: '{bounded_text(text, 80)}'{_hint(text)}", file=rows.path, row=line, column=name
        ) from None
    raise DataError(
        f"NaN or infinite value '{bounded_text(text, 80)}'", file=rows.path, row=line, column=name
    )


#: Number styles some exports and hand edits have that matid does not read, and what to write instead.
_HINTS = (
    (re.compile("\u2212"), "the minus sign '\u2212' (U+2212) is not read: write '-'"),
    (
        re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)[dDqQ][+-]?\d+$"),
        "a Fortran exponent (D or Q) is not read: write E",
    ),
    (re.compile(r"^#(DIV/0!|N/A|VALUE!|REF!|NUM!|NAME\?|NULL!|#+)$"), "a spreadsheet error cell"),
    (re.compile(r"(?![0-9])\d"), "only the digits 0-9 are read"),  # \d: any Unicode digit
    (re.compile(r"(?![ \t])\s"), "a Unicode space (such as the no-break space U+00A0) is inside the cell: "
     "cells are split at spaces and tabs only"),  # fmt: skip
)


def _hint(text: str) -> str:
    """`` (why)`` for a cell in a number style matid does not read, else ''."""
    cell = text.strip()
    hint = next((why for pattern, why in _HINTS if pattern.search(cell)), None)
    return f" ({hint})" if hint else ""
