"""Readers on two layouts public lab records have (issue 28, benchmarks/real_records.md).

- An Instron Bluehill CSV export as written: a results table above the data, and the column
  row starts with the specimen number (``1,Time,Displacement,...``) over a units row whose
  first cell is empty. The column row is the header, not the units row under it.
- A DAQ file with no header row at all: the study names its columns by position
  (``columns = { force = 3 }``, 1 = the first column) and gives their units.
- Thousands grouped with the other decimal mark (Bluehill's ``"1,006.28992"``) read as one number.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.errors import DataError
from matid.io.ingest.read import read_table

#: strain and force of a linear coupon: force = 4.0e6 N x strain + 0.005 kN preload
STRAIN = np.linspace(0.0, 2e-3, 30)
FORCE_KN = 4.0e3 * STRAIN + 0.005


def _bluehill(path: Path) -> Path:
    """The shape of an Instron Bluehill export (results row, then a column row led by the
    specimen number, a units row, quoted cells with an empty first one), made up here."""
    lines = [
        "Results Table 1",
        ",Sample,E-modulus,Maximum Tensile stress",
        ",,(GPa),(MPa)",
        '1,"AM-go 1055","110.351","939.877"',
        "1,Time,Displacement,Force,Tensile strain (Strain 2),Tensile stress",
        ",(s),(mm),(kN),(mm/mm),(MPa)",
    ]
    lines += [
        f'"","{0.1 * i:.4f}","{0.05 * i:.5f}","{f:.5f}","{e:.6f}","{f / 23.76e-3:.5f}"'
        for i, (e, f) in enumerate(zip(STRAIN, FORCE_KN, strict=True))
    ]
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("latin-1"))
    return path


def test_a_bluehill_column_row_led_by_the_specimen_number_is_the_header(tmp_path):
    path = _bluehill(tmp_path / "am.csv")
    table = read_table(
        path,
        "extension",
        columns={"time": "Time", "strain": "Tensile strain (Strain 2)", "force": "Force"},
    )
    assert table.header_row == 5
    assert table.n_rows == len(STRAIN)
    np.testing.assert_allclose(table["force"], np.round(FORCE_KN, 5) * 1e3)
    np.testing.assert_allclose(table["strain"], np.round(STRAIN, 6))
    np.testing.assert_allclose(table["time"][-1], 0.1 * (len(STRAIN) - 1))


def test_a_number_alone_is_not_a_header_cell_where_the_rest_are_numbers_too(tmp_path):
    """The specimen number is allowed at the start of a row of names only: a row of numbers above
    the header is still refused as data the preamble would swallow."""
    path = tmp_path / "pasted.csv"
    path.write_text("1,2,3\ntime [s],force [N],strain [1]\n0,0,0\n1,1,0.1\n2,2,0.2\n", encoding="utf-8")
    with pytest.raises(DataError, match="row of numbers above the header"):
        read_table(path, "extension")


def _headerless(path: Path) -> Path:
    """A DAQ file with no header row: time [s], displacement [mm], force [kN], strain [µε]."""
    rows = [
        f"{0.1 * i:.4f}\t{0.02 * i:.5f}\t{f:.6f}\t{1e6 * e:.3f}"
        for i, (e, f) in enumerate(zip(STRAIN, FORCE_KN, strict=True))
    ]
    path.write_text("\r\n".join(rows) + "\r\n", encoding="utf-8")
    return path


POSITIONS = {"time": 1, "force": 3, "strain": 4}
POSITION_UNITS = {"time": "s", "force": "kN", "strain": "µm/m"}


def test_a_file_without_a_header_row_is_read_with_columns_named_by_position(tmp_path):
    table = read_table(
        _headerless(tmp_path / "daq.dat"), "extension", columns=POSITIONS, units=POSITION_UNITS
    )
    assert table.n_rows == len(STRAIN)
    assert table.header_row == 0
    np.testing.assert_allclose(table["force"], np.round(FORCE_KN, 6) * 1e3)
    np.testing.assert_allclose(table["strain"], np.round(1e6 * STRAIN, 3) * 1e-6)
    np.testing.assert_allclose(table["time"], 0.1 * np.arange(len(STRAIN)))


def test_a_file_without_a_header_row_needs_the_units_of_the_columns_it_names(tmp_path):
    with pytest.raises(DataError, match="column has no unit"):
        read_table(_headerless(tmp_path / "daq.dat"), "extension", columns=POSITIONS)


def test_a_file_without_a_header_row_and_no_positions_says_how_to_name_them(tmp_path):
    with pytest.raises(DataError, match=r"no header row found.*columns = \{ force = 3 \}"):
        read_table(_headerless(tmp_path / "daq.dat"), "extension")


def test_a_position_beyond_the_last_column_is_refused_with_the_count(tmp_path):
    with pytest.raises(DataError, match="columns.force = 7: the file has 4 columns"):
        read_table(
            _headerless(tmp_path / "daq.dat"),
            "extension",
            columns={**POSITIONS, "force": 7},
            units=POSITION_UNITS,
        )


def test_a_position_names_a_column_of_a_file_with_a_header_too(tmp_path):
    """Two columns of one name (a force channel twice) cannot be told apart by text: by position."""
    path = tmp_path / "twice.csv"
    pairs = enumerate(zip(STRAIN, FORCE_KN, strict=True))
    rows = "".join(f"{0.1 * i},{f * 1e3},{2 * f * 1e3},{e}\n" for i, (e, f) in pairs)
    path.write_text("time [s],Force [N],Force [N],strain [1]\n" + rows, encoding="utf-8")
    table = read_table(path, "extension", columns={"force": 3})
    np.testing.assert_allclose(table["force"], 2 * FORCE_KN * 1e3)


def _grouped(path: Path, delimiter: str, cell) -> Path:
    """Bluehill-style rows whose force passes 1000 N, written with its thousands grouped."""
    force = np.linspace(500.0, 2600.0, 25)
    rows = [
        delimiter.join(f'"{v}"' for v in (f"{0.1 * i:.5f}", cell(f), cell(1e-5 * f)))
        for i, f in enumerate(force)
    ]
    head = delimiter.join(["Time", "Load", "Tensile strain (Strain 1)"])
    units = delimiter.join(["(s)", "(N)", "(mm/mm)"])
    path.write_text("\n".join([head, units, *rows]) + "\n", encoding="utf-8")
    return path, force


COLUMNS = {"time": "Time", "force": "Load", "strain": "Tensile strain (Strain 1)"}


def test_thousands_grouped_with_a_dot_decimal_are_read(tmp_path):
    """Instron Bluehill writes '1,006.28992' (quoted, in a ','-delimited file): one reading only."""
    path, force = _grouped(tmp_path / "bluehill.csv", ",", lambda v: f"{v:,.5f}")
    table = read_table(path, "extension", columns=COLUMNS)
    np.testing.assert_allclose(table["force"], force)
    np.testing.assert_allclose(table["strain"], [float(f"{1e-5 * f:.5f}") for f in force])


def test_thousands_grouped_with_a_decimal_comma_are_read(tmp_path):
    path, force = _grouped(
        tmp_path / "de.csv", ";", lambda v: f"{v:,.5f}".replace(",", " ").replace(".", ",").replace(" ", ".")
    )
    table = read_table(path, "extension", columns=COLUMNS)
    np.testing.assert_allclose(table["force"], force)


def test_a_grouped_cell_that_reads_two_ways_is_still_refused(tmp_path):
    """'1,012' alone in a column of decimal commas and dots: a thousands separator or a decimal mark."""
    path = tmp_path / "mixed.csv"
    path.write_text("time [s];force [N];strain [1]\n0;1,5;0\n1;2.5;0,1\n2;1,012;0,2\n", encoding="utf-8")
    with pytest.raises(DataError, match="reads as 1.012"):
        read_table(path, "extension")
