"""CSV ingest: test-machine exports turned into named columns in SI.

Implements docs/contract.md sections 2 and 7. :mod:`matid.io.ingest.detect` finds
the layout (encoding, delimiter, preamble, header, optional units row); here the
header cells become columns: ``force [N]``, ``force (N)`` or a units row give
the unit, the test's ``columns`` maps its own names to the file's header text
and ``units`` overrides a unit. Names match case-insensitively with spaces and
``_`` alike (``"Tip Angle [deg]"`` is ``tip_angle``). The columns the test kind
uses (:data:`matid.io.study.TEST_COLUMNS`) must have a known unit and numbers in
every row; other columns are kept as floats (in SI when pint knows their unit)
and never stop the run. ``negate`` flips signs, then
:mod:`matid.io.ingest.checks` rejects values beyond physical bounds and data of
the wrong sign.

Every problem raises :class:`DataError` naming the file and the row (the
1-based line number an editor shows) and/or the column, and how the file was
read (encoding, delimiter, header row).
"""

from __future__ import annotations

import csv
import hashlib
import math
import os
import stat
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from matid.errors import DataError
from matid.io.ingest import checks as ingest_checks
from matid.io.ingest.columns import (  # noqa: F401 - KNOWN, REQUIRED, canonical re-exported
    DIMENSIONLESS_NAMES,
    KNOWN,
    REQUIRED,
    Column,
    canonical,
    check_required,
    header,
)
from matid.io.ingest.detect import Layout, decode, detect, lines_of, number, preamble, split
from matid.io.limits import MAX_CSV_BYTES, MAX_CSV_ROWS
from matid.io.study import TEST_COLUMNS, Study, Test, bounded_text
from matid.io.views import PicklesViews
from matid.units import DIMENSIONS, UnitError, si_factor

MIN_ROWS = 3
#: Largest file read, most lines (docs/limits.md): checked on the bytes, before anything is parsed.
MAX_BYTES, MAX_ROWS = MAX_CSV_BYTES, MAX_CSV_ROWS


@dataclass(frozen=True, eq=False)
class Table(PicklesViews):
    """The columns of one CSV file, in SI, keyed by canonical name."""

    path: Path
    columns: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    metadata: Mapping[str, str]
    sha256: str
    #: How the file was read, for messages and the report.
    encoding: str = "utf-8"
    delimiter: str = ","
    header_row: int = 1
    #: Preamble lines that are not ``key: value`` metadata, bounded.
    preamble: tuple[str, ...] = ()
    #: The file's header text of each column, for messages.
    written: Mapping[str, str] = field(default_factory=dict)

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
        object.__setattr__(self, "written", MappingProxyType(dict(self.written)))
        object.__setattr__(self, "preamble", tuple(self.preamble))

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


def read_table(
    path: str | Path,
    kind: str,
    *,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    negate: tuple[str, ...] | list[str] = (),
    encoding: str | None = None,
) -> Table:
    """Read one export of a test of ``kind`` into a :class:`Table` in SI.

    ``columns``, ``units``, ``negate`` and ``encoding`` are the test's keys of
    docs/contract.md section 7.
    """
    if kind not in REQUIRED:
        raise ValueError(f"unknown test kind {kind!r} (one of {', '.join(REQUIRED)})")
    path = Path(path)
    raw = _read_bytes(path)
    text, used = decode(raw, path, encoding)
    lines = lines_of(text)
    if not lines:
        raise DataError("empty file", file=path)
    if all(not ln.strip() or ln.lstrip().startswith("#") for ln in lines):
        raise DataError("no header row (only '#' metadata lines)", file=path)
    layout = detect(lines, path, used)
    try:
        return _table(path, raw, lines, layout, kind, dict(columns or {}), dict(units or {}), tuple(negate))
    except DataError as exc:
        raise DataError(
            f"{exc.detail} ({layout.describe()})", file=path, row=exc.row, column=exc.column
        ) from exc


def _table(
    path: Path,
    raw: bytes,
    lines: list[str],
    layout: Layout,
    kind: str,
    mapping: dict[str, str],
    overrides: dict[str, str],
    negate: tuple[str, ...],
) -> Table:
    metadata, text = preamble(lines, layout)
    if text:
        metadata.setdefault("preamble", bounded_text(" / ".join(text)))
    cols = header(lines, layout, kind, mapping, overrides, path)
    check_required(cols, kind, path, row=layout.header_at + 1)
    used = TEST_COLUMNS[kind]
    rows = _data_rows(lines, layout, path)
    values: dict[str, np.ndarray] = {}
    for c in cols:
        v = _convert(c, used, rows, layout.decimal_comma, path)
        if v is not None:
            values[c.name] = -v if c.name in negate else v
    written = {c.name: c.written for c in cols if c.name in values}
    ingest_checks.check(values, kind, [r for r, _ in rows], written, path, negate)
    return Table(
        path=path,
        columns=values,
        units={c.name: c.unit for c in cols if c.name in values},
        metadata=metadata,
        sha256=hashlib.sha256(raw).hexdigest(),
        encoding=layout.encoding,
        delimiter=layout.delimiter,
        header_row=layout.header_at + 1,
        preamble=text,
        written=written,
    )


def load_measurements(study: Study) -> list[Measurement]:
    """Read the file of every test of ``study`` (excluded ones too), in study order."""
    measurements = []
    for test in study.tests:
        if not os.path.lexists(test.file):
            raise DataError(
                f"data file of [[test]] #{test.index + 1} ({test.kind}, specimen "
                f"{test.specimen}) not found; named in {study.source}",
                file=test.file,
            )
        table = read_table(
            test.file,
            test.kind,
            columns=test.columns,
            units=test.units,
            negate=test.negate,
            encoding=test.encoding,
        )
        measurements.append(Measurement(test=test, table=table))
    return measurements


def _read_bytes(path: Path) -> bytes:
    """The bytes of a regular file of at most :data:`MAX_BYTES`."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise DataError("file not found", file=path) from None
    except (OSError, RuntimeError) as exc:
        # ELOOP: a symlink to itself; ENAMETOOLONG, EACCES, ...
        raise DataError(f"cannot open file: {getattr(exc, 'strerror', None) or exc}", file=path) from None
    if stat.S_ISDIR(info.st_mode):
        raise DataError("is a folder, not a data file", file=path)
    if not stat.S_ISREG(info.st_mode):
        raise DataError("not a regular file (a device, pipe or socket); name the data file itself", file=path)
    if info.st_size > MAX_BYTES:
        raise DataError(
            f"file is {info.st_size / 2**20:.0f} MiB, larger than the {MAX_BYTES // 2**20} MiB "
            "matid reads; export only the test's rows",
            file=path,
        )
    try:
        with open(path, "rb") as handle:
            raw = handle.read(MAX_BYTES + 1)
    except OSError as exc:
        raise DataError(f"cannot read file: {exc.strerror}", file=path) from exc
    if len(raw) > MAX_BYTES:
        raise DataError(f"file grew beyond {MAX_BYTES // 2**20} MiB while being read", file=path)
    lines = max(raw.count(b"\n"), raw.count(b"\r"))  # line breaks: LF, CRLF or CR alone (UTF-16 too)
    if lines > MAX_ROWS:
        raise DataError(f"file has {lines} lines, more than MAX_CSV_ROWS = {MAX_ROWS} matid reads", file=path)
    return raw


def _data_rows(lines: list[str], layout: Layout, path: Path) -> list[tuple[int, list]]:
    """(row number, cells) of every data line; blank lines (and lines of delimiters) skipped."""
    rows = []
    n = layout.n_cells
    for i in range(layout.data_at, len(lines)):
        try:
            cells = split(lines[i], layout.delimiter)
        except csv.Error:
            raise DataError(
                f"a cell is longer than {csv.field_size_limit()} characters", file=path, row=i + 1
            ) from None
        if not cells:
            continue
        if len(cells) > n:
            raise DataError(f"row has {len(cells)} cells, header has {n}", file=path, row=i + 1)
        # Short rows (empty trailing cells) are padded with None: an error only where a used column lacks it.
        rows.append((i + 1, cells + [None] * (n - len(cells))))
    if len(rows) < MIN_ROWS:
        last = rows[-1][0] if rows else layout.data_at + 1
        raise DataError(f"only {len(rows)} data rows, need at least {MIN_ROWS}", file=path, row=last)
    return rows


def _convert(
    column: Column,
    used: Mapping[str, str],
    rows: list[tuple[int, list[str]]],
    decimal_comma: bool,
    path: Path,
) -> np.ndarray | None:
    """The column in SI; None for a column the test does not use that is not all numbers."""
    if column.name not in used:
        return _convert_other(column, rows, decimal_comma)
    try:
        factor = si_factor(column.unit, used[column.name])
    except UnitError as exc:
        source = "in the [[test]]'s units" if column.unit_row == 0 else None
        raise DataError(
            f"{exc}{' (' + source + ')' if source else ''}",
            file=path,
            row=column.unit_row or None,
            column=column.written,
        ) from exc
    values = np.empty(len(rows))
    for k, (line_no, cells) in enumerate(rows):
        if cells[column.index] is None:
            n = sum(c is not None for c in cells)
            raise DataError(f"row has {n} cells, header has {len(cells)}", file=path, row=line_no)
        values[k] = _cell(cells[column.index], decimal_comma, path, line_no, column.written)
    return values * factor


def _convert_other(
    column: Column, rows: list[tuple[int, list[str]]], decimal_comma: bool
) -> np.ndarray | None:
    """A column the test does not use: floats if every cell is a finite number, else None (dropped)."""
    try:
        values = [number(cells[column.index] or "", decimal_comma) for _, cells in rows]
    except ValueError:
        return None
    if not all(math.isfinite(v) for v in values):
        return None
    return np.asarray(values) * _soft_factor(column)


def _soft_factor(column: Column) -> float:
    """SI factor of an unused column's unit when it is known; 1 (raw values) when not."""
    kinds = (
        [KNOWN[column.name]] if column.name in KNOWN else [k for k in DIMENSIONS if k != "moment_per_length"]
    )
    for kind in kinds:
        try:
            return si_factor(column.unit, kind)
        except UnitError:
            continue
    return 1.0


def _cell(text: str, decimal_comma: bool, path: Path, row: int, column: str) -> float:
    if not text:
        raise DataError("empty cell", file=path, row=row, column=column)
    try:
        value = number(text, decimal_comma)
    except ValueError:
        raise DataError(
            f"not a number: '{bounded_text(text, 80)}'", file=path, row=row, column=column
        ) from None
    if not math.isfinite(value):
        raise DataError(f"NaN or infinite value '{text}'", file=path, row=row, column=column)
    return value
