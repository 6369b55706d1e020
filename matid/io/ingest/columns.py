"""The header of an export turned into matid columns (docs/contract.md sections 2 and 7).

A header cell is ``name [unit]`` or ``name (unit)``, or a name with its unit in
the units row below; the test's ``columns`` maps a matid name to the file's
header text, its ``units`` overrides a unit. The columns a test kind uses must
have a unit; the others never stop the run.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from pathlib import Path

from matid.errors import DataError
from matid.fits.kinds import BY_NAME, KINDS
from matid.io.ingest.detect import Layout, header_names, names
from matid.io.study_keys import bounded_text

#: Known columns (those of every test kind) and the quantity kind of their unit.
KNOWN: dict[str, str] = {name: q for kind in KINDS for name, q in kind.columns.items()}

_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\[\]()]*)[\])]$")
_WRAPPED_UNIT = re.compile(r"^[\[(](?P<unit>.*)[\])]$")


@dataclass(frozen=True)
class Column:
    """One header column: name as written, matid name, unit ('' if none).

    ``unit_row`` is the 1-based line the unit was read from (header, units row),
    0 when it came from the test's ``units``, None when the file has no header row.
    """

    index: int
    written: str
    name: str
    unit: str
    unit_row: int | None


def canonical(name: str) -> str:
    """Canonical column name: lowercase, runs of spaces and ``_`` as one ``_``."""
    return re.sub(r"[\s_]+", "_", name.strip().lower()).strip("_")


def header(
    lines: list[str],
    layout: Layout,
    kind: str,
    mapping: dict[str, str | int],
    overrides: dict[str, str],
    path: Path,
) -> list[Column]:
    """Columns from the header row (and units row), the test's ``columns`` and ``units`` applied;
    a file without a header row has nameless columns, named by position in ``columns``."""
    if layout.header_at is None:
        header_row, cells = None, [""] * layout.n_cells
    else:
        header_row = layout.header_at + 1
        cells = header_names(lines, layout.header_at, layout.units_at, layout.delimiter, layout.n_cells) or []
    written = [
        (m["name"].strip(), m["unit"].strip()) if (m := _NAME_UNIT.match(c)) else (c, "") for c in cells
    ]
    units = [(unit, header_row) for _, unit in written]
    if layout.units_at is not None:
        row_units = _units_row(lines[layout.units_at], layout)
        units = [(r, layout.units_at + 1) if r else u for r, u in zip(row_units, units, strict=True)]
    names_ = _matid_names(cells, written, mapping, path, header_row)
    columns = []
    for i, ((shown, _), (unit, row), name) in enumerate(zip(written, units, names_, strict=True)):
        if name in overrides:
            unit, row = overrides[name], 0
        shown = cells[i] if name in mapping and isinstance(mapping[name], str) else shown or f"column {i + 1}"
        columns.append(_column(i, shown, name, unit, row, kind, path))
    # columns no test uses may share a name ('Total Cycle Count(Linear Waveform)' and '...(Rotary
    # Waveform)', the brackets read as units): each keeps its own under its position
    names_ = [c.name for c in columns]
    columns = [
        Column(c.index, c.written, f"{c.name}_col{c.index + 1}", c.unit, c.unit_row)
        if names_.count(c.name) > 1 and c.name not in BY_NAME[kind].columns
        else c
        for c in columns
    ]
    _check_duplicates(columns, path, header_row)
    return columns


def _matid_names(
    cells: list[str],
    written: list[tuple[str, str]],
    mapping: dict[str, str | int],
    path: Path,
    row: int | None,
) -> list[str]:
    """matid name of each cell: the mapped one (by header text or column number), else its
    canonical name (renamed on collision)."""
    result = [canonical(name) or f"column_{i + 1}" for i, (name, _) in enumerate(written)]
    for name, header in mapping.items():
        hit = _mapped_column(name, header, cells, written, path, row)
        for i, current in enumerate(result):
            if current == name and i != hit:
                result[i] = f"{current}_col{i + 1}"  # the file's own 'force' when 'Load' is mapped to force
        result[hit] = name
    return result


def _mapped_column(
    name: str,
    header: str | int,
    cells: list[str],
    written: list[tuple[str, str]],
    path: Path,
    row: int | None,
) -> int:
    """The index of the one column ``columns.<name> = header`` names (by header text or column
    number, 1 = the first); a DataError when it names none or several."""
    if isinstance(header, int):
        if header > len(cells):
            raise DataError(
                f"columns.{name} = {header}: the file has {len(cells)} columns",
                file=path,
                row=row,
            )
        return header - 1
    want = header.strip().casefold()
    hits = [
        i
        for i, (cell, (shown, _)) in enumerate(zip(cells, written, strict=True))
        if want in (cell.strip().casefold(), shown.strip().casefold())
    ]
    if len(hits) > 1:  # side-by-side records repeat their names: one must be chosen
        numbers = ", ".join(str(i + 1) for i in hits)
        raise DataError(
            f"columns.{name} = '{bounded_text(header, 80)}' names {len(hits)} columns (numbers "
            f"{bounded_text(numbers, 80)}): name one by its number, e.g. "
            f"columns = {{ {name} = {hits[0] + 1} }}",
            file=path,
            row=row,
            column=bounded_text(header, 80),
        )
    if not hits:
        close = difflib.get_close_matches(header.strip(), cells, n=1, cutoff=0.5)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        raise DataError(
            f"columns.{name} = '{bounded_text(header, 80)}' is not a column of the file; header row has: "
            f"{bounded_text(', '.join(cells), 300)}{hint}",
            file=path,
            row=row,
            column=bounded_text(header, 80),
        )
    return hits[0]


def _units_row(line: str, layout: Layout) -> list[str]:
    """The units of the units row, padded to the header's cell count."""
    cells = names(line, layout.delimiter, layout.n_cells) or []
    cells += [""] * (layout.n_cells - len(cells))
    return [(m["unit"] if (m := _WRAPPED_UNIT.match(c)) else c).strip() for c in cells]


def _column(index: int, written: str, name: str, unit: str, row: int | None, kind: str, path: Path) -> Column:
    written = bounded_text(written, 200)
    if name in BY_NAME[kind].columns and not unit:
        raise DataError(
            f"column has no unit (write e.g. '{name} [unit]' in the header, a units row under it, "
            f'or units = {{ {name} = "..." }} in the [[test]])',
            file=path,
            row=row,
            column=written,
        )
    return Column(index=index, written=written, name=name, unit=unit, unit_row=row)


def _check_duplicates(columns: list[Column], path: Path, row: int | None) -> None:
    seen: set[str] = set()
    for column in columns:
        if column.name in seen:
            raise DataError(
                "column appears twice (name one with columns = { ... } in the [[test]])",
                file=path,
                row=row,
                column=column.written,
            )
        seen.add(column.name)


def check_required(columns: list[Column], kind: str, path: Path, row: int | None) -> None:
    found = [c.name for c in columns]
    for group in BY_NAME[kind].required:
        if not any(name in found for name in group):
            wanted = " or ".join(f"'{name}'" for name in group)
            shown = bounded_text(", ".join(c.written for c in columns), 300)
            raise DataError(
                f"{kind} file needs column {wanted}; found: {shown} (if one of these is it, say so with "
                f'columns = {{ {group[0]} = "<header text>" }} in the [[test]])',
                file=path,
                row=row,
            )
