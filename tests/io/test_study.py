"""Tests of matid.io.study: loading study.toml (data-contract section 1) and its bad inputs."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from matid.errors import DataError
from matid.io.study import load_study

HEAD = """
[study]
name = "Pebax 40D tube, lot 2611"
temperature = "37 degC"

[[specimen]]
id = "T1"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"

[[specimen]]
id = "T2"
outer_diameter = 0.003
"""

TESTS = """
[[test]]
kind = "extension"
specimen = "T1"
file = "extension_T1_r1.csv"
gauge_length = "50 mm"

[[test]]
kind = "magnetic_bending"
specimen = "T1"
file = "data/bending_T1_L30.csv"
free_length = "3 cm"
magnet_moment = "12.5 emu"
exclude = true
note = "magnet slipped"

[[test]]
kind = "torsion"
specimen = "T2"
file = "torsion_T2_L60.csv"
length = "60 mm"

[[test]]
kind = "three_point_bend"
specimen = "T1"
file = "3pb_T1_S10.csv"
span = "10 mm"
specimen_length = "30 mm"
support_radius = "2 mm"
nose_radius = "2 mm"
"""

FIXED = """
[[fixed]]
specimen = "T1"
parameter = "E_e"
value = "120 N"

[[fixed]]
specimen = "T2"
parameter = "E_b"
value = "65000 dyn cm^2"
"""


def write_study(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "study.toml"
    path.write_text(text, encoding="utf-8")
    return path


def expect(path: Path, message: str):
    """pytest.raises for a DataError naming ``path`` and matching ``message``."""
    return pytest.raises(DataError, match="^" + re.escape(str(path)) + ": .*" + message)


def test_load_study_from_folder_or_file(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS + FIXED)
    for where in (tmp_path, path, str(path)):
        study = load_study(where)
        assert study.source == path
        assert study.name == "Pebax 40D tube, lot 2611"
        assert study.temperature == "37 degC"
        assert [s.id for s in study.specimens] == ["T1", "T2"]
        assert [t.kind for t in study.tests] == [
            "extension",
            "magnetic_bending",
            "torsion",
            "three_point_bend",
        ]


def test_quantities_in_si_and_files_resolved_against_toml_folder(tmp_path):
    study = load_study(write_study(tmp_path, HEAD + TESTS + FIXED))
    t1 = study.specimen("T1")
    assert t1.outer_diameter == pytest.approx(2.4e-3)
    assert t1.inner_diameter == pytest.approx(1.6e-3)
    assert study.specimen("T2").inner_diameter == 0.0
    assert study.specimen("T2").outer_diameter == pytest.approx(3e-3)
    ext, mag, tor, bend = study.tests
    assert ext.file == (tmp_path / "extension_T1_r1.csv").resolve()
    assert mag.file == (tmp_path / "data" / "bending_T1_L30.csv").resolve()
    assert ext.params["gauge_length"] == pytest.approx(0.05)
    assert mag.params["free_length"] == pytest.approx(0.03)
    assert mag.params["magnet_moment"] == pytest.approx(0.0125)
    assert mag.exclude is True and mag.note == "magnet slipped"
    assert ext.exclude is False
    assert tor.params["length"] == pytest.approx(0.06)
    assert bend.params["span"] == pytest.approx(0.01)
    assert study.fixed_value("T1", "E_e") == pytest.approx(120.0)
    assert study.fixed_value("T2", "E_b") == pytest.approx(6.5e-5)
    assert study.fixed_value("T1", "E_b") is None
    assert [t.kind for t in study.tests_of("magnetic_bending", "T1")] == []
    assert len(study.tests_of("magnetic_bending", "T1", included=False)) == 1


def test_missing_study_toml(tmp_path):
    with expect(tmp_path / "study.toml", "study file not found"):
        load_study(tmp_path)


def test_bad_toml(tmp_path):
    path = write_study(tmp_path, HEAD + "[[test]\nkind = 'extension'\n")
    with expect(path, "not valid TOML"):
        load_study(path)


def test_unknown_test_kind(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS.replace('"torsion"', '"twisting"'))
    with expect(path, r"\[\[test\]\] #3: kind must be one of .*'twisting'"):
        load_study(path)


def test_unknown_specimen_in_test(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS.replace('specimen = "T2"', 'specimen = "T9"'))
    with expect(path, r"\[\[test\]\] #3: unknown specimen 'T9'"):
        load_study(path)


def test_unknown_specimen_in_fixed(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS + FIXED.replace('"T2"', '"T3"'))
    with expect(path, r"\[\[fixed\]\] #2: unknown specimen 'T3'"):
        load_study(path)


def test_unknown_parameter_in_fixed(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS + FIXED.replace('"E_e"', '"E_x"'))
    with expect(path, r"\[\[fixed\]\] #1: unknown parameter 'E_x'"):
        load_study(path)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('"50 mm"', '"50 N"', "gauge_length: 'N' is not a unit of length"),
        ('"50 mm"', '"50 parsecz"', "gauge_length: unknown unit 'parsecz'"),
        ('"50 mm"', '"fifty mm"', "gauge_length: cannot read a quantity from 'fifty mm'"),
    ],
)
def test_bad_unit_in_quantity(tmp_path, old, new, message):
    path = write_study(tmp_path, HEAD + TESTS.replace(old, new))
    with expect(path, r"\[\[test\]\] #1: " + message):
        load_study(path)


def test_bad_unit_in_specimen(tmp_path):
    path = write_study(tmp_path, HEAD.replace('"2.4 mm"', '"2.4 kg"') + TESTS)
    with expect(path, "specimen T1: outer_diameter: 'kg' is not a unit of length"):
        load_study(path)


def test_missing_required_key(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS.replace('span = "10 mm"\n', ""))
    with expect(path, r"\[\[test\]\] #4: missing 'span'"):
        load_study(path)


def test_missing_file_key(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS.replace('file = "torsion_T2_L60.csv"\n', ""))
    with expect(path, r"\[\[test\]\] #3: missing 'file'"):
        load_study(path)


@pytest.mark.parametrize("inner", ['"2.4 mm"', '"3 mm"'])
def test_outer_not_above_inner_diameter(tmp_path, inner):
    path = write_study(tmp_path, HEAD.replace('"1.6 mm"', inner) + TESTS)
    with expect(path, "specimen T1: need outer_diameter > inner_diameter"):
        load_study(path)


def test_duplicate_specimen_ids(tmp_path):
    path = write_study(tmp_path, HEAD.replace('id = "T2"', 'id = "T1"') + TESTS)
    with expect(path, "duplicate specimen id 'T1'"):
        load_study(path)


def test_non_positive_test_length(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS.replace('"60 mm"', '"0 mm"'))
    with expect(path, r"\[\[test\]\] #3: torsion test needs a positive length"):
        load_study(path)


def test_no_tests(tmp_path):
    path = write_study(tmp_path, HEAD)
    with expect(path, r"no \[\[test\]\] entries"):
        load_study(path)


# --- section 7: unknown keys, bare numbers, booleans, new test keys -----------------


BEND = TESTS.split("[[test]]")[4]  # the three_point_bend entry


def with_test_keys(extra: str, entry: str = BEND) -> str:
    """HEAD and one [[test]] entry with ``extra`` toml lines appended."""
    return HEAD + "\n[[test]]" + entry.rstrip() + "\n" + extra + "\n"


@pytest.mark.parametrize(
    ("extra", "key", "hint"),
    [
        ("exlude = true", "exlude", "exclude"),
        ("nots = 'x'", "nots", "note"),
        ("colums = { force = 'Load' }", "colums", "columns"),
        ("negat = ['force']", "negat", "negate"),
    ],
)
def test_unknown_test_key_names_it_and_the_nearest(tmp_path, extra, key, hint):
    path = write_study(tmp_path, with_test_keys(extra))
    with expect(path, rf"\[\[test\]\] #1: unknown key `{key}`.*did you mean `{hint}`\?"):
        load_study(path)


def test_key_of_another_kind_says_so(tmp_path):
    path = write_study(tmp_path, with_test_keys('gauge_length = "50 mm"'))
    with expect(path, "unknown key `gauge_length`, a key of extension tests, not of three_point_bend"):
        load_study(path)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            'temperature = "37 degC"',
            'temprature = "37 degC"',
            r"\[study\]: unknown key `temprature`.*`temperature`",
        ),
        ('id = "T2"', 'id = "T2"\ninner_diam = "1 mm"', r"\[\[specimen\]\] #2: unknown key `inner_diam`"),
        ("[study]", "[studdy]\n[study]", r"the top level: unknown key `studdy`.*`study`"),
    ],
)
def test_unknown_keys_elsewhere(tmp_path, old, new, message):
    path = write_study(tmp_path, HEAD.replace(old, new) + TESTS)
    with expect(path, message):
        load_study(path)


def test_unknown_key_in_fixed(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS + FIXED.replace('value = "120 N"', 'valeu = "120 N"'))
    with expect(path, r"\[\[fixed\]\] #1: unknown key `valeu`.*`value`"):
        load_study(path)


@pytest.mark.parametrize("value", ['"false"', "0", '"yes"'])
def test_exclude_must_be_a_real_boolean(tmp_path, value):
    path = write_study(tmp_path, with_test_keys(f"exclude = {value}"))
    with expect(path, "exclude must be a boolean"):
        load_study(path)


def test_bare_number_accepted_as_si_only_when_plausible(tmp_path):
    ok = write_study(tmp_path, with_test_keys("").replace('span = "10 mm"', "span = 0.01"))
    assert load_study(ok).tests[0].params["span"] == 0.01
    bad = write_study(tmp_path, with_test_keys("").replace('span = "10 mm"', "span = 10"))
    with expect(bad, r"span = 10 is a bare number, read as SI .* not plausible .* span = \"10 mm\""):
        load_study(bad)


def test_bare_fixed_stiffness_implausible(tmp_path):
    path = write_study(tmp_path, HEAD + TESTS + FIXED.replace('"65000 dyn cm^2"', "65000"))
    with expect(path, r"value = 65000 is a bare number.*N mm\^2"):
        load_study(path)


@pytest.mark.parametrize(
    ("quantity", "message"),
    [
        ('"60 1/0"', "unknown unit '1/0'"),
        ('"10 (mm"', r"unknown unit '\(mm'"),
        ('"1e300 mm"', "physical bound"),
    ],
)
def test_malformed_or_absurd_quantities(tmp_path, quantity, message):
    path = write_study(tmp_path, with_test_keys("").replace('"10 mm"', quantity))
    with expect(path, "span.*" + message):
        load_study(path)


def test_section7_keys_parsed_into_the_test(tmp_path):
    extra = """columns = { deflection = "Crosshead ", force = "Load" }
units = { force = "kN", deflection = "in" }
negate = ["force"]
window = { deflection = ["0.05 mm", "1.5 mm"] }
encoding = "GBK"
deflection_at = "centreline"
"""
    test = load_study(write_study(tmp_path, with_test_keys(extra))).tests[0]
    assert dict(test.columns) == {"deflection": "Crosshead ", "force": "Load"}
    assert dict(test.units) == {"force": "kN", "deflection": "in"}
    assert test.negate == ("force",)
    assert test.window["deflection"] == pytest.approx((5e-5, 1.5e-3))
    assert test.encoding == "gbk"
    assert test.deflection_at == "centreline"


def test_poisson_ratio(tmp_path):
    study = load_study(
        write_study(tmp_path, HEAD.replace('id = "T2"', 'id = "T2"\npoisson_ratio = 0.45') + TESTS)
    )
    assert study.specimen("T2").poisson_ratio == 0.45
    assert study.specimen("T1").poisson_ratio is None
    bad = write_study(tmp_path, HEAD.replace('id = "T2"', 'id = "T2"\npoisson_ratio = 0.7') + TESTS)
    with expect(bad, r"poisson_ratio must be a number in \(-1, 0.5\]"):
        load_study(bad)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('window = { time = ["0 s", "1 s"] }', "window: `time` is not a column of three_point_bend"),
        ('window = { deflection = ["2 mm", "1 mm"] }', "window.deflection needs low < high"),
        ('window = { deflection = ["1 N", "2 N"] }', "window.deflection: 'N' is not a unit of length"),
        ('window = { deflection = "1 mm" }', r"window.deflection must be \[\"low\", \"high\"\]"),
        ('units = { force = "mm" }', "units.force: 'mm' is not a unit of force"),
        ('units = { forse = "N" }', "did you mean `force`"),
        ('negate = ["torque"]', "negate: `torque` is not a column of three_point_bend"),
        ('negate = "force"', "negate must be a list"),
        ('columns = { force = "" }', "columns.force must be the file's header text"),
        ('encoding = "klingon-8"', "unknown encoding 'klingon-8'"),
        ('deflection_at = "tip"', "deflection_at must be 'nose' or 'centreline'"),
    ],
)
def test_section7_keys_rejected(tmp_path, extra, message):
    path = write_study(tmp_path, with_test_keys(extra))
    with expect(path, message):
        load_study(path)


def test_long_note_is_truncated_and_marked(tmp_path):
    study = load_study(write_study(tmp_path, with_test_keys(f'note = "{"x" * 1_000_000}"')))
    assert len(study.tests[0].note) < 2100
    assert study.tests[0].note.endswith("[... truncated]")


@pytest.mark.parametrize("value", ['["torsion"]', '{ v = "torsion" }', "[1, 2]", "3"])
def test_kind_of_the_wrong_type_is_a_data_error(tmp_path, value):
    # Found by the fuzz run: a list or table as kind escaped as TypeError (exit 3).
    import shutil

    import matid.example as example

    src = Path(example.__file__).parent
    shutil.copytree(src, tmp_path / "s")
    toml = tmp_path / "s" / "study.toml"
    text = toml.read_text(encoding="utf-8")
    toml.write_text(text.replace('kind = "torsion"', f"kind = {value}", 1), encoding="utf-8")
    with pytest.raises(DataError, match="kind must be one of"):
        load_study(toml)


# --- sections: rectangle and slit tube (contract section 10) ---------------------------------------

RECTANGLE = 'id = "T2"\nwidth = "10 mm"\nheight = "4 mm"\npoisson_ratio = 0.35'
SLIT = 'id = "T2"\nouter_diameter = "2.4 mm"\ninner_diameter = "1.6 mm"\nslit = true'


def test_rectangular_and_slit_sections(tmp_path):
    for text, shape in ((RECTANGLE, "rectangle"), (SLIT, "slit")):
        head = HEAD.replace('id = "T2"\nouter_diameter = 0.003', text)
        spec = load_study(write_study(tmp_path, head + TESTS)).specimen("T2")
        assert spec.section.shape == shape
    assert spec.slit and spec.section.J < spec.section.A**2  # an open wall is weak in torsion
    rect = load_study(
        write_study(tmp_path, HEAD.replace('id = "T2"\nouter_diameter = 0.003', RECTANGLE) + TESTS)
    )
    section = rect.specimen("T2").section
    assert (section.width, section.height) == pytest.approx((10e-3, 4e-3))
    assert section.I == pytest.approx(10e-3 * 4e-3**3 / 12)
    assert load_study(write_study(tmp_path, HEAD + TESTS)).specimen("T1").section.shape == "tube"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            'id = "T2"\nwidth = "10 mm"',
            "needs both width and height and no diameters; it gives width without",
        ),
        (
            'id = "T2"\nwidth = "1 mm"\nheight = "1 mm"\nouter_diameter = "1 mm"',
            "it also gives outer_diameter",
        ),
        ('id = "T2"\nouter_diameter = "2 mm"\nslit = true', "a slit \\(open\\) tube needs inner_diameter"),
        (
            'id = "T2"\nouter_diameter = "2 mm"\ninner_diameter = "1 mm"\nslit = "yes"',
            "slit must be a boolean",
        ),
        ('id = "T2"\nwidth = "0 mm"\nheight = "1 mm"', "width > 0 and height > 0"),
        ('id = "T2"\nwidth = "1 kg"\nheight = "1 mm"', "width: 'kg' is not a unit of length"),
    ],
)
def test_bad_sections_name_the_specimen_and_the_key(tmp_path, text, message):
    path = write_study(tmp_path, HEAD.replace('id = "T2"\nouter_diameter = 0.003', text) + TESTS)
    with expect(path, "specimen T2: .*" + message):
        load_study(path)


def test_columns_named_by_position(tmp_path):
    """columns = { force = 3 }: the file's third column (1 = the first), for a file without a header."""
    path = write_study(tmp_path, with_test_keys("columns = { deflection = 1, force = 3 }"))
    test = load_study(path).tests[0]
    assert dict(test.columns) == {"deflection": 1, "force": 3}


@pytest.mark.parametrize("value", ["0", "-2", "true", "1.5", "[3]"])
def test_a_column_position_that_is_no_column_number_is_refused(tmp_path, value):
    path = write_study(tmp_path, with_test_keys(f"columns = {{ force = {value} }}"))
    with expect(path, "columns.force must be the file's header text or a column number"):
        load_study(path)
