"""``stiffness.xlsx`` and ``summary.xlsx``: the stiffness tables as spreadsheets (docs/contract.md 7, 8).

Sheets of ``stiffness.xlsx``: ``stiffness`` (the rows of ``stiffness.csv``, numbers
as numbers, the status of each value last: contract section 10), ``warnings``
(specimen, what it concerns, the warning) and ``inputs`` (file, sha256, rows used,
rows read); text is written as text, never as a formula (:mod:`matid.io.cells`).
openpyxl is imported only when a workbook is
written, so ``import matid`` stays light.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence

from matid.io.cells import cell
from matid.io.results import CSV_COLUMNS, rows_used, table_rows

#: A sheet: its column names and its rows (dicts keyed by those names).
from matid.model.results import StudyResult

Sheet = tuple[Sequence[str], Sequence[Mapping[str, object]]]

WARNING_COLUMNS = ["specimen", "concerns", "warning"]
INPUT_COLUMNS = ["file", "sha256", "rows_used", "rows_read"]


def stiffness_xlsx(result: StudyResult, units: str = "SI") -> bytes:
    """The ``stiffness.xlsx`` workbook (sheets ``stiffness``, ``warnings``, ``inputs``) as bytes;
    an input's ``rows_used`` is None where the fits do not tell (:func:`matid.io.results.rows_used`)."""
    used = rows_used(result)
    inputs = [(f.path.name, f.sha256, used.get(f.path), f.n_rows) for f in result.inputs]
    warnings = result.warning_list("could not be fitted: ")
    return workbook(
        {
            "stiffness": (CSV_COLUMNS, table_rows(result, units)),
            "warnings": (WARNING_COLUMNS, [dict(zip(WARNING_COLUMNS, w, strict=True)) for w in warnings]),
            "inputs": (INPUT_COLUMNS, [dict(zip(INPUT_COLUMNS, f, strict=True)) for f in inputs]),
        }
    )


def workbook(sheets: Mapping[str, Sheet]) -> bytes:
    """An .xlsx file with one sheet per entry: a bold, frozen header row, then the rows."""
    from openpyxl import Workbook
    from openpyxl.styles import Font
    from openpyxl.utils import get_column_letter

    book = Workbook()
    book.remove(book.active)
    for name, (columns, rows) in sheets.items():
        sheet = book.create_sheet(name)
        _append(sheet, list(columns))
        for header in sheet[1]:
            header.font = Font(bold=True)
        for row in rows:
            _append(sheet, [row.get(c) for c in columns])
        sheet.freeze_panes = "A2"
        for i, column in enumerate(columns, start=1):
            width = max([len(str(column))] + [len(str(r.get(column) or "")) for r in rows])
            sheet.column_dimensions[get_column_letter(i)].width = min(width + 2, 80)
    buffer = io.BytesIO()
    book.save(buffer)
    return buffer.getvalue()


def _append(sheet, values: list[object]) -> None:
    """One row: numbers as numbers, text as text (never a formula, an error code or a control character)."""
    sheet.append([cell(v) for v in values])
    for written in sheet[sheet.max_row]:
        if isinstance(written.value, str):
            written.data_type = "s"  # openpyxl would type "#N/A" as an error; "=..." is prefixed already
