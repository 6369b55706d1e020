"""CSV ingest: test-machine exports turned into named columns in SI (docs/contract.md sections 2, 7).

:mod:`~matid.io.ingest.detect` finds the layout (encoding, delimiter, preamble, header,
units row), :mod:`~matid.io.ingest.columns` names the columns and their units,
:mod:`~matid.io.ingest.frame` parses the numbers, ``negate`` flips signs and
:mod:`~matid.io.ingest.checks` rejects values beyond physical bounds or of the wrong sign.
The columns the test kind uses (its :attr:`~matid.model.kind.Kind.columns`) must have a known unit
and numbers in every row; other columns are kept as floats (in SI when pint knows their
unit) and never stop the run.

Every problem raises :class:`DataError` naming the file and the row (the 1-based line an
editor shows) and/or the column, and how the file was read (encoding, delimiter, header row).
"""

from __future__ import annotations

import hashlib
import os
import stat
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from matid.errors import DataError
from matid.fits.kinds import BY_NAME
from matid.io.ingest import checks as ingest_checks
from matid.io.ingest.columns import KNOWN, Column, check_required, header
from matid.io.ingest.detect import HEAD_LINES, Layout, decode, detect, lines_of, preamble
from matid.io.ingest.frame import Rows, Start, locate, read_rows, without_trailing
from matid.io.ingest.frame import column as frame_column
from matid.io.study_keys import bounded_text
from matid.limits import MAX_CSV_BYTES, MAX_CSV_ROWS
from matid.model.measurement import Measurement, Table
from matid.model.study import Study, Test
from matid.units import DIMENSIONS, UnitError, si_factor

MIN_ROWS = 3
#: Largest file read, most lines (docs/limits.md): checked on the bytes, before anything is parsed.
MAX_BYTES, MAX_ROWS = MAX_CSV_BYTES, MAX_CSV_ROWS
#: The first bytes of binary workbooks, which matid does not read: a zip archive (.xlsx, .ods)
#: and an OLE2 compound file (.xls).
WORKBOOKS = (
    (b"PK\x03\x04", "a zip archive such as an .xlsx or .ods workbook"),
    (b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1", "an .xls workbook"),
)


def read_table(
    path: str | Path,
    kind: str,
    *,
    columns: Mapping[str, str | int] | None = None,
    units: Mapping[str, str] | None = None,
    negate: tuple[str, ...] | list[str] = (),
    encoding: str | None = None,
) -> Table:
    """Read one export of a test of ``kind`` into a :class:`Table` in SI.

    ``columns``, ``units``, ``negate`` and ``encoding`` are the test's keys of
    docs/contract.md section 7; a column named by number (``columns = { force = 3 }``) lets a
    file without a header row be read.
    """
    if kind not in BY_NAME:
        raise ValueError(f"unknown test kind {kind!r} (one of {', '.join(BY_NAME)})")
    path = Path(path)
    raw = _read_bytes(path)
    for magic, what in WORKBOOKS:
        if raw.startswith(magic):
            raise DataError(
                f"is {what}, not a text table: save the sheet as CSV (a header row of column names "
                "with units, then a row per sample) and name that file",
                file=path,
            )
    text, used = decode(raw, path, encoding)
    lines = lines_of(text, HEAD_LINES)
    if not lines:
        raise DataError("empty file", file=path)
    if all(not ln.strip() or ln.lstrip().startswith("#") for ln in lines):
        raise DataError("no header row (only '#' metadata lines)", file=path)
    positions = any(isinstance(v, int) for v in (columns or {}).values())
    layout = detect(lines, path, used, positions=positions)
    start = locate(raw, text, layout)
    del text  # a long record's numbers are parsed from raw; its text is not kept
    try:
        return _table(
            path, raw, start, lines, layout, kind, dict(columns or {}), dict(units or {}), tuple(negate)
        )
    except DataError as exc:
        raise DataError(
            f"{exc.detail} ({layout.describe()})", file=path, row=exc.row, column=exc.column
        ) from exc


def _table(
    path: Path,
    raw: bytes,
    start: Start,
    lines: list[str],
    layout: Layout,
    kind: str,
    mapping: dict[str, str | int],
    overrides: dict[str, str],
    negate: tuple[str, ...],
) -> Table:
    metadata, text = preamble(lines, layout)
    if text:
        metadata.setdefault("preamble", bounded_text(" / ".join(text)))
    cols = header(lines, layout, kind, mapping, overrides, path)
    header_row = None if layout.header_at is None else layout.header_at + 1
    check_required(cols, kind, path, row=header_row)
    used = BY_NAME[kind].columns
    rows = without_trailing(read_rows(raw, start, layout, path), [c.index for c in cols if c.name in used])
    if len(rows.lines) < MIN_ROWS:
        last = int(rows.lines[-1]) if len(rows.lines) else layout.data_at + 1
        raise DataError(f"only {len(rows.lines)} data rows, need at least {MIN_ROWS}", file=path, row=last)
    values: dict[str, np.ndarray] = {}
    for c in cols:
        v = _convert(c, used, rows, path)
        if v is not None:
            values[c.name] = -v if c.name in negate else v
    written = {c.name: c.written for c in cols if c.name in values}
    ingest_checks.check(values, kind, rows.lines, written, path, negate)
    return Table(
        path=path,
        columns=values,
        units={c.name: c.unit for c in cols if c.name in values},
        metadata=metadata,
        sha256=hashlib.sha256(raw).hexdigest(),
        encoding=layout.encoding,
        delimiter=layout.delimiter,
        header_row=header_row or 0,
        preamble=text,
        written=written,
        lines=_lines(rows.lines),
    )


def _lines(lines) -> range | np.ndarray:
    """The file line of each row, as a ``range`` when they follow each other (a long record then keeps
    no array of them)."""
    if len(lines) and int(lines[-1]) - int(lines[0]) == len(lines) - 1:
        return range(int(lines[0]), int(lines[-1]) + 1)
    out = np.asarray(lines, dtype=np.int64)
    out.setflags(write=False)
    return out


def load_measurements(study: Study) -> list[Measurement]:
    """Read the file of every test of ``study`` (excluded ones too), in study order."""
    measurements: list[Measurement] = []
    seen: dict[str, Test] = {}  # sha256 -> the first test that read it
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
        first = seen.setdefault(table.sha256, test)
        if first is not test and not (first.exclude or test.exclude):
            # the same rows twice would double n_points and shrink the interval by sqrt(2)
            one = Path(first.file).resolve() == Path(test.file).resolve()
            same = "the same file" if one else "the same contents"
            raise DataError(
                f"[[test]] #{first.index + 1} and #{test.index + 1} ({test.kind}) name {same} "
                f"(sha256 {table.sha256[:12]}...; first: {first.file}): a record counts once; "
                "remove one, or exclude = true on it",
                file=test.file,
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


def _convert(column: Column, used: Mapping[str, str], rows: Rows, path: Path) -> np.ndarray | None:
    """The column in SI; None for a column the test does not use that is not all finite numbers."""
    if column.name not in used:
        values = frame_column(rows, column.index, column.written, required=False)
        return None if values is None else values * _soft_factor(column)
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
    return frame_column(rows, column.index, column.written, required=True) * factor


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
