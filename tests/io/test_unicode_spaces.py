"""A Unicode space inside a cell of a space-delimited record (found by the mutation review of
2026-11-28): pandas' C reader splits cells at spaces and tabs only, the error path re-split the
row at every Unicode space, and named the wrong cell ("NaN or infinite value '0.5'" for the cell
'0.5<NBSP>7'). Both now split where pandas does; the message names the cell as read."""

from __future__ import annotations

import sys
import unicodedata

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from matid.errors import DataError
from matid.io.ingest.read import read_table

#: Every Unicode space but the space and tab (the no-break space, the ideographic space, ...).
OTHER_SPACES = [
    chr(c) for c in range(sys.maxunicode + 1)
    if chr(c).isspace() and chr(c) not in " \t\n\r\x0b\x0c\x1c\x1d\x1e\x1f\x85\u2028\u2029"
]  # fmt: skip


def test_the_other_spaces_are_the_ones_a_reader_meets():
    assert "\u00a0" in OTHER_SPACES and "\u3000" in OTHER_SPACES
    assert all(unicodedata.category(c) == "Zs" for c in OTHER_SPACES)


@settings(max_examples=25, deadline=None)
@given(space=st.sampled_from(OTHER_SPACES), row=st.integers(0, 2))
def test_a_unicode_space_inside_a_cell_is_named_with_its_cell(tmp_path_factory, space, row):
    rows = [["0", "0.1", "0.0"], ["1", "0.5", "0.1"], ["2", "0.9", "0.2"]]
    rows[row][1] = f"0.5{space}7"
    text = "time force elongation\ns N mm\n" + "".join(" ".join(r) + "\n" for r in rows)
    path = tmp_path_factory.mktemp("r") / "r.txt"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DataError) as info:
        read_table(path, "extension")
    message = str(info.value)
    assert f"row {row + 3}" in message and "'force'" in message
    assert "not a number" in message and "Unicode space" in message, message


def test_spaces_and_tabs_still_separate_cells(tmp_path):
    path = tmp_path / "r.txt"
    text = "time force elongation\ns N mm\n0 \t0.1  0.0\n1\t0.5 0.1\n2 0.9\t\t0.2\n"
    path.write_text(text, encoding="utf-8")
    table = read_table(path, "extension")
    assert table.columns["force"].tolist() == [0.1, 0.5, 0.9]
