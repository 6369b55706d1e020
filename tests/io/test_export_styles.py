"""Styles real exports and hand-edited files have (the CSV fuzz's export kinds, tests/fuzzkit.py).

Each either reads to the numbers the file means or is a DataError naming the file, the row
and the column, with a message saying what to change; none becomes a silent wrong number:
a row left out, or a cell read one of two ways it could mean.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from matid.errors import DataError
from matid.io.ingest.read import read_table
from tests.io.test_ingest import where, write

HEADER = "twist_angle [rad],torque [N m]"
ROWS = [f"{0.05 * i:.2f},{0.125 * i + 0.5:.3f}" for i in range(12)]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(at=st.integers(0, len(ROWS)), preamble=st.booleans())
def test_a_header_repeated_among_the_rows_never_drops_rows_silently(tmp_path, at, preamble):
    """A second export appended (its '# ...' preamble and header) or a header row pasted in among
    the rows: the header search took the second header when the rows after the first did not look
    like data, and the rows above it became preamble, dropped without a word (found by the CSV
    fuzz's 'rehead' kind). Now: every row read, or an error at a row of the file."""
    block = ["# machine: rig 2", "# operator: B", HEADER] if preamble else [HEADER]
    lines = ["# machine: rig 1", HEADER, *ROWS[:at], *block, *ROWS[at:]]
    path = write(tmp_path, "\n".join(lines) + "\n")
    try:
        table = read_table(path, "torsion")
    except DataError as exc:
        assert exc.row is not None and 1 <= exc.row <= len(lines), str(exc)
    else:
        assert len(table["twist_angle"]) == len(ROWS)


def test_rows_of_numbers_above_the_header_name_the_first(tmp_path):
    lines = ["# machine: rig 1", HEADER, ROWS[0], "# operator: B", "# date: today", HEADER, *ROWS[1:]]
    path = write(tmp_path, "\n".join(lines) + "\n")
    with pytest.raises(DataError, match=where(path, row=3) + "row of numbers above the header row 6"):
        read_table(path, "torsion")


def _semicolon_file(tmp_path, cell: str):
    rows = [row.replace(",", ";") for row in ROWS]
    rows[5] = cell + ";" + rows[5].split(";")[1]
    return write(tmp_path, HEADER.replace(",", ";") + "\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize("cell", ["1,012", "-2,500", "1.012"])
def test_a_cell_with_two_readings_in_a_column_of_mixed_decimal_marks_is_an_error(tmp_path, cell):
    """In a ';' file whose column has '.' decimals, "1,012" was read as 1.012 (the comma taken for a
    decimal mark) though it may be 1012 with a thousands separator: a confident wrong number."""
    path = _semicolon_file(tmp_path, cell)
    if "." in cell:  # the other way round: a ',' column with one '.' cell
        text = path.read_text().replace(".", ",").replace("1,012;", "1.012;")
        path.write_text(text)
    one, other = cell.replace(",", "."), cell.replace(",", "").replace(".", "")
    two = re.escape(f"'{cell}' reads as {one} (a decimal mark) or {other} (a thousands separator)")
    with pytest.raises(DataError, match=where(path, row=7, column="twist_angle") + two):
        read_table(path, "torsion")


def test_a_decimal_comma_cell_that_reads_one_way_still_reads(tmp_path):
    table = read_table(_semicolon_file(tmp_path, "1,5"), "torsion")
    assert table["twist_angle"][5] == 1.5


@pytest.mark.parametrize(
    ("cell", "hint"),
    [
        ("\u22120.25", "(the minus sign '\u2212' (U+2212) is not read: write '-')"),
        ("2.5D-01", "(a Fortran exponent (D or Q) is not read: write E)"),
        ("#DIV/0!", "(a spreadsheet error cell)"),
        ("#N/A", "(a spreadsheet error cell)"),
        ("\u0660.\u0662\u0665", "(only the digits 0-9 are read)"),
        ("\uff10.\uff12\uff15", "(only the digits 0-9 are read)"),
    ],
)
def test_a_number_style_matid_does_not_read_says_what_to_write(tmp_path, cell, hint):
    """Python's float() reads Arabic-Indic and full-width digits, pandas does not: such a cell was
    reported as 'NaN or infinite value'. The other styles said only 'not a number'."""
    rows = list(ROWS)
    rows[3] = cell + "," + rows[3].split(",")[1]
    path = write(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n")
    message = re.escape(f"not a number: '{cell}' {hint}")
    with pytest.raises(DataError, match=where(path, row=5, column="twist_angle") + message):
        read_table(path, "torsion")


def test_mixed_line_endings_read_every_row(tmp_path):
    """Lone CR and CRLF on part of the file (a second tool appended rows) are line breaks."""
    text = HEADER + "\n" + "\r".join(ROWS[:4]) + "\r\n" + "\r\n".join(ROWS[4:8]) + "\n" + "\n".join(ROWS[8:])
    table = read_table(write(tmp_path, text + "\n"), "torsion")
    want = np.array([float(r.split(",")[0]) for r in ROWS])
    np.testing.assert_array_equal(table["twist_angle"], want)
