"""Real test-machine export styles read as the machines wrote them (data-contract section 7).

``tests/corpus`` holds one small file per style, written after each machine's
documented export layout: Instron Bluehill raw-data CSV, ZwickRoell testXpert
(``;``, decimal comma, cp1252), MTS TestSuite (whitespace-aligned, banner), a
LabVIEW torque logger, Shimadzu Trapezium, a GBK Chinese header and a UTF-16
file. Each is read against the numbers written into it. A hypothesis property
test writes random valid files in random styles and reads them back exactly.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from matid.io.ingest.read import read_table
from matid.units import si_factor
from tests import ROOT, TESTS

CORPUS = TESTS / "corpus"
DEG = math.pi / 180
IN_LB = 0.0254 * 4.4482216152605  # pound-force inch in N m
KGF = 9.80665

#: file -> (kind, read_table keywords, expected metadata items, {column: SI values})
CASES = {
    "bluehill_tension.csv": (
        "extension",
        {"columns": {"elongation": "Extension", "force": "Load"}},
        {"Sample ID": "T1-r1", "Method": "Tension catheter.im_tens"},
        {
            "time": [0.0, 0.5, 1.0, 1.5, 2.0],
            "elongation": [0.0, 2.5e-5, 5.0e-5, 7.5e-5, 1.0e-4],
            "force": [0.01234, 0.71, 1.425, 2.13, 2.841],
        },
    ),
    "testxpert_zwick.TXT": (
        "extension",
        {"columns": {"time": "Prüfzeit", "elongation": "Standardweg", "force": "Standardkraft"}},
        {"Prüfer": "Müller", "Prüfvorschrift": "ISO 527-1"},
        {
            "time": [0.0, 0.25, 0.5, 0.75, 1.0],
            "elongation": [0.0, 1.25e-5, 2.5e-5, 3.75e-5, 5.0e-5],
            "force": [0.015, 0.357, 0.712, 1.068, 1.42],
        },
    ),
    "mts_bend.txt": (
        "three_point_bend",
        {"columns": {"deflection": "Crosshead", "force": "Axial Force"}, "negate": ["deflection", "force"]},
        {"Station Name": "Bionix 370.02", "Specimen": "T1"},
        {
            "deflection": [0.0, 1e-5, 2e-5, 3e-5, 4e-5],
            "force": [0.0001, 0.0502, 0.1003, 0.1498, 0.2001],
            "time": [0.0, 0.5, 1.0, 1.5, 2.0],
        },
    ),
    "labview_torsion.lvm": (
        "torsion",
        {"columns": {"twist_angle": "Angle", "torque": "Torque"}},
        {},
        {
            "twist_angle": [0.0, 5 * DEG, 10 * DEG, 15 * DEG, 20 * DEG],
            "torque": [0.0, 0.0012 * IN_LB, 0.0024 * IN_LB, 0.00361 * IN_LB, 0.00479 * IN_LB],
            "time": [0.0, 1.0, 2.0, 3.0, 4.0],
        },
    ),
    "shimadzu_trapezium.csv": (
        "three_point_bend",
        {"columns": {"deflection": "Stroke"}},
        {"Test Name": "3pb T2", "Batch": "1", "Speed": "0.02 mm/sec"},
        {
            "deflection": [0.0, 2e-5, 4e-5, 6e-5, 8e-5],
            "force": [0.0, 0.0051 * KGF, 0.0102 * KGF, 0.0153 * KGF, 0.0204 * KGF],
        },
    ),
    "gbk_torsion.csv": (
        "torsion",
        {"columns": {"twist_angle": "扭转角", "torque": "扭矩"}},
        {"试验编号": "T2-L60", "操作员": "王工"},
        {
            "twist_angle": [0.0, 3 * DEG, 6 * DEG, 9 * DEG, 12 * DEG],
            "torque": [0.0, 5.0e-5, 1.01e-4, 1.49e-4, 2.0e-4],
        },
    ),
    "utf16_bending.txt": (
        "magnetic_bending",
        {},
        {},
        {
            "tip_angle": [0.1 * DEG, 2.3 * DEG, 4.6 * DEG, 6.8 * DEG, 9.1 * DEG],
            "field": [0.0, 0.005, 0.010, 0.015, 0.020],
            "field_angle": [90 * DEG] * 5,
        },
    ),
}

ENCODINGS = {
    "bluehill_tension.csv": "utf-8",
    "testxpert_zwick.TXT": "cp1252",
    "gbk_torsion.csv": "gb18030",
    "utf16_bending.txt": "utf-16",
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_corpus_file_reads_to_the_numbers_written_in_it(name):
    kind, keywords, metadata, expected = CASES[name]
    table = read_table(CORPUS / name, kind, **keywords)
    for column, values in expected.items():
        np.testing.assert_allclose(table[column], values, rtol=1e-12, atol=1e-15, err_msg=column)
    for key, value in metadata.items():
        assert table.metadata[key] == value
    if name in ENCODINGS:
        assert table.encoding == ENCODINGS[name]


def test_free_text_preamble_lines_are_kept_as_text():
    table = read_table(CORPUS / "mts_bend.txt", "three_point_bend", **CASES["mts_bend.txt"][1])
    assert table.preamble == ("MTS793|BTW|ENG|NOR|1|2|SPA|NOR|NOR|1|2|1|",)
    assert table.delimiter == " " and table.header_row == 6
    lab = read_table(CORPUS / "labview_torsion.lvm", "torsion", **CASES["labview_torsion.lvm"][1])
    # "text, more text" is a key,value line by the contract's rules
    assert lab.metadata["Torque sensor log"] == "channel 0 (TQ-201 serial 44817)"
    assert lab.metadata["free text"].startswith("tube clamped")


def test_zwick_text_column_is_kept_out_not_in_the_way():
    _, keywords, _, _ = CASES["testxpert_zwick.TXT"]
    table = read_table(CORPUS / "testxpert_zwick.TXT", "extension", **keywords)
    assert "bemerkung" not in table  # a remark column of text: not numbers, left out
    assert table.delimiter == ";"


# --- property: random valid files in random styles read back exactly ----------------

STYLES = st.fixed_dictionaries(
    {
        "delimiter": st.sampled_from([",", ";", "\t", " "]),
        "encoding": st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "cp1252", "gbk"]),
        "newline": st.sampled_from(["\n", "\r\n"]),
        "units": st.sampled_from(["brackets", "parentheses", "row"]),
        "quote": st.booleans(),
        "trailing": st.booleans(),
        "preamble": st.sampled_from(["none", "hash", "colon", "pairs", "banner"]),
        "blank_after_header": st.booleans(),
    }
)
FINITE = st.floats(min_value=1e-3, max_value=100.0, allow_nan=False, allow_infinity=False)
UNITS = {"time": ["s", "ms", "Sec"], "deflection": ["mm", "µm", "in"], "force": ["N", "mN", "kgf", "lbf"]}


def _render(value: float, decimal_comma: bool) -> str:
    text = repr(value)
    return text.replace(".", ",") if decimal_comma else text


def _write_style(tmp_path: Path, style: dict, units: dict, rows: list[list[float]]) -> Path:
    d = style["delimiter"]
    if d == " " and style["quote"]:
        style = {**style, "quote": False}
    comma = d != "," and style["quote"] is False and d != " "
    q = (lambda s: f'"{s}"') if style["quote"] else (lambda s: s)
    sep = "   " if d == " " else d
    tail = d if style["trailing"] and d != " " else ""
    names = ["time", "deflection", "force"]
    lines = {
        "none": [],
        "hash": ["# operator: A. Bell", "# rig: bench 2"],
        "colon": ["Operator: A. Bell", "Rig: bench 2"],
        "pairs": [f"{q('Operator:')}{',' if d == ' ' else d}{q('A. Bell')}"],
        "banner": ["MTS793|BTW|ENG|NOR|1|2|"],
    }[style["preamble"]]
    if style["units"] == "row":
        lines.append(sep.join(q(n) for n in names) + tail)
        lines.append(sep.join(q(units[n]) for n in names) + tail)
    else:
        left, right = ("[", "]") if style["units"] == "brackets" else ("(", ")")
        header = [f"{n}{' ' if d != ' ' else '_'}{left}{units[n]}{right}" for n in names]
        lines.append(sep.join(q(h) for h in header) + tail)
    if style["blank_after_header"]:
        lines.append("")
    for row in rows:
        lines.append(sep.join(q(_render(v, comma)) for v in row) + tail)
    path = tmp_path / "random.csv"
    path.write_bytes((style["newline"].join(lines) + style["newline"]).encode(style["encoding"]))
    return path


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    style=STYLES,
    units=st.fixed_dictionaries({k: st.sampled_from(v) for k, v in UNITS.items()}),
    data=st.lists(st.tuples(FINITE, FINITE, FINITE), min_size=3, max_size=12),
)
def test_random_styles_read_back_exactly(tmp_path, style, units, data):
    # deflection rising: one loading branch
    rows = sorted(([t, d, f] for t, d, f in data), key=lambda r: r[1])
    if style["encoding"] == "gbk" and units["deflection"] not in ("mm", "in"):
        units = {**units, "deflection": "um"}  # GBK has no micro sign
    path = _write_style(tmp_path, style, units, rows)
    table = read_table(path, "three_point_bend")
    for k, (name, quantity) in enumerate([("time", "time"), ("deflection", "length"), ("force", "force")]):
        expected = np.array([r[k] for r in rows]) * si_factor(units[name], quantity)
        np.testing.assert_array_equal(table[name], expected, err_msg=f"{name} in {style}")


# --- acceptance: the demo study rewritten in machine styles fits as well ----------------

EXAMPLE = ROOT / "matid" / "example"

#: Per style: matid column -> (header text, unit written), file suffix, encoding,
#: delimiter, decimal comma, quoted, preamble lines, units in a row (else "name (unit)"),
#: columns negated in the file.
STYLE_SPECS = {
    "bluehill": dict(
        names={
            "time": ("Time", "s"),
            "elongation": ("Extension", "mm"),
            "strain": ("Tensile strain", "%"),
            "force": ("Load", "N"),
        },
        encoding="utf-8",
        delimiter=",",
        comma=False,
        quote=True,
        newline="\r\n",
        units_row=True,
        preamble=['"Sample ID:","{stem}"', '"Method:","catheter tension.im_tens"', ""],
        negate=(),
    ),
    "testxpert": dict(
        names={
            "time": ("Prüfzeit", "s"),
            "elongation": ("Standardweg", "µm"),
            "strain": ("Dehnung", "%"),
            "force": ("Standardkraft", "mN"),
        },
        encoding="cp1252",
        delimiter=";",
        comma=True,
        quote=False,
        newline="\r\n",
        units_row=True,
        preamble=["Prüfer: Müller", "Prüfvorschrift;ISO 527-1"],
        negate=(),
    ),
    "utf16": dict(
        names={
            "tip_angle": ("Tip angle", "deg"),
            "field": ("Field", "mT"),
            "field_angle": ("Field angle", "°"),
            "torque": ("Moment", "N·m"),
        },
        encoding="utf-16",
        delimiter="\t",
        comma=False,
        quote=False,
        newline="\r\n",
        units_row=True,
        preamble=[],
        negate=(),
    ),
    "labview": dict(
        names={"twist_angle": ("Angle", "deg."), "torque": ("Torque", "in-lb")},
        encoding="utf-8",
        delimiter="\t",
        comma=False,
        quote=False,
        newline="\r\n",
        units_row=False,
        preamble=["Torque meter log of {stem}", "free text: clamped both ends"],
        negate=(),
    ),
    "gbk": dict(
        names={"twist_angle": ("扭转角", "°"), "torque": ("扭矩", "N·m")},
        encoding="gbk",
        delimiter=",",
        comma=False,
        quote=False,
        newline="\n",
        units_row=False,
        preamble=["试验编号: {stem}", "操作员: 王工"],
        negate=(),
    ),
    "mts": dict(
        names={"time": ("Time", "Sec"), "deflection": ("Crosshead", "mm"), "force": ("Axial Force", "N")},
        encoding="utf-8",
        delimiter="   ",
        comma=False,
        quote=False,
        newline="\n",
        units_row=True,
        preamble=["MTS793|BTW|ENG|NOR|1|2|SPA|NOR|", "Station Name: Bionix", ""],
        negate=("deflection", "force"),
    ),
    "shimadzu": dict(
        names={"time": ("Time", "sec"), "deflection": ("Stroke", "mm"), "force": ("Force", "kgf")},
        encoding="utf-8",
        delimiter=",",
        comma=False,
        quote=True,
        newline="\n",
        units_row=True,
        preamble=['"Test Name","{stem}"', '"Batch","1"'],
        negate=(),
    ),
}
#: (kind, specimen) -> style
STYLE_OF = {
    ("extension", "T1"): "bluehill",
    ("extension", "T2"): "testxpert",
    ("magnetic_bending", "T1"): "utf16",
    ("magnetic_bending", "T2"): "utf16",
    ("torsion", "T1"): "labview",
    ("torsion", "T2"): "gbk",
    ("three_point_bend", "T1"): "mts",
    ("three_point_bend", "T2"): "shimadzu",
}
QUANTITY = {
    "time": "time",
    "elongation": "length",
    "strain": "strain",
    "force": "force",
    "tip_angle": "angle",
    "field": "field",
    "field_angle": "angle",
    "torque": "torque",
    "twist_angle": "angle",
    "deflection": "length",
}


def _restyle(table, spec: dict, target: Path) -> list[str]:
    """Write ``table`` (SI) in ``spec``'s style; the matid columns written."""
    used = [c for c in spec["names"] if c in table]
    q = (lambda s: f'"{s}"') if spec["quote"] else (lambda s: s)
    d = spec["delimiter"]
    lines = [line.format(stem=target.stem) for line in spec["preamble"]]
    if spec["units_row"]:
        lines.append(d.join(q(spec["names"][c][0]) for c in used))
        lines.append(d.join(q(spec["names"][c][1]) for c in used))
    else:
        lines.append(d.join(q(f"{spec['names'][c][0]} ({spec['names'][c][1]})") for c in used))
    columns = []
    for c in used:
        values = np.asarray(table[c]) / si_factor(spec["names"][c][1], QUANTITY[c])
        columns.append(-values if c in spec["negate"] else values)
    for row in zip(*columns, strict=True):
        cells = [repr(float(v)) for v in row]
        lines.append(d.join(q(x.replace(".", ",") if spec["comma"] else x) for x in cells))
    target.write_bytes((spec["newline"].join(lines) + spec["newline"]).encode(spec["encoding"]))
    return used


def _toml_value(value) -> str:
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + " }"
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    import json

    return json.dumps(value, ensure_ascii=False) if isinstance(value, str) else json.dumps(value)


@pytest.mark.slow
def test_demo_study_in_machine_styles_fits_to_ground_truth(tmp_path):
    import json
    import tomllib

    from matid.app.pipeline import run_study
    from matid.fits.kinds import BY_NAME
    from matid.io.study import load_study

    raw = tomllib.loads((EXAMPLE / "study.toml").read_text(encoding="utf-8"))
    out = ["[study]", f"name = {_toml_value(raw['study']['name'])}", ""]
    for spec in raw["specimen"]:
        out += ["[[specimen]]", *(f"{k} = {_toml_value(v)}" for k, v in spec.items()), ""]
    for entry in raw["test"]:
        style = STYLE_OF[(entry["kind"], entry["specimen"])]
        spec = STYLE_SPECS[style]
        table = read_table(EXAMPLE / entry["file"], entry["kind"])
        name = f"{Path(entry['file']).stem}_{style}.{'txt' if style in ('utf16', 'mts') else 'csv'}"
        used = _restyle(table, spec, tmp_path / name)
        # only columns / negate / encoding help: the file is as the machine wrote it
        mapped = {c: spec["names"][c][0] for c in used if c in BY_NAME[entry["kind"]].columns}
        entry = {**entry, "file": name, "columns": mapped}
        if spec["negate"]:
            entry["negate"] = list(spec["negate"])
        if style == "gbk" and entry["specimen"] == "T2" and "L26" in name:
            entry["encoding"] = "gbk"  # one stated, the other detected
        out += ["[[test]]", *(f"{k} = {_toml_value(v)}" for k, v in entry.items()), ""]
    (tmp_path / "study.toml").write_text("\n".join(out), encoding="utf-8")

    result = run_study(load_study(tmp_path))
    truth = json.loads((EXAMPLE / "ground_truth.json").read_text())["specimens"]
    table = result.estimates()
    for sid, expected in truth.items():
        assert table[sid]["E_e"].value == pytest.approx(expected["E_e"], rel=0.005)
        assert table[sid]["E_b"].value == pytest.approx(expected["E_b"], rel=0.005)
        assert table[sid]["E_t"].value == pytest.approx(expected["E_t"], rel=0.01)
        assert table[sid]["sls_k2"].value == pytest.approx(expected["sls_k2"], rel=0.03)
        assert table[sid]["sls_eta"].value == pytest.approx(expected["sls_eta"], rel=0.03)
    bends = [f for f in result.fits if f.kind == "three_point_bend"]
    assert len(bends) == 2 and all(f.estimate("E_s") is not None for f in bends)
    assert result.ok and not result.failures
