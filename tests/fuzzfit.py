"""Studies fitted end to end (issue 30 item 7): mutated reduced demo studies through ``matid fit``.

A case is one of tests/fuzzkit.TEMPLATES (one test kind on specimen T1) or the three kinds
together, with one to three mutations of what a lab hands in: study.toml numbers (diameters,
lengths, moments, spans, radii, fixed values, the Poisson ratio) scaled over 600 orders of
magnitude, flipped or zeroed; reading keys added (``window`` on a used column, ``columns``
swapped, ``units``, ``negate``); the CSV records with a column scaled, its sign flipped, two
columns' data or header names swapped, NaN cells, rows dropped or duplicated, the file cut
(mid-line too), the unit strings of the header changed, or any of fuzzkit.csv_mutation's
mutations (encodings, export styles). Every case runs ``matid fit`` (matid.app.cli.main, in this
process, under an alarm) into a fresh folder: exit 0, 1, 2 or 4 is allowed; exit 3 (an uncaught
exception), a run past the limit (a hang) and an absurd stiffness.json (a value of a parameter
reported with status ok that is above fuzzkit.ABSURD or not finite, or its interval) are not.
"""

from __future__ import annotations

import copy
import json
import math
import shutil
import time
from pathlib import Path

from hypothesis import strategies as st

from tests import fuzzkit

#: The three kinds that fit without fixed values, together on one specimen (E_s from torsion too).
MIXED = [t for kind in ("torsion", "magnetic_bending", "extension") for t in fuzzkit.TEMPLATES[kind]["tests"]]
FIT_TEMPLATES = {**fuzzkit.TEMPLATES, "mixed": {"tests": MIXED}}
#: The columns a test of each kind reads (the names of docs/contract.md's table).
COLUMNS = {
    "torsion": ["twist_angle", "torque"],
    "magnetic_bending": ["tip_angle", "field", "field_angle"],
    "extension": ["time", "force", "elongation"],
    "three_point_bend": ["deflection", "force"],
}
#: Units a reading key may name (right kind, wrong kind, unknown).
READ_UNITS = ["N", "mN", "kN", "gf", "mm", "um", "m", "deg", "rad", "s", "ms", "mT", "T", "N m", "mN mm",
              "foo", ""]  # fmt: skip
#: Bounds of an added window, in the units of the column named.
WINDOW_ENDS = ["0", "0.05", "0.5", "1", "10", "45", "90", "180", "1e300", "-1e300", "-1", "nan"]
#: A fit taking longer than this counts as a hang (issue 30: 120 s).
LIMIT = 120.0


def _numeric_keys(table: dict) -> list[str]:
    return [k for k in sorted(table) if fuzzkit.scaled(table[k], 2.0) != table[k]]


@st.composite
def toml_number(draw, doc: dict) -> str:
    """A number of study.toml (a dimension, a length, a moment, a fixed value) scaled, or a
    Poisson ratio added."""
    tables = [("specimen", t) for t in doc["specimen"]] + [("test", t) for t in doc["test"]]
    tables += [("fixed", t) for t in doc.get("fixed", [])]
    name, table = draw(st.sampled_from(tables))
    if name == "specimen" and draw(st.integers(0, 3)) == 0:
        table["poisson_ratio"] = draw(st.sampled_from([0.0, 0.3, 0.5, 0.49999, -1.0, 1.0, 1e300, -0.5]))
        return f"specimen.poisson_ratio = {table['poisson_ratio']}"
    keys = _numeric_keys(table)
    if not keys:
        return f"{name}: no number"
    key = draw(st.sampled_from(keys))
    factor = draw(st.sampled_from(fuzzkit.MILD * 3 + fuzzkit.SCALES))
    table[key] = fuzzkit.scaled(table[key], factor)
    return f"{name}.{key} x {factor:g}"


@st.composite
def reading_key(draw, doc: dict) -> str:
    """A reading key on a test: a window on one of its columns, columns swapped, a unit, a negation."""
    test = draw(st.sampled_from(doc["test"]))
    names = COLUMNS[test["kind"]]
    col = draw(st.sampled_from(names))
    what = draw(st.sampled_from(["window", "window", "columns", "units", "negate"]))
    if what == "window":
        unit = draw(st.sampled_from(["", " mm", " deg", " mT", " s", " N", " %"]))
        a, b = (draw(st.sampled_from(WINDOW_ENDS)) + unit for _ in "ab")
        test["window"] = {col: [a, b]}
    elif what == "columns":
        other = draw(st.sampled_from(names))
        test["columns"] = {col: other, other: col} if other != col else {col: col.upper()}
    elif what == "units":
        test["units"] = {col: draw(st.sampled_from(READ_UNITS))}
    else:
        test["negate"] = [col] if draw(st.booleans()) else list(names)
    return f"test {test['file']}: {what} {test.get(what)}"


def _table(text: str) -> tuple[list[str], int, list[int]]:
    lines = text.split("\n")
    head = next((i for i, line in enumerate(lines) if line and not line.startswith("#")), 0)
    return lines, head, [i for i in range(head + 1, len(lines)) if lines[i]]


def _number(cell: str, factor: float) -> str:
    try:
        return repr(float(cell) * factor)
    except ValueError:
        return cell


@st.composite
def csv_numbers(draw, text: str) -> tuple[str, str]:
    """A CSV record with its numbers changed as a lab's slip would: a column scaled or negated,
    two columns swapped (data or header), NaN cells, rows dropped, duplicated or cut, units changed."""
    lines, head, rows = _table(text)
    if not rows:
        return text, "none"
    ncol = len(lines[head].split(","))
    what = draw(st.sampled_from(["scale", "scale", "sign", "swap", "swap_head", "nan", "drop", "dup",
                                 "cut", "cut_mid", "unit", "sort", "zero_rows"]))  # fmt: skip
    c = draw(st.integers(0, ncol - 1))
    split = {r: lines[r].split(",") for r in rows}
    if what in ("scale", "sign"):
        factor = -1.0 if what == "sign" else draw(st.sampled_from(fuzzkit.SCALES + [1e-12, 1e12, 1e100]))
        for r in rows:
            if c < len(split[r]):
                split[r][c] = _number(split[r][c], factor)
        what += f" column {c} x {factor:g}"
    elif what == "swap" and ncol > 1:
        d = (c + draw(st.integers(1, ncol - 1))) % ncol
        for r in rows:
            cells = split[r]
            if max(c, d) < len(cells):
                cells[c], cells[d] = cells[d], cells[c]
        what += f" columns {c}, {d}"
    elif what == "swap_head" and ncol > 1:
        names = lines[head].split(",")
        names[0], names[-1] = names[-1], names[0]
        lines[head] = ",".join(names)
    elif what == "nan":
        for r in draw(st.lists(st.sampled_from(rows), min_size=1, max_size=max(1, len(rows)))):
            if c < len(split[r]):
                split[r][c] = draw(st.sampled_from(["nan", "NaN", "", "inf", "-inf"]))
    elif what == "drop":
        keep = draw(st.integers(0, len(rows)))
        drop = set(draw(st.permutations(rows))[keep:])
        lines = [line for i, line in enumerate(lines) if i not in drop]
        split = {}
    elif what == "dup":
        lines = lines[: head + 1] + [lines[r] for r in rows for _ in range(draw(st.sampled_from([2, 3])))]
        split = {}
    elif what in ("cut", "cut_mid"):
        body = "\n".join(lines)
        at = draw(st.integers(len("\n".join(lines[: head + 1])), len(body)))
        if what == "cut":
            at = body.rfind("\n", 0, at) + 1 or at
        return body[:at], f"{what} at {at} of {len(body)}"
    elif what == "unit":
        names = lines[head].split(",")
        base = names[c].split("[")[0].strip()
        names[c] = f"{base} [{draw(st.sampled_from(READ_UNITS))}]"
        lines[head] = ",".join(names)
        what += f" {names[c]}"
    elif what == "sort":
        order = sorted(rows, key=lambda r: split[r][c] if c < len(split[r]) else "")
        texts = [",".join(split[r]) for r in order]
        lines = lines[: head + 1] + texts
        split = {}
    else:  # zero_rows: every row the same (a frozen sensor)
        lines = lines[: head + 1] + [lines[rows[0]]] * len(rows)
        split = {}
    for r, cells in split.items():
        lines[r] = ",".join(cells)
    return "\n".join(lines), what


@st.composite
def fit_cases(draw):
    """(template, study.toml text, {csv name: text/bytes}, labels): a mutated study to fit."""
    kind = draw(st.sampled_from(sorted(FIT_TEMPLATES)))
    template = FIT_TEMPLATES[kind]
    doc = {"study": dict(fuzzkit.HEADER), "specimen": [dict(fuzzkit.SPECIMEN)],
           "test": [copy.deepcopy(t) for t in template["tests"]]}  # fmt: skip
    if "fixed" in template:
        doc["fixed"] = copy.deepcopy(template["fixed"])
    files: dict[str, str | bytes] = {
        t["file"]: (fuzzkit.DEMO / t["file"]).read_text(encoding="utf-8") for t in template["tests"]
    }
    labels = []
    for _ in range(draw(st.integers(1, 3))):
        way = draw(st.sampled_from(["toml", "toml", "reading", "csv", "csv", "csv", "any"]))
        if way == "toml":
            labels.append(draw(toml_number(doc)))
            continue
        if way == "reading":
            labels.append(draw(reading_key(doc)))
            continue
        name = draw(st.sampled_from(sorted(files)))
        if isinstance(files[name], bytes):
            continue
        mutate = csv_numbers if way == "csv" else fuzzkit.csv_mutation
        files[name], label = draw(mutate(files[name]))
        labels.append(f"csv {name}: {label}")
    return kind, fuzzkit.toml_dumps(doc), files, labels


def absurd_stiffness(doc: dict) -> str | None:
    """A value of stiffness.json reported with status ok that is above ABSURD or not finite (its
    value, standard error or interval); None when there is none."""
    for sid, params in doc.get("specimens", {}).items():
        for name, item in params.items():
            if not isinstance(item, dict) or item.get("status") != "ok":
                continue
            numbers = [item.get("value"), item.get("stderr"), *(item.get("ci95") or [])]
            for x in numbers:
                sane = isinstance(x, (int, float)) and math.isfinite(x) and abs(x) <= fuzzkit.ABSURD
                if x is not None and not sane:
                    return f"{sid} {name}: {x!r} with status ok"
            if item.get("value") is None:
                return f"{sid} {name}: no value with status ok"
    return None


def run_fit_case(case, work: Path, *, limit: float = LIMIT) -> fuzzkit.Outcome:
    """Write the case's study into ``work``, run ``matid fit`` on it, check stiffness.json."""
    kind, toml, files, labels = case
    study = work / "study"
    shutil.rmtree(work, ignore_errors=True)
    study.mkdir(parents=True)
    fuzzkit._write(study / "study.toml", toml)
    for name, content in files.items():
        fuzzkit._write(study / name, content)
    out = work / "out"
    clock = time.perf_counter()
    code, message = fuzzkit.run_cli(["fit", str(study), "--out", str(out), "--quiet"], limit)
    seconds = time.perf_counter() - clock
    if code != "hang" and seconds > limit:
        code, message = "hang", f"answered after {seconds:.0f} s (> {limit} s)"
    if code == 4:  # the outputs could not be written (docs/contract.md section 5): allowed
        return fuzzkit.Outcome(code, "fitted", seconds, message or "exit 4")
    if code in (0, 1) and (out / "stiffness.json").exists():
        try:
            text = (out / "stiffness.json").read_text(encoding="utf-8")
            wrong = absurd_stiffness(json.loads(text, parse_constant=_not_json))
        except ValueError as exc:  # NaN or Infinity tokens: not JSON (RFC 8259)
            wrong = f"stiffness.json does not parse: {exc}"
        if wrong:
            code, message = "absurd", wrong
    elif code in (0, 1):
        code, message = "absurd", f"exit {code} without stiffness.json"
    return fuzzkit.Outcome(code, "fitted", seconds, message or f"exit {code}")


def _not_json(token: str):
    raise ValueError(f"{token} is not a JSON number")


def allowed(outcome: fuzzkit.Outcome) -> str | None:
    """None when a fitted case's outcome is allowed (exit 0, 1, 2 or 4), else what is wrong."""
    if outcome.code == 4:
        return None
    return fuzzkit.allowed(outcome)
