"""The corners of a study (issue 30, item 5): encodings, look-alike specimen ids, duplicate fixed values,
tiny data. Each was accepted or crashed (exit 3) before; now a DataError naming the key, or a status."""

from __future__ import annotations

import encodings
import encodings.aliases
import pkgutil
import re
import shutil
import unicodedata
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from matid.errors import DataError
from matid.io.cells import text_cell
from matid.io.ingest.read import read_table
from matid.io.study import load_study
from matid.toml import escaped
from tests import ROOT

EXAMPLE = ROOT / "matid" / "example"
TORSION = "torsion_T1_L60.csv"


def study(folder: Path, ids=("T1",), test_extra: str = "", fixed: str = "", data: str | None = None) -> Path:
    """A torsion study in ``folder``: one specimen per id, one torsion test each (the demo's data)."""
    folder.mkdir(parents=True, exist_ok=True)
    if data is None:
        shutil.copy(EXAMPLE / TORSION, folder / "t.csv")
    else:
        (folder / "t.csv").write_text(data, encoding="utf-8")
    text = '[study]\nname = "corners"\n'
    for sid in ids:
        text += f'[[specimen]]\nid = "{sid}"\nouter_diameter = "2.4 mm"\ninner_diameter = "1.6 mm"\n'
    for sid in ids:
        text += f'[[test]]\nkind = "torsion"\nspecimen = "{sid}"\nfile = "t.csv"\n'
        text += f'length = "60 mm"\n{test_extra}\n'
    (folder / "study.toml").write_text(text + fixed, encoding="utf-8")
    return folder


# -- encoding: text codecs only ------------------------------------------------------------------

#: Every codec name Python knows (module names and aliases).
CODEC_NAMES = sorted(
    set(encodings.aliases.aliases) | set(encodings.aliases.aliases.values())
    | {m.name for m in pkgutil.iter_modules(encodings.__path__)} - {"aliases"}
)  # fmt: skip


@pytest.mark.parametrize("name", ["rot13", "hex", "base64", "bz2", "uu", "zlib", "quopri"])
def test_a_bytes_codec_as_encoding_is_a_data_error_naming_the_key(tmp_path, name):
    """Before: exit 3 (LookupError: 'rot-13' is not a text encoding) when the file was read.
    After: a DataError at load naming the test, the key and the name."""
    folder = study(tmp_path, test_extra=f'encoding = "{name}"')
    with pytest.raises(DataError, match=rf"\[\[test\]\] #1: encoding '{name}' is not a text encoding"):
        load_study(folder)


@settings(max_examples=60, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(CODEC_NAMES))
@example(name="punycode")
@example(name="idna")
@example(name="undefined")
@example(name="unicode_escape")
@example(name="utf-7")
def test_any_codec_name_is_accepted_and_read_or_refused_as_data(tmp_path_factory, name):
    """Any codec name: refused at load (DataError), or accepted and the file read or refused as data;
    never another exception."""
    folder = study(tmp_path_factory.mktemp("enc"), test_extra=f'encoding = "{name}"')
    try:
        test = load_study(folder).tests[0]
    except DataError as exc:
        assert "encoding" in str(exc)
        return
    assert isinstance("x".encode(test.encoding), bytes) and b"".decode(test.encoding) == ""
    try:
        read_table(test.file, test.kind, encoding=test.encoding)
    except DataError:
        pass


# -- specimen ids: NFC, no look-alikes, no format characters -------------------------------------


def test_an_nfd_id_is_stored_as_nfc_and_its_tests_and_fixed_values_find_it(tmp_path):
    """Before: an id written in NFD in [[specimen]] and NFC in [[test]] was an 'unknown specimen'; two
    ids differing only by NFC/NFD were two specimens printed alike. After: every id is NFC."""
    nfd, nfc = unicodedata.normalize("NFD", "Tübe-1"), unicodedata.normalize("NFC", "Tübe-1")
    folder = study(tmp_path, ids=(nfd,))
    toml = folder / "study.toml"
    text = toml.read_text(encoding="utf-8").replace(f'specimen = "{nfd}"', f'specimen = "{nfc}"')
    text += f'[[fixed]]\nspecimen = "{nfd}"\nparameter = "E_b"\nvalue = "6.5e-5 N m^2"\n'
    toml.write_text(text, encoding="utf-8")
    loaded = load_study(folder)
    assert [s.id for s in loaded.specimens] == [nfc]
    assert loaded.tests[0].specimen == nfc and loaded.fixed[0].specimen == nfc


@pytest.mark.parametrize(
    "other",
    [
        unicodedata.normalize("NFD", "Tübe-1"),  # canonical equivalent
        "tübe-1",  # case
        "Tü\u200bbe-1",  # zero-width space
        "Tübe\u20111",  # a non-breaking hyphen: NFKC makes it U+2010, not "-": a character of its own
        "Ｔübe-1",  # fullwidth T: NFKC
    ],
    ids=["nfd", "case", "zero-width", "nb-hyphen", "fullwidth"],
)
def test_look_alike_ids_are_refused(tmp_path, request, other):
    """Before: ids equal but for NFC/NFD, case, a zero-width space or width were two specimens, printed
    alike in every table. After: a DataError naming both (an NFD id is the same NFC id: a duplicate; a
    zero-width space is refused as a format character; a non-breaking hyphen is a character of its
    own, not a look-alike by this rule, and is still accepted)."""
    folder = study(tmp_path, ids=("Tübe-1", other))
    if other == "Tübe\u20111":
        assert len(load_study(folder).specimens) == 2
        return
    why = {"nfd": "duplicate specimen id", "zero-width": "invisible format character U\\+200B"}
    with pytest.raises(DataError, match=why.get(request.node.callspec.id, "look alike")):
        load_study(folder)


@pytest.mark.parametrize("char", ["\u202e", "\u200b", "\u2066", "\u200f", "\ufeff", "\u00ad"])
def test_format_characters_in_an_id_are_refused(tmp_path, char):
    """Before: U+202E (right-to-left override) and other invisible format characters were accepted in an
    id and reached the terminal and the CSV raw. After: a DataError naming the character's code point."""
    folder = study(tmp_path, ids=(f"T{char}1",))
    with pytest.raises(DataError, match=f"U\\+{ord(char):04X}"):
        load_study(folder)


def _key(sid: str) -> str:
    """The look-alike key of the rule under test, computed here from its definition."""
    text = unicodedata.normalize("NFKC", sid).casefold()
    text = "".join(c for c in text if unicodedata.category(c) != "Cf")
    return unicodedata.normalize("NFKC", text)


ID_TEXT = st.text(
    st.characters(blacklist_categories=("Cs",), blacklist_characters='"\\'), min_size=1, max_size=12
)


@settings(max_examples=80, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ids=st.lists(ID_TEXT, min_size=1, max_size=3))
def test_any_ids_are_refused_or_stored_nfc_distinct_and_visible(tmp_path_factory, ids):
    """Any ids: a DataError, or specimens whose ids are NFC, free of format and control characters,
    and pairwise distinct under case folding, NFKC and removal of format characters."""
    folder = study(tmp_path_factory.mktemp("ids"), ids=tuple(ids))
    try:
        loaded = load_study(folder)
    except DataError:
        return
    got = [s.id for s in loaded.specimens]
    for sid in got:
        assert unicodedata.is_normalized("NFC", sid)
        assert not any(unicodedata.category(c) in ("Cf", "Cc") for c in sid)
    assert len({_key(s) for s in got}) == len(got)


@settings(max_examples=200)
@given(text=st.text())
def test_escaped_text_has_no_bidi_control(text):
    """Every text matid prints or writes into a cell: no bidi control (a U+202E in a file name or a note
    would reorder the terminal line or the CSV row), no control character."""
    for shown in (escaped(text), text_cell(text)):
        assert not re.search(r"[\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]", shown)
        assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]", shown)


def test_a_bidi_control_is_escaped_on_the_terminal_and_in_the_csv():
    """Before: U+202E went raw to the terminal and the CSV. After: written as \\u202e."""
    assert escaped("note \u202eabc") == "note \\u202eabc"
    assert text_cell("\u2066x") == "\\u2066x"


# -- [[fixed]]: one value per specimen and parameter ---------------------------------------------

FIXED = '[[fixed]]\nspecimen = "T1"\nparameter = "E_b"\nvalue = "{}"\n'


def test_two_fixed_values_for_one_parameter_are_refused(tmp_path):
    """Before: two [[fixed]] E_b for T1: the first won silently. After: a DataError naming both entries."""
    folder = study(tmp_path, fixed=FIXED.format("6.5e-5 N m^2") + FIXED.format("7e-5 N m^2"))
    with pytest.raises(DataError, match=r"\[\[fixed\]\] #2: .*E_b of specimen T1 .* \[\[fixed\]\] #1"):
        load_study(folder)


def test_a_fixed_value_per_parameter_is_still_accepted(tmp_path):
    fixed = FIXED.format("6.5e-5 N m^2") + FIXED.replace("E_b", "E_e").format("120 N")
    assert len(load_study(study(tmp_path, fixed=fixed)).fixed) == 2


# -- tiny data: refused as data, never a crash ---------------------------------------------------


def _scaled(column: int, scale: float) -> str:
    lines = (EXAMPLE / TORSION).read_text().splitlines()
    out = []
    for line in lines:
        cells = line.split(",")
        try:
            cells[column] = repr(float(cells[column]) * scale)
        except (ValueError, IndexError):
            pass
        out.append(",".join(cells))
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("column", [0, 1], ids=["twist_angle", "torque"])
def test_a_column_of_vanishing_values_is_a_data_error_naming_it(tmp_path, column):
    """Before: torsion angles scaled by 1e-300 gave exit 3 (ZeroDivisionError), torques by 1e-300 an
    'identified' not-identifiable result. After: a DataError naming the file and the column."""
    test = load_study(study(tmp_path, data=_scaled(column, 1e-300))).tests[0]
    name = ("twist_angle", "torque")[column]
    with pytest.raises(DataError, match=rf"column '{name}.*': .*largest magnitude .* below"):
        read_table(test.file, test.kind)


def test_a_small_but_measurable_column_is_read(tmp_path):
    """Torques of ~1e-9 N m (a micro-scale rig) stay data: the floor is far below any instrument."""
    test = load_study(study(tmp_path, data=_scaled(1, 1e-6))).tests[0]
    assert read_table(test.file, test.kind).columns["torque"].max() > 0


# -- tiny set-up values: the data columns' floor -------------------------------------------------


@pytest.mark.parametrize(("key", "value"), [("length", "1e-300 mm"), ("length", "5e-33 m")])
def test_a_set_up_value_below_the_floor_of_its_kind_is_refused_naming_the_key(tmp_path, key, value):
    """A nonzero value below PHYSICAL_BOUND / DYNAMIC_RANGE (the floor of a data column) is a unit
    mistake. Found by the study fuzz of 2026-11-28: magnet_moment x 1e-300 made the computed torque
    ~1e-304 N m, whose weights overflowed (exit 3: lmfit's NaN ValueError)."""
    folder = study(tmp_path)
    toml = folder / "study.toml"
    text = toml.read_text(encoding="utf-8").replace('length = "60 mm"', f'{key} = "{value}"')
    toml.write_text(text, encoding="utf-8")
    said = rf"\[\[test\]\] #1: {key} = '{value}' is .* below 1e-29, the smallest length"
    with pytest.raises(DataError, match=said):
        load_study(folder)


def test_a_tiny_magnet_moment_is_exit_2_not_an_internal_error(tmp_path):
    from matid.app.cli import main

    folder = tmp_path / "demo"
    shutil.copytree(ROOT / "matid" / "example", folder, ignore=shutil.ignore_patterns("*.py", "__pycache__"))
    text = (folder / "study.toml").read_text(encoding="utf-8").replace('"0.0125 A m^2"', '"1.25e-302 A m^2"')
    (folder / "study.toml").write_text(text, encoding="utf-8")
    assert main(["fit", str(folder), "--out", str(tmp_path / "out"), "--quiet"]) == 2
