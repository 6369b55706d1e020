"""Readers on two more layouts public lab records have (issue 28, benchmarks/real_records.md).

- A Shimadzu Trapezium export of several specimens (raballito/tensile_test_analyzer,
  ``Exemple_MS_Shimadzu_Flex_L20_D2.csv``): each specimen's ``Temps,Force,Course_Traverse``
  next to the others' under a label row, one units row, and the shorter records ending in
  empty cells while the longest runs on. One specimen is named by column numbers; the rows
  after its last value are the other records', not empty cells of this one. Its header text
  names every specimen's column, so naming a column by that text is refused, with the numbers.
- A Zwick testXpert II ASCII export (``.TRA``, a-hilhorst/Tensile-test-Analysis): lines
  ``"name",value,"unit"`` of the set-up above the quoted channel names and their units row.

The files are made up here in those shapes (the fetched ones carry no licence).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.errors import DataError
from matid.io.ingest.read import read_table

#: two bend records of unequal length: deflection [mm] and force [N] of a rod, 0.01 s apart
LONG, SHORT = 40, 25
D_LONG, D_SHORT = np.linspace(0.0, 0.4, LONG), np.linspace(0.0, 0.3, SHORT)
F_LONG, F_SHORT = 1350.0 * D_LONG + 0.07, 980.0 * D_SHORT + 0.05


def _trapezium(path: Path, gap: int | None = None) -> Path:
    """Two specimens side by side, the second one shorter (its cells empty after row SHORT);
    ``gap``: a row of the second one whose force cell is left empty."""
    lines = [
        "Brut 1,,,Recuit 250\u00b0C,,",
        ",".join(["Temps", "Force", "Course_Traverse"] * 2),
        ",".join(["sec", "N", "mm"] * 2),
    ]
    for i in range(LONG):
        cells = [f"{0.01 * i:g}", f"{F_LONG[i]:.6g}", f"{D_LONG[i]:.6g}"]
        if i < SHORT:
            force = "" if i == gap else f"{F_SHORT[i]:.6g}"
            cells += [f"{0.01 * i:g}", force, f"{D_SHORT[i]:.6g}"]
        else:
            cells += ["", "", ""]
        lines.append(",".join(cells))
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("latin-1"))
    return path


def _bend(path: Path, columns: dict):
    """The three-point bend record of ``columns`` in the Latin-1 file ``path``."""
    return read_table(path, "three_point_bend", columns=columns, encoding="latin-1")


def test_the_shorter_of_two_records_side_by_side_ends_at_its_last_value(tmp_path):
    table = _bend(_trapezium(tmp_path / "flex.csv"), {"deflection": 6, "force": 5})
    assert table.n_rows == SHORT
    np.testing.assert_allclose(table["force"], [float(f"{f:.6g}") for f in F_SHORT])
    np.testing.assert_allclose(table["deflection"], [1e-3 * float(f"{d:.6g}") for d in D_SHORT])


def test_the_longer_record_side_by_side_is_read_to_its_end(tmp_path):
    table = _bend(_trapezium(tmp_path / "flex.csv"), {"deflection": 3, "force": 2})
    assert table.n_rows == LONG
    np.testing.assert_allclose(table["force"][-1], float(f"{F_LONG[-1]:.6g}"))


def test_an_empty_cell_before_the_last_value_of_a_record_is_still_refused(tmp_path):
    with pytest.raises(DataError, match=r"row 14, column 'Force': empty cell"):
        _bend(_trapezium(tmp_path / "flex.csv", gap=10), {"deflection": 6, "force": 5})


def test_a_header_text_every_record_repeats_is_refused_with_the_column_numbers(tmp_path):
    with pytest.raises(DataError, match=r"columns.force = 'Force' names 2 columns \(numbers 2, 5\)"):
        _bend(_trapezium(tmp_path / "flex.csv"), {"deflection": 6, "force": "Force"})


def _zwick(path: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    """A testXpert II .TRA: set-up lines (some with a number in them), channel names, units."""
    travel = np.linspace(0.0, 0.05, 30)
    force = 146.4 + 46000.0 * travel
    lines = [
        '"Specimen thickness",1.5,"mm"',
        '"Specimen width",4.89,"mm"',
        '"Cross-section",7.335,"mm\u00b2"',
        '"Gage length, standard travel",30,"mm"',
        '"Extensometer",""',
        '"Date/Clock time",44182.5,""',
        '"v1",1,"mm/min"',
        '"Time","Crosshead absolute","Standard force","Standard travel"',
        '"s","mm","N","mm"',
    ]
    lines += [
        f"{2.6 + 0.01 * i:g},{1190.55 + t:g},{f:g},{t:g}"
        for i, (t, f) in enumerate(zip(travel, force, strict=True))
    ]
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("latin-1"))
    return path, travel, force


def test_a_zwick_tra_export_is_read_below_its_set_up_lines(tmp_path):
    path, travel, force = _zwick(tmp_path / "Invar.TRA")
    table = read_table(
        path,
        "extension",
        columns={"time": "Time", "elongation": "Standard travel", "force": "Standard force"},
        encoding="latin-1",
    )
    assert table.header_row == 8
    np.testing.assert_allclose(table["force"], [float(f"{f:g}") for f in force])
    np.testing.assert_allclose(table["elongation"], [1e-3 * float(f"{t:g}") for t in travel])
