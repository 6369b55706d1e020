"""The corners of a study (issue 30, item 5): encodings, look-alike specimen ids, duplicate fixed values,
tiny data. Each was accepted or crashed (exit 3) before; now a DataError naming the key, or a status."""

from __future__ import annotations

import encodings
import encodings.aliases
import pkgutil
import shutil
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from matid.errors import DataError
from matid.io.ingest.read import read_table
from matid.io.study import load_study
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
