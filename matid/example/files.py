"""How the SYNTHETIC demo files are written: CSV dialects, units and study.toml.

A :class:`TestSpec` describes one lab test (kind, specimen, file, set-up and the
columns to write); a :class:`Dialect` says how its CSV looks (delimiter,
decimal mark, where units go, header spelling, encoding, line endings), so
one simulated data set can be written the way different test machines export
(docs/contract.md section 2). Values are simulated in SI and converted here,
with this module's own unit table, independent of matid's unit parser.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

#: SI value of one unit, for every unit the generator writes.
UNIT_SI: dict[str, float] = {
    "m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6,
    "N": 1.0, "mN": 1e-3, "kN": 1e3, "dyn": 1e-5, "gf": 9.80665e-3,
    "N m": 1.0, "mN m": 1e-3, "N mm": 1e-3, "mN mm": 1e-6, "dyn cm": 1e-7,
    "rad": 1.0, "deg": math.pi / 180.0,
    "s": 1.0, "ms": 1e-3, "min": 60.0,
    "1": 1.0, "%": 1e-2,
    "T": 1.0, "mT": 1e-3, "G": 1e-4,
}  # fmt: skip

#: Columns that are dimensionless by name: written as integers, without a unit.
COUNTERS = ("cycle", "index")

#: Significant digits written per column (a fixed number of decimals per column,
#: as test machines export).
SIGNIFICANT = 6


@dataclass(frozen=True)
class Dialect:
    """How one CSV file is spelled."""

    delimiter: str = ","
    decimal: str = "."
    units: str = "brackets"  #: brackets | parens | row | row_parens
    names: str = "snake"  #: snake | spaced | title | upper
    encoding: str = "utf-8"  #: utf-8 | utf-8-sig (BOM) | latin-1
    newline: str = "\n"
    trailing_blank_lines: int = 0
    degree_sign: bool = False  #: write deg as the degree sign
    micro_sign: bool = False  #: write um with the micro sign

    def __post_init__(self) -> None:
        if self.units not in {"brackets", "parens", "row", "row_parens"}:
            raise ValueError(f"unknown units style {self.units!r}")
        if self.names not in {"snake", "spaced", "title", "upper"}:
            raise ValueError(f"unknown names style {self.names!r}")
        if self.decimal == "," and self.delimiter != ";":
            raise ValueError("a decimal comma needs the ';' delimiter")


@dataclass(frozen=True)
class TestSpec:
    """One lab test of the study: what to simulate and how to write it.

    ``setup`` holds the simulation inputs in SI (lengths, histories, fields);
    ``toml`` the keys written to its ``[[test]]`` entry, as quantity strings;
    ``columns`` the (quantity, unit) pairs written, in order (unit "" for
    counters); ``preamble`` is "none", "short" or "full".
    """

    kind: str
    specimen: str
    file: str
    setup: dict
    toml: dict
    columns: tuple[tuple[str, str], ...]
    description: str
    dialect: Dialect = field(default_factory=Dialect)
    preamble: str = "short"
    note: str = ""
    exclude: bool = False


def header_name(name: str, style: str) -> str:
    """A canonical column name (``tip_angle``) spelled in a header style."""
    spaced = name.replace("_", " ")
    return {"snake": name, "spaced": spaced, "title": spaced.title(), "upper": name.upper()}[style]


def unit_text(unit: str, dialect: Dialect) -> str:
    if unit == "deg" and dialect.degree_sign:
        return "\u00b0"
    if unit == "um" and dialect.micro_sign:
        return "\u00b5m"
    return unit


def format_column(values: np.ndarray, *, counter: bool) -> list[str]:
    """Fixed decimals per column giving SIGNIFICANT digits at the column's largest value."""
    if counter:
        return [str(int(v)) for v in values]
    largest = float(np.max(np.abs(values))) if values.size else 0.0
    magnitude = math.floor(math.log10(largest)) if largest > 0.0 else 0
    decimals = max(0, SIGNIFICANT - 1 - magnitude)
    return [f"{v:.{decimals}f}" for v in values]


def render_csv(spec: TestSpec, data: dict[str, np.ndarray], preamble: list[str]) -> bytes:
    """The bytes of one CSV file: preamble, header (and units row), data rows."""
    d = spec.dialect
    names, units, cells = [], [], []
    for quantity, unit in spec.columns:
        counter = quantity in COUNTERS
        values = np.asarray(data[quantity], dtype=float)
        if not counter:
            values = values / UNIT_SI[unit]
        text = format_column(values, counter=counter)
        if d.decimal != ".":
            text = [t.replace(".", d.decimal) for t in text]
        cells.append(text)
        name, shown = header_name(quantity, d.names), unit_text(unit, d)
        if counter or d.units in {"row", "row_parens"}:
            names.append(name)
        else:
            names.append(f"{name} [{shown}]" if d.units == "brackets" else f"{name} ({shown})")
        units.append("" if counter else (f"({shown})" if d.units == "row_parens" else shown))
    lines = [f"# {line}" for line in preamble]
    lines.append(d.delimiter.join(names))
    if d.units in {"row", "row_parens"}:
        lines.append(d.delimiter.join(units))
    lines.extend(d.delimiter.join(row) for row in zip(*cells, strict=True))
    text = d.newline.join(lines) + d.newline + d.newline * d.trailing_blank_lines
    return text.encode(d.encoding)


def toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(float(value))
    return json.dumps(str(value), ensure_ascii=False)


def render_toml(head: dict, specimens: list[dict], specs: list[TestSpec], comment: str) -> str:
    """study.toml (docs/contract.md section 1) for a list of specimens and tests."""
    out = [f"# {line}" for line in comment.splitlines()]
    out += ["", "[study]"] + [f"{k} = {toml_value(v)}" for k, v in head.items()]
    for specimen in specimens:
        out += ["", "[[specimen]]"] + [f"{k} = {toml_value(v)}" for k, v in specimen.items()]
    for spec in specs:
        entry = {"kind": spec.kind, "specimen": spec.specimen, "file": spec.file, **spec.toml}
        if spec.note:
            entry["note"] = spec.note
        if spec.exclude:
            entry["exclude"] = True
        out += ["", "[[test]]"] + [f"{k} = {toml_value(v)}" for k, v in entry.items()]
    return "\n".join(out) + "\n"
