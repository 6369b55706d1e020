"""Tests of matid.io.ingest.read: every CSV variant of data-contract section 2, and bad input."""

from __future__ import annotations

import hashlib
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from matid.errors import DataError
from matid.io.ingest.checks import DYNAMIC_RANGE
from matid.io.ingest.read import load_measurements, read_table
from matid.io.study import load_study
from matid.model.measurement import Table
from matid.units import PHYSICAL_BOUND

EXT_BRACKETS = "time [s],force [N],elongation [mm]\n0,0.5,0.1\n1,1.5,0.2\n2,2.5,0.3\n"


def write(tmp_path: Path, text: str, name: str = "data.csv", encoding: str = "utf-8") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode(encoding))
    return path


def where(path: Path, *, row: int | None = None, column: str | None = None) -> str:
    """The regex for the location prefix of a DataError message."""
    parts = [re.escape(str(path))]
    if row is not None:
        parts.append(f"row {row}")
    if column is not None:
        parts.append(re.escape(f"column '{column}'"))
    return "^" + re.escape(", ").join(parts) + ": "


# --- format variants ----------------------------------------------------------------


def test_brackets_give_si_arrays_units_and_hash(tmp_path):
    path = write(tmp_path, EXT_BRACKETS)
    table = read_table(path, "extension")
    assert isinstance(table, Table)
    assert table.path == path
    assert table.n_rows == 3
    np.testing.assert_allclose(table["time"], [0.0, 1.0, 2.0])
    np.testing.assert_allclose(table["force"], [0.5, 1.5, 2.5])
    np.testing.assert_allclose(table["elongation"], [1e-4, 2e-4, 3e-4])
    assert dict(table.units) == {"time": "s", "force": "N", "elongation": "mm"}
    assert table.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert "force" in table and "strain" not in table
    assert dict(table.metadata) == {}


def test_parentheses_ms_kn_percent_strain(tmp_path):
    text = "time (ms),force (kN),strain (%)\n0,0.001,0\n500,0.002,1.5\n1000,0.003,3\n"
    table = read_table(write(tmp_path, text), "extension")
    np.testing.assert_allclose(table["time"], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(table["force"], [1.0, 2.0, 3.0])
    np.testing.assert_allclose(table["strain"], [0.0, 0.015, 0.03])
    assert table.units["strain"] == "%"


@pytest.mark.parametrize("units_row", ["min,mN,um", "(min),(mN),(um)", "[min],[mN],[um]"])
def test_units_row_with_and_without_parentheses(tmp_path, units_row):
    text = f"time,force,elongation\n{units_row}\n0,10,5\n0.5,20,10\n1,30,15\n"
    table = read_table(write(tmp_path, text), "extension")
    np.testing.assert_allclose(table["time"], [0.0, 30.0, 60.0])
    np.testing.assert_allclose(table["force"], [0.01, 0.02, 0.03])
    np.testing.assert_allclose(table["elongation"], [5e-6, 10e-6, 15e-6])
    assert table.units["time"] == "min"
    assert table.n_rows == 3


def test_semicolon_with_decimal_comma(tmp_path):
    text = "time [s];force [N];elongation [mm]\n0;1,25;0,5\n0,5;2,5;1,0\n1;3,75;1,5e-1\n"
    table = read_table(write(tmp_path, text), "extension")
    np.testing.assert_allclose(table["time"], [0.0, 0.5, 1.0])
    np.testing.assert_allclose(table["force"], [1.25, 2.5, 3.75])
    np.testing.assert_allclose(table["elongation"], [5e-4, 1e-3, 1.5e-4])


def test_semicolon_units_row_with_empty_trailing_unit(tmp_path):
    text = "time;force;elongation;cycle\n(s);(mN);(mm);\n0;1,5;0,1;1\n1;2,5;0,2;1\n2;3,5;0,3;2\n"
    table = read_table(write(tmp_path, text), "extension")
    np.testing.assert_allclose(table["force"], [1.5e-3, 2.5e-3, 3.5e-3])
    np.testing.assert_allclose(table["cycle"], [1, 1, 2])


def test_tab_delimited(tmp_path):
    text = "twist angle [deg]\ttorque [mN mm]\n0\t0\n90\t2\n180\t4\n"
    table = read_table(write(tmp_path, text), "torsion")
    np.testing.assert_allclose(table["twist_angle"], [0.0, math.pi / 2, math.pi])
    np.testing.assert_allclose(table["torque"], [0.0, 2e-6, 4e-6])


def test_utf8_bom_is_ignored(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf" + EXT_BRACKETS.encode())
    table = read_table(path, "extension")
    assert "time" in table
    np.testing.assert_allclose(table["time"], [0.0, 1.0, 2.0])


def test_latin1_micro_and_degree(tmp_path):
    bend = write(tmp_path, "deflection [µm],force [mN]\n0,0\n50,1\n100,2\n", "b.csv", "latin-1")
    table = read_table(bend, "three_point_bend")
    np.testing.assert_allclose(table["deflection"], [0.0, 5e-5, 1e-4])
    assert table.units["deflection"] == "µm"
    text = "Tip Angle [°],torque [N m]\n0,0\n45,1e-4\n90,2e-4\n"
    table = read_table(write(tmp_path, text, "m.csv", "latin-1"), "magnetic_bending")
    np.testing.assert_allclose(table["tip_angle"], [0, math.pi / 4, math.pi / 2])
    assert table.units["tip_angle"] == "°"


def test_metadata_preamble_is_kept_and_rows_counted(tmp_path):
    text = "# operator: A. Bell\n# machine: Instron 5944\n#started: 12:30:05\n" + EXT_BRACKETS
    table = read_table(write(tmp_path, text), "extension")
    assert dict(table.metadata) == {
        "operator": "A. Bell",
        "machine": "Instron 5944",
        "started": "12:30:05",
    }
    assert table.n_rows == 3


def test_cgs_units(tmp_path):
    bend = "tip_angle [rad],field [G],field_angle [deg]\n0,100,90\n0.1,200,90\n0.2,300,90\n"
    table = read_table(write(tmp_path, bend, "m.csv"), "magnetic_bending")
    np.testing.assert_allclose(table["field"], [0.01, 0.02, 0.03])
    np.testing.assert_allclose(table["field_angle"], [math.pi / 2] * 3)
    torsion = "twist_angle [rad],torque [dyn cm]\n0,0\n1,100\n2,200\n"
    table = read_table(write(tmp_path, torsion, "t.csv"), "torsion")
    np.testing.assert_allclose(table["torque"], [0, 1e-5, 2e-5])
    ext = "time [s],force [dyn],strain [1]\n0,0,0\n1,1e5,0.01\n2,2e5,0.02\n"
    table = read_table(write(tmp_path, ext, "e.csv"), "extension")
    np.testing.assert_allclose(table["force"], [0, 1, 2])
    bend3 = "deflection [mm],force [gf]\n0,0\n0.1,1\n0.2,2\n"
    table = read_table(write(tmp_path, bend3, "3.csv"), "three_point_bend")
    np.testing.assert_allclose(table["force"], [0, 9.80665e-3, 2 * 9.80665e-3])


def test_trailing_blank_lines_and_crlf(tmp_path):
    text = EXT_BRACKETS.replace("\n", "\r\n") + "\r\n\r\n   \r\n"
    table = read_table(write(tmp_path, text), "extension")
    assert table.n_rows == 3
    np.testing.assert_allclose(table["force"], [0.5, 1.5, 2.5])


def test_trailing_lines_of_delimiters_only(tmp_path):
    text = "time;force;strain\ns;N;1\n0;0;0\n1;1;0,01\n2;2;0,02\n;;\n;;\n"
    table = read_table(write(tmp_path, text), "extension")
    assert table.n_rows == 3
    np.testing.assert_allclose(table["strain"], [0.0, 0.01, 0.02])


def test_trailing_delimiter_on_every_line(tmp_path):
    text = "time [s],force [N],elongation [mm],\n0,0.5,0.1,\n1,1.5,0.2,\n2,2.5,0.3,\n"
    table = read_table(write(tmp_path, text), "extension")
    assert set(table.columns) == {"time", "force", "elongation"}


def test_free_form_names_match_case_spaces_underscores(tmp_path):
    text = "TIP  Angle [deg],Field_Angle [deg],Field [mT]\n0,90,10\n10,90,20\n20,90,30\n"
    table = read_table(write(tmp_path, text), "magnetic_bending")
    assert set(table.columns) == {"tip_angle", "field_angle", "field"}
    np.testing.assert_allclose(table["field"], [0.01, 0.02, 0.03])
    np.testing.assert_allclose(table["tip_angle"], np.deg2rad([0, 10, 20]))


def test_unknown_columns_kept_and_dimensionless_names_need_no_unit(tmp_path):
    text = (
        "Cycle,Index,time [s],force [N],strain [-],crosshead [mm],temp [degC],status [-]\n"
        "1,0,0,0,0,0,37,ok\n1,1,1,1,0.01,1,37.5,ok\n2,2,2,2,0.02,2,38,done\n"
    )
    table = read_table(write(tmp_path, text), "extension")
    np.testing.assert_allclose(table["cycle"], [1, 1, 2])
    np.testing.assert_allclose(table["index"], [0, 1, 2])
    np.testing.assert_allclose(table["crosshead"], [0, 1e-3, 2e-3])  # pint knows mm
    np.testing.assert_allclose(table["temp"], [37, 37.5, 38])  # raw floats
    assert "status" not in table  # text column: ignored
    assert table.units["cycle"] == ""


def test_magnetic_bending_with_torque_only(tmp_path):
    text = "tip_angle [deg],torque [N mm]\n0,0\n5,0.01\n10,0.02\n"
    table = read_table(write(tmp_path, text), "magnetic_bending")
    np.testing.assert_allclose(table["torque"], [0, 1e-5, 2e-5])


def test_arrays_are_read_only(tmp_path):
    table = read_table(write(tmp_path, EXT_BRACKETS), "extension")
    with pytest.raises(ValueError):
        table["force"][0] = 1.0
    with pytest.raises(TypeError):
        table.columns["force"] = np.zeros(3)


def test_unknown_kind_is_a_programming_error(tmp_path):
    with pytest.raises(ValueError, match="unknown test kind"):
        read_table(write(tmp_path, EXT_BRACKETS), "tension")


# --- bad input ------------------------------------------------------------------------


def test_missing_file(tmp_path):
    path = tmp_path / "nope.csv"
    with pytest.raises(DataError, match=where(path) + "file not found"):
        read_table(path, "extension")


@pytest.mark.parametrize("text", ["", "\n\n  \n"])
def test_empty_file(tmp_path, text):
    path = write(tmp_path, text)
    with pytest.raises(DataError, match=where(path) + "empty file"):
        read_table(path, "extension")


def test_only_metadata(tmp_path):
    path = write(tmp_path, "# operator: A\n# machine: B\n")
    with pytest.raises(DataError, match=where(path) + "no header row"):
        read_table(path, "extension")


def test_missing_required_column_lists_found(tmp_path):
    path = write(tmp_path, "# a: b\ntime [s],force [N],crosshead [mm]\n0,0,0\n1,1,1\n2,2,2\n")
    with pytest.raises(DataError, match=where(path, row=2)) as info:
        read_table(path, "extension")
    assert "'elongation' or 'strain'" in str(info.value)
    assert "found: time, force, crosshead" in str(info.value)


def test_magnetic_bending_needs_torque_or_field_and_field_angle(tmp_path):
    path = write(tmp_path, "tip_angle [deg],field [mT]\n0,1\n1,2\n2,3\n")
    with pytest.raises(DataError, match=where(path, row=1) + ".*'torque' or 'field_angle'"):
        read_table(path, "magnetic_bending")


def test_column_without_unit(tmp_path):
    path = write(tmp_path, "time [s],Force,elongation [mm]\n0,0,0\n1,1,1\n2,2,2\n")
    with pytest.raises(DataError, match=where(path, row=1, column="Force") + "column has no unit"):
        read_table(path, "extension")


def test_column_the_test_does_not_use_needs_no_known_unit(tmp_path):
    # data-contract section 7: only the columns a test uses must have a known unit.
    text = "remark,time [Sec],deflection [mm],force [N],temp [degF??]\n1,0,0,0,1\n2,1,1,1,2\n3,2,2,2,3\n"
    table = read_table(write(tmp_path, text), "three_point_bend")
    np.testing.assert_allclose(table["remark"], [1, 2, 3])
    np.testing.assert_allclose(table["temp"], [1, 2, 3])  # unit unknown: raw values kept
    np.testing.assert_allclose(table["time"], [0, 1, 2])
    assert table.units["temp"] == "degF??"


def test_unknown_unit(tmp_path):
    path = write(tmp_path, "time [s],force [kgfx],elongation [mm]\n0,0,0\n1,1,1\n2,2,2\n")
    pattern = where(path, row=1, column="force") + "unknown unit 'kgfx'"
    with pytest.raises(DataError, match=pattern):
        read_table(path, "extension")


def test_wrong_dimension_unit(tmp_path):
    path = write(tmp_path, "time [s],force [mm],elongation [mm]\n0,0,0\n1,1,1\n2,2,2\n")
    pattern = where(path, row=1, column="force") + "'mm' is not a unit of force"
    with pytest.raises(DataError, match=pattern):
        read_table(path, "extension")


def test_malformed_unit(tmp_path):
    path = write(tmp_path, "time [s],force [-],elongation [mm]\n0,0,0\n1,1,1\n2,2,2\n")
    with pytest.raises(DataError, match=where(path, row=1, column="force") + "unknown unit '-'"):
        read_table(path, "extension")


def test_bad_unit_in_units_row_names_that_row(tmp_path):
    path = write(tmp_path, "# x: y\ntime,force,elongation\ns,N,deg\n0,0,0\n1,1,1\n2,2,2\n")
    with pytest.raises(DataError, match=where(path, row=3, column="elongation") + "'deg'"):
        read_table(path, "extension")


def test_non_numeric_cell_names_line_column_and_text(tmp_path):
    text = "# operator: A\n# rig: 2\ntime,force,elongation\n(s),(N),(mm)\n"
    path = write(tmp_path, text + "0,0,0\n1,1,1\n2,1.5x,2\n3,3,3\n")
    pattern = where(path, row=7, column="force") + "not a number: '1.5x'"
    with pytest.raises(DataError, match=pattern):
        read_table(path, "extension")


def test_decimal_comma_not_accepted_with_comma_delimiter(tmp_path):
    path = write(tmp_path, 'time [s],force [N],strain [1]\n0,0,0\n1,"1,5",0\n2,2,0\n')
    with pytest.raises(DataError, match=where(path, row=3, column="force") + "not a number: '1,5'"):
        read_table(path, "extension")


@pytest.mark.parametrize("bad", ["nan", "NaN", "inf", "-Infinity"])
def test_nan_and_inf_cells(tmp_path, bad):
    path = write(tmp_path, f"time [s],force [N],strain [%]\n0,0,0\n1,1,{bad}\n2,2,2\n")
    pattern = where(path, row=3, column="strain") + re.escape(f"NaN or infinite value '{bad}'")
    with pytest.raises(DataError, match=pattern):
        read_table(path, "extension")


def test_empty_cell(tmp_path):
    path = write(tmp_path, "time [s],force [N],strain [%]\n0,0,0\n1,,1\n2,2,2\n")
    with pytest.raises(DataError, match=where(path, row=3, column="force") + "empty cell"):
        read_table(path, "extension")


def test_ragged_row(tmp_path):
    path = write(tmp_path, "time [s],force [N],strain [%]\n0,0,0\n1,1,1,7\n2,2,2\n")
    with pytest.raises(DataError, match=where(path, row=3) + "row has 4 cells, header has 3"):
        read_table(path, "extension")


def test_short_row(tmp_path):
    path = write(tmp_path, "time [s],force [N],strain [%]\n0,0,0\n1,1,1\n2,2\n")
    with pytest.raises(DataError, match=where(path, row=4) + "row has 2 cells, header has 3"):
        read_table(path, "extension")


def test_blank_lines_inside_data_are_skipped_and_rows_still_counted(tmp_path):
    path = write(tmp_path, "time [s],force [N],strain [%]\n0,0,0\n\n1,1,1\n\n2,x,2\n")
    with pytest.raises(DataError, match=where(path, row=6, column="force") + "not a number: 'x'"):
        read_table(path, "extension")


@pytest.mark.parametrize("n_rows", [0, 1, 2])
def test_fewer_than_three_data_rows(tmp_path, n_rows):
    text = "time [s],force [N],strain [%]\n" + "".join(f"{i},{i},{i}\n" for i in range(n_rows))
    path = write(tmp_path, text)
    pattern = where(path, row=n_rows + 1) + f"only {n_rows} data rows, need at least 3"
    if n_rows == 0:  # a header with nothing under it is not recognised as a header
        pattern = where(path) + "no header row found"
    with pytest.raises(DataError, match=pattern):
        read_table(path, "extension")


def test_duplicate_column(tmp_path):
    path = write(tmp_path, "time [s],Force [N],force [mN],strain [%]\n0,0,0,0\n1,1,1,1\n2,2,2,2\n")
    pattern = where(path, row=1, column="force") + "column appears twice"
    with pytest.raises(DataError, match=pattern):
        read_table(path, "extension")


def test_latin1_control_byte_does_not_shift_row_numbers(tmp_path):
    # 0x85 decodes to U+0085 (NEL), which str.splitlines would treat as a line break.
    path = tmp_path / "nel.csv"
    path.write_bytes(b"# note: a\x85b\ntime [s],force [N],strain [%]\n0,0,0\n1,x,1\n2,2,2\n")
    with pytest.raises(DataError, match=where(path, row=4, column="force")):
        read_table(path, "extension")


# --- load_measurements ----------------------------------------------------------------

STUDY = """
[study]
name = "ingest test"

[[specimen]]
id = "T1"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"

[[test]]
kind = "extension"
specimen = "T1"
file = "ext1.csv"
gauge_length = "50 mm"

[[test]]
kind = "torsion"
specimen = "T1"
file = "sub/tor.csv"
length = "60 mm"
exclude = true
"""


def test_load_measurements_in_study_order_including_excluded(tmp_path):
    (tmp_path / "study.toml").write_text(STUDY)
    write(tmp_path, EXT_BRACKETS, "ext1.csv")
    (tmp_path / "sub").mkdir()
    write(tmp_path, "twist_angle [rad],torque [N m]\n0,0\n1,1\n2,2\n", "sub/tor.csv")
    measurements = load_measurements(load_study(tmp_path))
    assert [m.test.kind for m in measurements] == ["extension", "torsion"]
    assert measurements[1].test.exclude is True
    np.testing.assert_allclose(measurements[0].table["elongation"], [1e-4, 2e-4, 3e-4])
    np.testing.assert_allclose(measurements[1].table["torque"], [0, 1, 2])


def test_load_measurements_missing_file_names_it(tmp_path):
    (tmp_path / "study.toml").write_text(STUDY)
    write(tmp_path, EXT_BRACKETS, "ext1.csv")
    with pytest.raises(DataError, match=r"sub[/\\]tor\.csv: data file of \[\[test\]\] #2") as info:
        load_measurements(load_study(tmp_path))
    assert "study.toml" in str(info.value)


# --- section 7 and issue 12: bad input at the edge, exit 2 naming file and row/column ----------

BEND_OK = "deflection [mm],force [N]\n0,0\n0.1,0.5\n0.2,1.0\n0.3,1.5\n"


@pytest.mark.parametrize(("unit", "shown"), [("1/0", "1/0"), ("(N", "(N")])
def test_malformed_unit_is_a_data_error(tmp_path, unit, shown):
    path = write(tmp_path, "deflection,force\nmm," + unit + "\n0,0\n0.1,0.5\n0.2,1.0\n")
    with pytest.raises(
        DataError, match=where(path, row=2, column="force") + re.escape(f"unknown unit '{shown}'")
    ):
        read_table(path, "three_point_bend")


def test_cell_longer_than_csv_limit(tmp_path):
    path = write(tmp_path, BEND_OK + "0.4," + "1" * 200_000 + "\n")
    with pytest.raises(DataError, match=where(path, row=6)):
        read_table(path, "three_point_bend")


def test_header_cell_longer_than_csv_limit(tmp_path):
    path = write(tmp_path, "x" * 200_000 + "," + BEND_OK)
    with pytest.raises(DataError, match="^" + re.escape(str(path))):
        read_table(path, "three_point_bend")


def test_symlink_loop_directory_and_device(tmp_path):
    loop = tmp_path / "loop.csv"
    loop.symlink_to(loop)
    with pytest.raises(DataError, match=where(loop) + "cannot open file"):
        read_table(loop, "three_point_bend")
    with pytest.raises(DataError, match=where(tmp_path) + "is a folder"):
        read_table(tmp_path, "three_point_bend")
    with pytest.raises(DataError, match=re.escape("/dev/zero: not a regular file")):
        read_table("/dev/zero", "three_point_bend")


def test_symlink_loop_through_a_study(tmp_path):
    (tmp_path / "loop.csv").symlink_to(tmp_path / "loop.csv")
    toml = (
        '[[specimen]]\nid = "T1"\nouter_diameter = "2 mm"\n\n[[test]]\nkind = "torsion"\nspecimen = "T1"\n'
        'file = "loop.csv"\nlength = "60 mm"\n'
    )
    (tmp_path / "study.toml").write_text(toml)
    with pytest.raises(DataError, match="loop.csv"):
        load_measurements(load_study(tmp_path))


def test_huge_file_is_refused_with_its_size(tmp_path, monkeypatch):
    import matid.io.ingest.read as ingest

    monkeypatch.setattr(ingest, "MAX_BYTES", 100)
    path = write(tmp_path, BEND_OK * 10)
    with pytest.raises(DataError, match=where(path) + r"file is .* larger than"):
        read_table(path, "three_point_bend")


@pytest.mark.parametrize(
    ("text", "kind", "row", "column"),
    [
        ("time [s],force [N],elongation [mm]\n0,0,0\n1,1,1e308\n2,2,2\n", "extension", 3, "elongation"),
        ("twist_angle [deg],torque [N m]\n0,0\n1e300,1\n2,2\n", "torsion", 3, "twist_angle"),
        ("deflection [m],force [N]\n0,0\n0.1,1\n20,2\n", "three_point_bend", 4, "deflection"),
    ],
)
def test_values_beyond_physical_bound_name_row_and_column(tmp_path, text, kind, row, column):
    path = write(tmp_path, text)
    with pytest.raises(DataError, match=where(path, row=row, column=column) + ".*beyond the physical bound"):
        read_table(path, kind)


def test_all_loads_negative_suggest_negate(tmp_path):
    path = write(tmp_path, "deflection [mm],force [N]\n0,0.001\n0.1,-0.5\n0.2,-1.0\n0.3,-1.5\n")
    with pytest.raises(DataError, match=where(path, column="force") + r".*negate = \[\"force\"\]"):
        read_table(path, "three_point_bend")
    table = read_table(path, "three_point_bend", negate=["force"])
    np.testing.assert_allclose(table["force"], [-0.001, 0.5, 1.0, 1.5])


def test_preamble_without_hash_and_message_says_how_it_was_read(tmp_path):
    text = '"Sample ID:","T1"\nMTS793|BTW|ENG\nLoad,Crosshead\nN,mm\n0,0\n0.5,0.1\nx,0.2\n'
    path = write(tmp_path, text)
    pattern = (
        where(path, row=7, column="Load")
        + r"not a number: 'x' \(read as utf-8, ','-delimited, header row 3, units row 4\)"
    )
    with pytest.raises(DataError, match=pattern):
        read_table(path, "three_point_bend", columns={"force": "Load", "deflection": "Crosshead"})


def test_mapped_column_missing_names_it_and_the_nearest(tmp_path):
    path = write(tmp_path, "Load [N],Crosshead [mm]\n0,0\n0.5,0.1\n1,0.2\n")
    with pytest.raises(DataError, match=where(path, row=1, column="Crosshed") + ".*did you mean 'Crosshead"):
        read_table(path, "three_point_bend", columns={"force": "Load", "deflection": "Crosshed"})


def test_wrong_stated_encoding_says_so(tmp_path):
    path = write(tmp_path, "扭转角 [deg],扭矩 [N m]\n0,0\n1,1\n2,2\n", encoding="gbk")
    with pytest.raises(DataError, match=where(path) + "cannot be read as utf-8"):
        read_table(path, "torsion", encoding="utf-8")
    table = read_table(path, "torsion", encoding="gbk", columns={"twist_angle": "扭转角", "torque": "扭矩"})
    assert table.encoding == "gbk"


def test_machine_units_in_headers(tmp_path):
    text = "Angle (deg.),Torque (in-lb),Time [Sec]\n0,0,0\n10,1,1\n20,2,2\n"
    table = read_table(write(tmp_path, text), "torsion", columns={"twist_angle": "Angle"})
    np.testing.assert_allclose(table["torque"], [0, 0.1129848290276167, 0.2259696580552334])
    np.testing.assert_allclose(table["twist_angle"], np.deg2rad([0, 10, 20]))
    text = "deflection (µm),force (Nm?)\n0,0\n1,1\n2,2\n"
    with pytest.raises(DataError, match="column 'force': 'Nm\\?'"):
        read_table(write(tmp_path, text, "b.csv"), "three_point_bend")


def test_long_metadata_value_is_truncated(tmp_path):
    text = "# note: " + "y" * 2_000_000 + "\n" + BEND_OK
    table = read_table(write(tmp_path, text), "three_point_bend")
    assert len(table.metadata["note"]) < 2100 and table.metadata["note"].endswith("[... truncated]")


# --- single-spaced multi-word headers (issue 21, contract section 10) ----------------------------

#: MTS Series 793 MultiPurpose TestWare "plain" specimen data file (space-delimited; its first line
#: is MTS793|progName|language|version|iDelim (0: space)|decimal|...), as the 793 application manual
#: describes it; channel names "Ch 1 Displacement" hold single spaces like the gaps between columns.
MTS_PLAIN = Path(__file__).parent.parent / "corpus" / "mts793_plain_flexure.dat"


def test_mts_plain_single_space_header_is_resolved_by_the_units_row():
    mapping = {"deflection": "Ch 1 Displacement", "force": "Ch 1 Force"}
    table = read_table(MTS_PLAIN, "three_point_bend", columns=mapping)
    assert table.header_row == 4
    assert dict(table.written) == {"deflection": "Ch 1 Displacement", "force": "Ch 1 Force", "time": "Time"}
    assert dict(table.units) == {"deflection": "mm", "force": "kN", "time": "Sec"}
    # The slope by hand: last and first data rows of the file, split on whitespace, mm and kN to SI.
    rows = [line.split() for line in MTS_PLAIN.read_text().splitlines()[5:]]
    hand = (float(rows[-1][1]) - float(rows[0][1])) * 1e3 / ((float(rows[-1][0]) - float(rows[0][0])) * 1e-3)
    slope = np.polyfit(table["deflection"], table["force"], 1)[0]
    assert slope == pytest.approx(hand, rel=0.02)
    assert table.n_rows == len(rows) == 101


@pytest.mark.parametrize(
    ("header", "units", "names"),
    [
        ("Axial Force Axial Displacement Time", "N mm s", ["Axial Force", "Axial Displacement", "Time"]),
        ("Time Axial Force Crosshead", "s N mm", ["Time", "Axial Force", "Crosshead"]),
        ("Rotary Angle Rotary Torque", "deg N-m", ["Rotary Angle", "Rotary Torque"]),
    ],
)
def test_single_spaced_names_follow_the_quantity_of_their_unit(header, units, names):
    from matid.io.ingest.spaced import spaced_names

    assert spaced_names(header.split(), len(units.split()), units.split()) == names


def test_single_spaced_header_over_bracketed_units(tmp_path):
    text = "Time [s] Axial Force [N] Crosshead [mm]\n0 0 0\n1 1.5 0.1\n2 3.0 0.2\n"
    mapping = {"deflection": "Crosshead", "force": "Axial Force"}
    table = read_table(write(tmp_path, text, "b.txt"), "three_point_bend", columns=mapping)
    assert table.units["time"] == "s"
    np.testing.assert_allclose(table["force"], [0, 1.5, 3.0])
    np.testing.assert_allclose(table["deflection"], [0, 1e-4, 2e-4])


def test_single_spaced_header_that_cannot_be_grouped_is_refused_not_guessed(tmp_path):
    # Two unit-less 'Ch' channels: nothing tells which words belong to which name.
    text = "Ch A Ch B Extra Word\nmm mm mm\n0 0 0\n1 1 1\n2 2 2\n"
    path = write(tmp_path, text, "c.txt")
    with pytest.raises(DataError, match=where(path, row=1) + "header row 1 has 6 words"):
        read_table(path, "three_point_bend")


# --- long records: the numbers parsed by pandas' C engine after detection ---------------------------

_CELL = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e3, max_value=1e3)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    numbers=st.lists(st.tuples(_CELL, _CELL), min_size=3, max_size=30),
    style=st.sampled_from([(",", "."), (";", ","), ("\t", "."), ("\t", ","), (" ", ".")]),
    digits=st.sampled_from(["r", ".3f", ".17g", ".6e"]),
)
def test_numbers_are_the_doubles_python_reads_from_the_cells(tmp_path, numbers, style, digits):
    delimiter, decimal = style
    cells = [[repr(x) if digits == "r" else format(x, digits) for x in row] for row in numbers]
    lines = [delimiter.join(c.replace(".", decimal) for c in row) for row in cells]
    path = write(tmp_path, f"tip_angle [rad]{delimiter}torque [N m]\n" + "\n".join(lines) + "\n")
    expected = np.array([[float(c) for c in row] for row in cells])
    floors = [PHYSICAL_BOUND[q] / DYNAMIC_RANGE for q in ("angle", "torque")]
    vanishing = [n for n, col, f in zip(("tip_angle", "torque"), expected.T, floors, strict=True)
                 if 0 < np.abs(col).max() < f]  # fmt: skip
    if vanishing:  # a column of vanishing values is refused (matid.io.ingest.checks), naming it
        with pytest.raises(DataError, match=f"column '{vanishing[0]}.*largest magnitude"):
            read_table(path, "magnetic_bending")
        return
    table = read_table(path, "magnetic_bending")
    assert table["tip_angle"].tolist() == expected[:, 0].tolist()
    assert table["torque"].tolist() == expected[:, 1].tolist()


def test_blank_and_space_only_lines_keep_the_row_numbers_of_a_long_record(tmp_path):
    rows = [f"{k * 0.001:.3f},{k * 0.5:.1f},{k * 1e-4:.4f}" for k in range(20_000)]
    rows[7_000] = "   "
    rows[12_000] = ""
    rows[15_000] = ",,"
    rows[18_000] = "18.000,x,1.8000"
    path = write(tmp_path, "time [s],force [N],elongation [mm]\n" + "\n".join(rows) + "\n")
    with pytest.raises(DataError, match=where(path, row=18_002, column="force") + "not a number: 'x'"):
        read_table(path, "extension")
    rows[18_000] = "18.000,9000.0,1.8000"
    table = read_table(
        write(tmp_path, "time [s],force [N],elongation [mm]\n" + "\n".join(rows) + "\n"), "extension"
    )
    assert table.n_rows == 20_000 - 3
    assert table["force"][-1] == 19_999 * 0.5


def test_a_record_in_utf16_with_a_bom_is_read_from_the_byte_after_its_preamble(tmp_path):
    text = "Prüfung: T1 °C\nTime [s]\tForce [N]\tElongation [mm]\n" + "".join(
        f"{k}\t{k},5\t0,{k:03d}\n" for k in range(1, 50)
    )
    table = read_table(write(tmp_path, text, encoding="utf-16"), "extension")
    assert table.encoding == "utf-16" and table.n_rows == 49
    np.testing.assert_array_equal(table["force"], np.arange(1, 50) + 0.5)


def test_rows_of_unequal_length_are_parsed_again_and_checked_like_a_short_file(tmp_path):
    """pandas sizes a parse by its first row: a short first row or a trailing delimiter on some rows
    only are parsed again as wide as the widest row; a row with more cells than the header is named."""
    head = "time [s],force [N],strain [%]\n"
    table = read_table(write(tmp_path, head + "0,0,0\n1,1,1,\n2,2,2\n"), "extension")
    np.testing.assert_array_equal(table["force"], [0, 1, 2])
    path = write(tmp_path, head + "0,0\n1,1,1\n2,2,2\n", "short.csv")
    with pytest.raises(DataError, match=where(path, row=2) + "row has 2 cells, header has 3"):
        read_table(path, "extension")
    path = write(tmp_path, head + "0,0,0\n1,1,1,,,,\n2,2,2\n3,3,3,4\n", "wide.csv")
    with pytest.raises(DataError, match=where(path, row=5) + "row has 4 cells, header has 3"):
        read_table(path, "extension")


_HEADS = [("Time", "s"), ("Elapsed Time", "min"), ("Force", "kN"), ("Load", "N"), ("Displacement", "mm"),
          ("Crosshead", "mm"), ("Rotation", "deg"), ("Angle", "rad"), ("Torque", "N-m"),
          ("Strain", "%")]  # fmt: skip
_QUALIFIERS = ["", "Axial", "Ch 1", "Ch 2", "Rotary", "Specimen", "Cell"]


@given(
    st.lists(
        st.tuples(st.sampled_from(_QUALIFIERS), st.sampled_from(_HEADS)), min_size=2, max_size=5, unique=True
    )
)
def test_single_spaced_names_qualifier_then_head_noun_are_recovered(columns):
    """Names written as a qualifier and the noun of their quantity (how channel names read) over
    their units: the words are cut back into exactly those names."""
    from matid.io.ingest.spaced import spaced_names

    names = [f"{q} {head}".strip() for q, (head, _) in columns]
    units = [unit for _, (_, unit) in columns]
    words = " ".join(names).split()
    assert spaced_names(words, len(names), units) == names


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    numbers=st.lists(st.tuples(_CELL, _CELL), min_size=3, max_size=20),
    style=st.sampled_from([(",", "."), (";", ","), ("\t", "."), (" ", ".")]),
    where=st.tuples(st.integers(min_value=0), st.integers(min_value=0)),
)
def test_a_quote_that_never_closes_is_bad_input_naming_its_row(tmp_path, numbers, style, where):
    """A '"' put anywhere in a data row of a record opens a quoted cell that never closes: pandas'
    C parser then reads to the end of the file and raised ParserError (exit 3). Now the reader says
    which row opens it (exit 2); a quote the reader can read past (a quoted number) still reads."""
    delimiter, decimal = style
    lines = [delimiter.join(repr(x).replace(".", decimal) for x in row) for row in numbers]
    k = where[0] % len(lines)
    at = where[1] % (len(lines[k]) + 1)
    lines[k] = lines[k][:at] + '"' + lines[k][at:]
    path = write(tmp_path, f"tip_angle [rad]{delimiter}torque [N m]\n" + "\n".join(lines) + "\n")
    try:
        table = read_table(path, "magnetic_bending")
    except DataError as exc:  # any bad-input message (e.g. no header found on a short record) ...
        if "never closed" in str(exc):  # ... and the quote's names the line that holds it
            assert exc.row == k + 2, str(exc)
    else:
        assert len(table["tip_angle"]) == len(lines)


def test_an_unclosed_quote_names_the_row_that_opens_it(tmp_path):
    path = write(tmp_path, 'twist_angle [rad],torque [N m]\n0,0\n0.1,"0.5\n0.2,1.0\n0.3,1.5\n')
    message = r"a quote \(\"\) opens a cell and is never closed"
    with pytest.raises(DataError, match=where(path, row=3) + message):
        read_table(path, "torsion")


@pytest.mark.parametrize(
    ("name", "magic", "what"),
    [
        ("data.xlsx", b"PK\x03\x04\x14\x00\x06\x00", "a zip archive such as an .xlsx"),
        ("data.xls", b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1\x00\x00", "an .xls workbook"),
    ],
)
def test_a_binary_workbook_is_refused_as_one(tmp_path, name, magic, what):
    """A workbook is said to be one, with the way out (save the sheet as CSV), whatever its
    file name says; it is not read as Latin-1 text and refused for lacking a header row."""
    import zipfile

    path = tmp_path / name
    if magic.startswith(b"PK"):  # a real (minimal) workbook: a zip with the sheet's XML in it
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("xl/worksheets/sheet1.xml", "<worksheet/>")
        assert path.read_bytes().startswith(magic[:4])
    else:
        path.write_bytes(magic + b"\x00" * 500)
    renamed = tmp_path / "export.csv"  # the name does not decide
    renamed.write_bytes(path.read_bytes())
    for p in (path, renamed):
        with pytest.raises(DataError, match=where(p) + f"is {re.escape(what)}.*save the sheet as CSV"):
            read_table(p, "magnetic_bending")
