"""Record reading against hand-made records, for what the mutation sample (benchmarks/mutation.sh,
seed 29) showed no other test sees."""

from __future__ import annotations

import codecs
import re
from pathlib import Path

import numpy as np
import pytest

from matid.errors import DataError
from matid.io.ingest.detect import split
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


# --- single-spaced headers (matid/io/ingest/spaced.py): each of the four rules decides a case ---


@pytest.mark.parametrize(
    ("names", "units"),
    [
        # rule 2: the numbers of two channels of one quantity end their names, never start one
        (["Force 1", "Force 2"], ["N", "N"]),
        # rules 2 and 4: the prefix 'Ch' (written twice) starts each name it is in
        (["Time", "Ch Force 1", "Ch Position 1"], ["s", "N", "mm"]),
        # rule 1 through a colon: 'Time:' names a time, 'Force:' a force
        (["Elapsed Time:", "Axial Force:"], ["s", "N"]),
    ],
)
def test_single_spaced_names_are_cut_back_into_the_names_written(names, units) -> None:
    from matid.io.ingest.spaced import spaced_names

    words = " ".join(names).split()
    assert spaced_names(words, len(names), units) == names


def test_fewer_header_words_than_columns_give_no_names() -> None:
    """Two words cannot name three columns: no names (the header is not read as one)."""
    from matid.io.ingest.spaced import spaced_names

    assert spaced_names(["Time", "Force"], 3, ["s", "N", "mm"]) is None
    assert spaced_names(["Time[s]Force[N]"], 2, None) is None


# --- frame, checks and load_measurements ---


def test_an_unclosed_quote_after_a_quoted_number_names_its_own_row(tmp_path: Path) -> None:
    """Row 3 holds a quoted number (two quotes, read past); row 4 opens a quote that never closes:
    the error names row 4."""
    path = _write(tmp_path, 'twist_angle [rad],torque [N m]\n0,0\n0.1,"0.5"\n0.2,"1.0\n0.3,1.5\n')
    with pytest.raises(DataError, match=r"never closed") as info:
        read_table(path, "torsion")
    assert info.value.row == 4


def test_a_negated_column_that_ends_negative_says_to_remove_the_negation(tmp_path: Path) -> None:
    path = _write(tmp_path, "deflection [mm],force [N]\n0,0.001\n0.1,0.5\n0.2,1.0\n0.3,1.5\n")
    with pytest.raises(DataError) as info:
        read_table(path, "three_point_bend", negate=["force"])
    assert info.value.column == "force"
    assert 'remove "force" from negate' in info.value.detail


def test_a_study_s_negate_reaches_the_measurement(tmp_path: Path) -> None:
    """A bend record with the force written negative (compression) and negate = ["force"] in its
    [[test]]: the measurement's force is the record's, sign changed."""
    from matid.io.ingest.read import load_measurements
    from matid.io.study import load_study

    forces = [-0.001, -0.5, -1.0, -1.5]
    rows = "\n".join(f"{0.1 * k},{f}" for k, f in enumerate(forces))
    _write(tmp_path, "deflection [mm],force [N]\n" + rows + "\n")
    (tmp_path / "study.toml").write_text(
        '[study]\nname = "negate"\n\n[[specimen]]\nid = "T1"\nouter_diameter = "2 mm"\n'
        'inner_diameter = "1 mm"\n\n[[test]]\nkind = "three_point_bend"\nspecimen = "T1"\n'
        'file = "data.csv"\nspan = "10 mm"\nspecimen_length = "40 mm"\nsupport_radius = "2 mm"\n'
        'nose_radius = "2 mm"\nnegate = ["force"]\n',
        encoding="utf-8",
    )
    (measurement,) = load_measurements(load_study(tmp_path / "study.toml"))
    np.testing.assert_array_equal(measurement.table["force"], [-f for f in forces])


def test_a_wrong_encoding_names_the_byte_it_cannot_read(tmp_path: Path) -> None:
    path = tmp_path / "data.csv"
    path.write_bytes(b"twist_angle [rad],torque [N m]\n0,0\n0.1,0.5\xe9\n0.2,1.0\n")
    with pytest.raises(DataError) as info:
        read_table(path, "torsion", encoding="utf-8")
    assert "byte 42 is b'\\xe9'" in info.value.detail  # the 43rd byte of the file, 0xE9 (not UTF-8)


def test_a_column_too_small_to_measure_names_its_si_unit(tmp_path: Path) -> None:
    """Torques of 1e-40 N m (a unit mistake): the message gives the largest in N m and says what to do."""
    path = _write(tmp_path, "twist_angle [rad],torque [N m]\n0,0\n0.1,1e-40\n0.2,2e-40\n0.3,1e-40\n")
    with pytest.raises(DataError) as info:
        read_table(path, "torsion")
    assert info.value.column == "torque"
    assert "is 2e-40 N m (after unit conversion)" in info.value.detail
    assert "check the unit of the column" in info.value.detail


def test_a_row_of_numbers_above_the_header_is_named_by_its_line(tmp_path: Path) -> None:
    path = _write(
        tmp_path, "Specimen A\n0.5,1\ntwist_angle [rad],torque [N m]\n0,0\n0.1,0.5\n0.2,1.0\n0.3,1.5\n"
    )
    with pytest.raises(DataError, match="row of numbers above the header row 3") as info:
        read_table(path, "torsion")
    assert info.value.row == 2


def test_the_file_s_own_column_of_a_mapped_name_keeps_its_position_in_its_name(tmp_path: Path) -> None:
    """columns = { torque = "Moment" } while the file has a 'torque' column too (its second): that one
    is kept as 'torque_col2' (1-based position), the mapped one is the torque."""
    path = _write(
        tmp_path, "twist_angle [rad],torque [N m],Moment [N m]\n0,0,0\n0.1,0.5,1\n0.2,1.0,2\n0.3,1.5,3\n"
    )
    table = read_table(path, "torsion", columns={"torque": "Moment"})
    assert np.array_equal(table.columns["torque"], [0, 1, 2, 3])
    assert np.array_equal(table.columns["torque_col2"], [0, 0.5, 1.0, 1.5])


def test_a_unit_given_in_the_test_that_is_wrong_says_where_it_came_from(tmp_path: Path) -> None:
    path = _write(tmp_path, "twist_angle [rad],torque [N m]\n0,0\n0.1,0.5\n0.2,1.0\n0.3,1.5\n")
    with pytest.raises(DataError) as info:
        read_table(path, "torsion", units={"torque": "furlong"})
    assert info.value.column == "torque"
    assert "'furlong'" in info.value.detail and "(in the [[test]]'s units)" in info.value.detail


def test_rows_of_nan_only_leave_no_data_rows_at_the_first_data_line(tmp_path: Path) -> None:
    """Every data row is NaN (dropped as blank): no rows are left; the error points at line 2,
    where the data would begin."""
    path = _write(tmp_path, "twist_angle [rad],torque [N m]\nnan,nan\nnan,nan\nnan,nan\n")
    with pytest.raises(DataError, match="only 0 data rows") as info:
        read_table(path, "torsion")
    assert info.value.row == 2


def test_a_file_that_grows_past_the_limit_while_read_is_refused_in_mib(tmp_path, monkeypatch) -> None:
    """The size is checked on stat, then at most MAX_BYTES + 1 bytes are read: a file that grew in
    between (stat said 40 bytes) is refused, the limit given in MiB (here 1 MiB)."""
    import os
    from types import SimpleNamespace

    from matid.io.ingest import read

    small = _write(tmp_path, "twist_angle [rad],torque [N m]\n0,0\n")
    big = tmp_path / "big.csv"
    big.write_bytes(b"0,0\n" * (2**18 + 1))  # 1 MiB + 4 bytes
    monkeypatch.setattr(read, "MAX_BYTES", 2**20)
    monkeypatch.setattr(read, "os", SimpleNamespace(stat=lambda path: os.stat(small)))
    with pytest.raises(DataError, match=r"file grew beyond 1 MiB while being read"):
        read_table(big, "torsion")


def test_a_row_with_values_under_the_first_row_s_trailing_delimiters_is_named_and_counted(tmp_path) -> None:
    """The first data row ends in two empty cells (a trailing ',,'), so pandas parses five columns
    without an error; row 3 writes values into the two beyond the header's three: it is named with
    its own count of cells (a row under an empty trailing cell only, row 4, is read)."""
    path = _write(tmp_path, "time [s],force [N],strain [%]\n0,0,0,,\n1,1,1,7,8\n2,2,2,\n3,3,3\n")
    with pytest.raises(DataError) as info:
        read_table(path, "extension")
    assert info.value.row == 3 and info.value.detail.startswith("row has 5 cells, header has 3")
    path = _write(tmp_path, "time [s],force [N],strain [%]\n0,0,0,,\n1,1,1\n2,2,2,\n3,3,3\n")
    assert np.array_equal(read_table(path, "extension").columns["force"], [0, 1, 2, 3])


_BODY = "twist_angle [rad],torque [N m]\n1000.5,2.25\n2,3.25\n3,4.25\n4,5.25\n5,6.25\n"
_BY_NUMBER = {"columns": {"twist_angle": 1, "torque": 2}, "units": {"twist_angle": "rad", "torque": "N m"}}


@pytest.mark.parametrize(
    ("mark", "codec"),
    [
        (codecs.BOM_UTF8, "utf-8"),
        (codecs.BOM_UTF16_LE, "utf-16-le"),
        (codecs.BOM_UTF16_BE, "utf-16-be"),
        (codecs.BOM_UTF32_LE, "utf-32-le"),
    ],
    ids=["utf-8", "utf-16-le", "utf-16-be", "utf-32-le"],
)
def test_a_byte_order_mark_kept_by_the_test_s_encoding_is_counted_once(tmp_path: Path, mark, codec) -> None:
    """A file with a byte-order mark read with `encoding` naming the codec without its mark ("utf-8"
    for an Excel "CSV UTF-8"): the codec keeps the mark as U+FEFF, and the first data row starts
    where it starts. Before: the mark was counted twice, and 1000.5 was read as 0.5, silently."""
    path = tmp_path / "marked.csv"
    path.write_bytes(mark + _BODY.encode(codec))
    table = read_table(path, "torsion", encoding=codec, **_BY_NUMBER)
    assert np.array_equal(table.columns["twist_angle"], [1000.5, 2, 3, 4, 5])
    assert list(table.lines) == [2, 3, 4, 5, 6]


def test_a_first_row_read_from_the_middle_of_a_character_was_a_crash(tmp_path: Path) -> None:
    """As above with a text cell 'abé' first: the row read 3 bytes late started inside 'é', and pandas'
    UnicodeDecodeError reached the user (exit 3). Now the row reads."""
    path = tmp_path / "marked.csv"
    text = "note,twist_angle [rad],torque [N m]\nabé,0.5,1.25\nx,1.5,2.25\nx,2.5,3.25\nx,3.5,4.25\n"
    path.write_bytes(codecs.BOM_UTF8 + text.encode("utf-8"))
    table = read_table(path, "torsion", encoding="utf-8")
    assert np.array_equal(table.columns["torque"], [1.25, 2.25, 3.25, 4.25])


def test_utf_16_text_starting_with_nul_is_not_taken_for_a_utf_32_mark(tmp_path: Path) -> None:
    """UTF-16 LE with its mark, the first character U+0000: the file starts FF FE 00 00, the UTF-32 LE
    mark. Read as "utf-16" (the test's encoding), the rows are UTF-16 LE. Before: parsed as UTF-32 LE
    from the data row on, a UnicodeDecodeError (exit 3). Found by a hypothesis search for the
    ValueError path of frame.read_rows."""
    path = tmp_path / "nul.csv"
    path.write_bytes(codecs.BOM_UTF16_LE + ("\x00 export\n" + _BODY).encode("utf-16-le"))
    table = read_table(path, "torsion", encoding="utf-16", **_BY_NUMBER)
    assert np.array_equal(table.columns["torque"], [2.25, 3.25, 4.25, 5.25, 6.25])


def test_a_redundant_escape_of_iso2022_jp_does_not_move_the_rows(tmp_path: Path) -> None:
    """ISO-2022-JP with an escape to ASCII at the start where the text is ASCII already: it decodes to
    nothing, and the text encoded again is 3 bytes shorter than the file's. Before: the rows were read
    from 3 bytes early ('NaN or infinite value' at a good cell)."""
    path = tmp_path / "jis.csv"
    path.write_bytes(b"\x1b(B" + _BODY.encode("iso2022_jp"))
    table = read_table(path, "torsion", encoding="iso2022_jp", **_BY_NUMBER)
    assert np.array_equal(table.columns["twist_angle"], [1000.5, 2, 3, 4, 5])


def test_a_tab_before_a_quoted_cell_of_a_space_delimited_row_separates_cells(tmp_path: Path) -> None:
    """Space-delimited rows '0.5 1.25<TAB>"run a"': pandas splits at the tab (``\\s+``), and so does the
    reading of a row for layout and messages now, quoted cell or not (a tab inside quotes stays). Before:
    the quoted branch split at spaces only, '1.25<TAB>"run' was one cell, and the file had 'no header
    row'; with a third number before the tab, a row of 4 cells was reported as 'row has 3 cells, header
    has 3'. Found looking for an input that reaches frame._check_width."""
    rows = "".join(f'{k}.5 {k + 1}.25\t"run {k}"\n' for k in range(4))
    path = _write(tmp_path, "twist_angle [rad]  torque [N m]  note\n" + rows)
    table = read_table(path, "torsion")
    assert np.array_equal(table.columns["torque"], [1.25, 2.25, 3.25, 4.25])
    assert split('1 2\t"a\tb" 3', " ") == ["1", "2", "a\tb", "3"]


def test_a_bad_cell_of_a_file_without_a_header_names_the_row_its_data_start_at(tmp_path: Path) -> None:
    """What the reader saw, in the message of a bad cell: a file with no header row whose data
    start at its first row says so (a mutant said row -1)."""
    path = _write(tmp_path, "0\t0\t0\n1\t1.5\t1\n2\tx\t2\n3\t4.5\t3\n")
    columns, units = {"time": 1, "force": 2, "strain": 3}, {"time": "s", "force": "N", "strain": "%"}
    with pytest.raises(DataError) as info:
        read_table(path, "extension", columns=columns, units=units)
    assert "no header row, data from row 1)" in info.value.detail, info.value.detail
    assert info.value.row == 3


def test_a_mapped_name_that_is_the_start_of_a_header_cell_is_suggested(tmp_path: Path) -> None:
    """columns.force = 'Load' where the header says 'Loadcell_1': not a column, but the message
    offers the cell (a name cut short is the usual slip; 'Load' is 8/14 of their joint length)."""
    rows = ["time [s],Loadcell_1,strain [%]"] + [f"{i},{0.5 * i},{i}" for i in range(6)]
    path = _write(tmp_path, "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=r"columns\.force = 'Load' is not a column") as info:
        read_table(path, "extension", columns={"force": "Load"}, units={"force": "N"})
    assert "did you mean 'Loadcell_1'?" in str(info.value)


def test_a_study_s_encoding_is_the_one_its_record_is_read_in(tmp_path: Path) -> None:
    """An EBCDIC (cp500) record that detection cannot read (it finds no header): the study's
    encoding = "cp500" reads it, every value as written."""
    from matid.io.ingest.read import load_measurements
    from matid.io.study import load_study

    rows = ["time [s],force [N],strain [%]"] + [f"{i},{0.5 + i},{i}" for i in range(6)]
    (tmp_path / "ebcdic.csv").write_bytes(("\n".join(rows) + "\n").encode("cp500"))
    study = tmp_path / "study.toml"
    study.write_text(
        '[study]\nname = "e"\n\n[[specimen]]\nid = "T1"\nouter_diameter = "2 mm"\n\n'
        '[[test]]\nkind = "extension"\nspecimen = "T1"\nfile = "ebcdic.csv"\ngauge_length = "50 mm"\n'
        'encoding = "cp500"\n',
        encoding="utf-8",
    )
    (measurement,) = load_measurements(load_study(study))
    assert measurement.table.columns["force"] == pytest.approx([0.5 + i for i in range(6)])
    with pytest.raises(DataError, match="no header row"):  # without it (the test can tell)
        read_table(tmp_path / "ebcdic.csv", "extension")
