"""Record reading against hand-made records, for what the mutation sample (benchmarks/mutation.sh,
seed 29) showed no other test sees."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from matid.errors import DataError
from matid.io.ingest.read import read_table


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "data.csv"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_column_with_one_decimal_mark_reads_1_250_one_way(tmp_path: Path) -> None:
    """A ';' record with decimal commas in its time column and only '.' in its force column:
    the force column has one decimal mark, so '1.250' has one reading there, 1.25 (no ',' in the
    column to make the '.' a thousands separator)."""
    rows = ["time [s];force [N];strain [%]", "0,0;0.5;0", "0,5;1.250;1", "1,0;2.75;2", "1,5;3.125;3"]
    path = _write(tmp_path, "\n".join(rows) + "\n")
    table = read_table(path, "extension")
    assert np.array_equal(table.columns["time"], [0.0, 0.5, 1.0, 1.5])
    assert np.array_equal(table.columns["force"], [0.5, 1.25, 2.75, 3.125])


def test_an_empty_cell_in_a_column_of_both_marks_is_named_as_empty(tmp_path: Path) -> None:
    """'1,5' and '2.5' in one column (each reads one way) and an empty cell in row 4: the error is
    the empty cell, at its row and column, not an ambiguity of the decimal mark."""
    path = _write(tmp_path, "time [s];force [N];strain [%]\n0;1,5;0\n1;2.5;1\n2;;2\n3;4,5;3\n")
    with pytest.raises(DataError) as info:
        read_table(path, "extension")
    assert (info.value.row, info.value.column) == (4, "force")
    assert re.search(r"empty cell", info.value.detail), info.value.detail


def test_a_preamble_keeps_its_keys_whole_and_its_free_text_as_text(tmp_path: Path) -> None:
    """'#Xmax: 12 mm' is the key 'Xmax' (the '#' marks the line, the X is the key's), and a '#'
    line without ':' is free text, kept as the preamble, not a key without a value."""
    lines = ["#Xmax: 12 mm", "# tested on the blue rig", "time [s],force [N],strain [%]"]
    lines += ["0,0,0", "1,1,1", "2,2,2"]
    table = read_table(_write(tmp_path, "\n".join(lines) + "\n"), "extension")
    assert table.metadata == {"Xmax": "12 mm", "preamble": "# tested on the blue rig"}
