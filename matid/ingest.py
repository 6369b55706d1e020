"""CSV ingest: raw test-machine exports turned into named columns in SI.

Implements data-contract.md section 2. A file is read as

1. optional leading metadata lines ``# key: value`` (kept in ``Table.metadata``);
2. one header row whose names carry their unit, ``force [N]`` or ``force (N)``,
   or are followed by a units row (``time,force`` then ``s,N`` or ``(s),(N)``);
3. numeric data rows, blank trailing lines ignored.

The delimiter (``,``, ``;`` or tab) is detected from the header and the first
row after it; with ``;`` or tab a decimal comma (``1,25``) is accepted. The
encoding is UTF-8 (with or without BOM), else Latin-1. Names match
case-insensitively with spaces and ``_`` alike: ``"Tip Angle [deg]"`` becomes
the canonical ``tip_angle``. Known columns are converted to SI with
:func:`matid.units.si_factor`; other columns are kept as floats (in SI when pint
knows their unit) and ignored by the fits.

Every problem raises :class:`DataError` naming the file and the row (the
1-based line number an editor shows) and/or the column.
"""

from __future__ import annotations

import csv
import hashlib
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from matid.errors import DataError
from matid.study import Study, Test
from matid.units import DIMENSIONS, UnitError, si_factor

#: Known columns and the quantity kind of their unit.
KNOWN: dict[str, str] = {
    "time": "time",
    "force": "force",
    "elongation": "length",
    "strain": "strain",
    "tip_angle": "angle",
    "torque": "torque",
    "field": "field",
    "field_angle": "angle",
    "twist_angle": "angle",
    "deflection": "length",
}

#: Columns that may go without a unit: dimensionless by name.
DIMENSIONLESS_NAMES = frozenset({"cycle", "index", "step", "point"})

#: Per test kind, groups of alternatives: each group needs at least one of its
#: columns. "torque, or both field and field_angle" is written as the two groups
#: (torque, field) and (torque, field_angle).
REQUIRED: dict[str, list[tuple[str, ...]]] = {
    "extension": [("time",), ("force",), ("elongation", "strain")],
    "magnetic_bending": [("tip_angle",), ("torque", "field"), ("torque", "field_angle")],
    "torsion": [("twist_angle",), ("torque",)],
    "three_point_bend": [("deflection",), ("force",)],
}

MIN_ROWS = 3
_DELIMITERS = ("\t", ";", ",")
_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\[\]()]*)[\])]$")
_WRAPPED_UNIT = re.compile(r"^[\[(](?P<unit>.*)[\])]$")
_LINE_BREAK = re.compile(r"\r\n|\r|\n")


@dataclass(frozen=True, eq=False)
class Table:
    """The columns of one CSV file, in SI, keyed by canonical name."""

    path: Path
    columns: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    metadata: Mapping[str, str]
    sha256: str

    def __post_init__(self) -> None:
        lengths = {len(v) for v in self.columns.values()}
        if len(lengths) > 1:
            raise ValueError(f"{self.path}: columns of unequal length {sorted(lengths)}")
        columns = {}
        for name, values in self.columns.items():
            array = np.array(values, dtype=float)
            array.setflags(write=False)
            columns[name] = array
        object.__setattr__(self, "path", Path(self.path))
        object.__setattr__(self, "columns", MappingProxyType(columns))
        object.__setattr__(self, "units", MappingProxyType(dict(self.units)))
        object.__setattr__(self, "metadata", MappingProxyType(dict(self.metadata)))

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    @property
    def n_rows(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0


@dataclass(frozen=True)
class Measurement:
    """One test of a study with the table read from its file."""

    test: Test
    table: Table

    def in_window(self) -> np.ndarray:
        """Rows inside every range of the test's ``window`` (all rows when it has none).

        A window on a column the table lacks selects nothing; the study loader
        rejects such windows at input, so this does not happen for loaded studies.
        """
        n = len(next(iter(self.table.columns.values()), ()))
        mask = np.ones(n, dtype=bool)
        for name, (low, high) in self.test.window.items():
            values = self.table.columns.get(name)
            if values is None:
                return np.zeros(n, dtype=bool)
            mask &= (values >= low) & (values <= high)
        return mask


@dataclass(frozen=True)
class _Column:
    """One header column: name as written, canonical name, unit ('' if none).

    ``unit_row`` is the line the unit was read from (header or units row).
    """

    index: int
    written: str
    name: str
    unit: str
    unit_row: int


def canonical(name: str) -> str:
    """Canonical column name: lowercase, runs of spaces and ``_`` as one ``_``."""
    return re.sub(r"[\s_]+", "_", name.strip().lower()).strip("_")


def read_table(path: str | Path, kind: str) -> Table:
    """Read one CSV file of a test of ``kind`` into a :class:`Table` in SI."""
    if kind not in REQUIRED:
        raise ValueError(f"unknown test kind {kind!r} (one of {', '.join(REQUIRED)})")
    path = Path(path)
    raw = _read_bytes(path)
    lines = _lines(raw, path)
    metadata, header_at = _preamble(lines, path)
    delimiter = _detect_delimiter(lines, header_at)
    columns, data_at = _header(lines, header_at, delimiter, path)
    _check_required(columns, kind, path, row=header_at + 1)
    factors = [_factor(c, path) for c in columns]
    rows = _data_rows(lines, data_at, delimiter, len(columns), path)
    decimal_comma = delimiter != ","
    values = {
        c.name: _convert(c, f, rows, decimal_comma, path) for c, f in zip(columns, factors, strict=True)
    }
    values = {name: v for name, v in values.items() if v is not None}
    return Table(
        path=path,
        columns=values,
        units={c.name: c.unit for c in columns if c.name in values},
        metadata=metadata,
        sha256=hashlib.sha256(raw).hexdigest(),
    )


def load_measurements(study: Study) -> list[Measurement]:
    """Read the file of every test of ``study`` (excluded ones too), in study order."""
    measurements = []
    for test in study.tests:
        if not test.file.is_file():
            raise DataError(
                f"data file of [[test]] #{test.index + 1} ({test.kind}, specimen "
                f"{test.specimen}) not found; named in {study.source}",
                file=test.file,
            )
        measurements.append(Measurement(test=test, table=read_table(test.file, test.kind)))
    return measurements


def _read_bytes(path: Path) -> bytes:
    if not path.exists():
        raise DataError("file not found", file=path)
    if not path.is_file():
        raise DataError("not a file", file=path)
    try:
        return path.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read file: {exc.strerror}", file=path) from exc


def _lines(raw: bytes, path: Path) -> list[str]:
    """Decoded lines, trailing blank lines dropped; line i is row i + 1 in an editor."""
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    # Split on line breaks only: str.splitlines would also split on \x0c, \x85, ...
    # and shift the row numbers from what an editor shows.
    lines = _LINE_BREAK.split(text)
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise DataError("empty file", file=path)
    return lines


def _preamble(lines: list[str], path: Path) -> tuple[dict[str, str], int]:
    """Metadata from the leading ``# key: value`` lines; index of the header line."""
    metadata: dict[str, str] = {}
    for i, line in enumerate(lines):
        text = line.strip()
        if not text:
            continue
        if not text.startswith("#"):
            return metadata, i
        key, _, value = text.lstrip("#").partition(":")
        if key.strip():
            metadata[key.strip()] = value.strip()
    raise DataError("no header row (only '#' metadata lines)", file=path)


def _split(line: str, delimiter: str) -> list[str]:
    """Cells of one line, stripped; trailing empty cells (a trailing delimiter) dropped."""
    cells = [c.strip() for c in next(csv.reader([line], delimiter=delimiter), [])]
    while cells and not cells[-1]:
        cells.pop()
    return cells


def _detect_delimiter(lines: list[str], header_at: int) -> str:
    """The delimiter splitting the header into most cells, matched by one of the next two rows.

    Two rows, because the first may be a units row with trailing cells left empty.
    """
    header = lines[header_at]
    following = [ln for ln in lines[header_at + 1 : header_at + 3] if ln.strip()]
    best, best_cells = None, 1
    for delimiter in _DELIMITERS:
        n = len(_split(header, delimiter))
        if n > best_cells and any(len(_split(ln, delimiter)) == n for ln in following):
            best, best_cells = delimiter, n
    if best is not None:
        return best
    return max(_DELIMITERS, key=header.count) if any(d in header for d in _DELIMITERS) else ","


def _header(lines: list[str], header_at: int, delimiter: str, path: Path) -> tuple[list[_Column], int]:
    """Columns from the header row (and a units row if present); index of first data line."""
    cells = _split(lines[header_at], delimiter)
    if not cells:
        raise DataError("header row has no column names", file=path, row=header_at + 1)
    written = [_name_and_unit(c) for c in cells]
    units = [(unit, header_at + 1) for _, unit in written]
    data_at = header_at + 1
    if data_at < len(lines) and any(
        not unit and canonical(name) not in DIMENSIONLESS_NAMES for name, unit in written
    ):
        row_units = _units_row(lines[data_at], delimiter, len(cells), path, data_at + 1)
        if row_units is not None:
            data_at += 1
            units = [(r, data_at) if r else u for r, u in zip(row_units, units, strict=True)]
    columns = [
        _column(i, name, unit, path, row)
        for i, ((name, _), (unit, row)) in enumerate(zip(written, units, strict=True))
    ]
    _check_duplicates(columns, path, header_at + 1)
    return columns, data_at


def _name_and_unit(cell: str) -> tuple[str, str]:
    match = _NAME_UNIT.match(cell)
    if match is None:
        return cell, ""
    return match["name"].strip(), match["unit"].strip()


def _units_row(line: str, delimiter: str, n: int, path: Path, row: int) -> list[str] | None:
    """The units of a units row, or None when the line is data (all cells numeric)."""
    cells = _split(line, delimiter)
    if all(_is_number(c) for c in cells if c):
        return None
    if len(cells) > n:
        raise DataError(f"units row has {len(cells)} cells, header has {n}", file=path, row=row)
    cells += [""] * (n - len(cells))
    return [(m["unit"] if (m := _WRAPPED_UNIT.match(c)) else c).strip() for c in cells]


def _column(index: int, written: str, unit: str, path: Path, row: int) -> _Column:
    name = canonical(written)
    if not name:
        raise DataError(f"header column {index + 1} has no name", file=path, row=row)
    if not unit and name not in DIMENSIONLESS_NAMES:
        raise DataError(
            "column has no unit (write e.g. 'force [N]', or a units row under the header)",
            file=path,
            row=row,
            column=written,
        )
    return _Column(index=index, written=written, name=name, unit=unit, unit_row=row)


def _check_duplicates(columns: list[_Column], path: Path, row: int) -> None:
    seen: set[str] = set()
    for column in columns:
        if column.name in seen:
            raise DataError("column appears twice", file=path, row=row, column=column.written)
        seen.add(column.name)


def _check_required(columns: list[_Column], kind: str, path: Path, row: int) -> None:
    found = [c.name for c in columns]
    for group in REQUIRED[kind]:
        if not any(name in found for name in group):
            wanted = " or ".join(f"'{name}'" for name in group)
            raise DataError(
                f"{kind} file needs column {wanted}; found: {', '.join(found)}",
                file=path,
                row=row,
            )


def _data_rows(
    lines: list[str], data_at: int, delimiter: str, n: int, path: Path
) -> list[tuple[int, list[str]]]:
    """(row number, cells) of every data line; ragged and blank inner lines are errors.

    Trailing lines of delimiters only (``,,,`` as spreadsheets write) count as blank.
    """
    split = [_split(line, delimiter) for line in lines[data_at:]]
    while split and not split[-1]:
        split.pop()
    rows = []
    for i, cells in enumerate(split, start=data_at):
        if not cells:
            raise DataError("blank line inside the data", file=path, row=i + 1)
        if len(cells) != n:
            raise DataError(f"row has {len(cells)} cells, header has {n}", file=path, row=i + 1)
        rows.append((i + 1, cells))
    if len(rows) < MIN_ROWS:
        last = rows[-1][0] if rows else data_at
        raise DataError(f"only {len(rows)} data rows, need at least {MIN_ROWS}", file=path, row=last)
    return rows


def _factor(column: _Column, path: Path) -> float:
    """SI factor of a column: checked against its kind if known, else whatever pint makes of it."""
    if column.name not in KNOWN:
        return _any_si_factor(column.unit)
    try:
        return si_factor(column.unit, KNOWN[column.name])
    except UnitError as exc:
        raise DataError(str(exc), file=path, row=column.unit_row, column=column.written) from exc


def _convert(
    column: _Column,
    factor: float,
    rows: list[tuple[int, list[str]]],
    decimal_comma: bool,
    path: Path,
) -> np.ndarray | None:
    """The column in SI; None for an unknown column that is not all numbers."""
    if column.name not in KNOWN:
        return _convert_other(column, factor, rows, decimal_comma)
    values = np.empty(len(rows))
    for k, (line_no, cells) in enumerate(rows):
        values[k] = _cell(cells[column.index], decimal_comma, path, line_no, column.written)
    return values * factor


def _convert_other(
    column: _Column, factor: float, rows: list[tuple[int, list[str]]], decimal_comma: bool
) -> np.ndarray | None:
    """An unknown column: floats if every cell is a finite number, else None (dropped)."""
    try:
        values = [_number(cells[column.index], decimal_comma) for _, cells in rows]
    except ValueError:
        return None
    if not all(math.isfinite(v) for v in values):
        return None
    return np.asarray(values) * factor


def _any_si_factor(unit: str) -> float:
    """SI factor for a unit of any known kind; 1 (raw values) when none fits."""
    for kind in DIMENSIONS:
        if kind == "moment_per_length":
            continue
        try:
            return si_factor(unit, kind)
        except UnitError:
            continue
    return 1.0


def _number(text: str, decimal_comma: bool) -> float:
    """A float from a cell; ValueError if it is not a plain number."""
    if decimal_comma and text.count(",") == 1 and "." not in text:
        text = text.replace(",", ".")
    if not text or "_" in text:
        raise ValueError(text)
    return float(text)


def _is_number(text: str) -> bool:
    try:
        _number(text, decimal_comma=True)
    except ValueError:
        return False
    return True


def _cell(text: str, decimal_comma: bool, path: Path, row: int, column: str) -> float:
    if not text:
        raise DataError("empty cell", file=path, row=row, column=column)
    try:
        value = _number(text, decimal_comma)
    except ValueError:
        raise DataError(f"not a number: '{text}'", file=path, row=row, column=column) from None
    if not math.isfinite(value):
        raise DataError(f"NaN or infinite value '{text}'", file=path, row=row, column=column)
    return value
