"""A study: specimens, tests and fixed stiffnesses, loaded from ``study.toml``.

data-contract.md section 1. Every quantity is converted to SI here, once; every
problem is a DataError naming the toml file and the entry.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from matid.errors import DataError
from matid.units import UnitError, to_si

#: Per test kind: the toml keys it needs and their quantity kinds; optional keys.
TEST_KINDS: dict[str, dict[str, str]] = {
    "extension": {"gauge_length": "length"},
    "magnetic_bending": {"free_length": "length"},
    "torsion": {"length": "length"},
    "three_point_bend": {
        "span": "length",
        "specimen_length": "length",
        "support_radius": "length",
        "nose_radius": "length",
    },
}
OPTIONAL_KEYS: dict[str, dict[str, str]] = {
    "magnetic_bending": {"magnet_moment": "moment"},
}

#: Parameters a study may fix, with their quantity kinds (data-contract section 3).
PARAMETERS: dict[str, str] = {
    "E_e": "force",
    "E_b": "bending_stiffness",
    "E_t": "bending_stiffness",
    "E_s": "force",
    "sls_k1": "force",
    "sls_k2": "force",
    "sls_eta": "viscosity",
}


@dataclass(frozen=True)
class Specimen:
    """A tube specimen; diameters in m."""

    id: str
    outer_diameter: float
    inner_diameter: float = 0.0
    #: Poisson's ratio for the shear coefficient of E_s from torsion (None: stated default range).
    poisson_ratio: float | None = None

    def __post_init__(self) -> None:
        if not self.id:
            raise ValueError("specimen id must not be empty")
        if not (self.outer_diameter > self.inner_diameter >= 0.0):
            raise ValueError(
                f"specimen {self.id}: need outer_diameter > inner_diameter >= 0, got "
                f"{self.outer_diameter} m and {self.inner_diameter} m"
            )

    @property
    def outer_radius(self) -> float:
        return 0.5 * self.outer_diameter


@dataclass(frozen=True)
class Test:
    """One lab test: a CSV file of one kind on one specimen, with its set-up in SI."""

    __test__ = False  # not a pytest class

    kind: str
    specimen: str
    file: Path
    params: Mapping[str, float] = field(default_factory=dict, hash=False)
    exclude: bool = False
    note: str = ""
    index: int = 0  #: position in study.toml, for messages
    #: matid column name -> (low, high) in SI: only rows inside every range enter the fit
    #: (data-contract section 7, ``window``); rows outside are shown, marked.
    window: Mapping[str, tuple[float, float]] = field(default_factory=dict, hash=False)
    #: three_point_bend: where deflection is measured, "nose" (crosshead) or "centreline".
    deflection_at: str = "nose"

    def __post_init__(self) -> None:
        if self.kind not in TEST_KINDS:
            raise ValueError(f"unknown test kind {self.kind!r}")
        object.__setattr__(self, "params", MappingProxyType(dict(self.params)))
        object.__setattr__(self, "window", MappingProxyType(dict(self.window)))
        if self.deflection_at not in ("nose", "centreline"):
            raise ValueError(f"deflection_at must be 'nose' or 'centreline', got {self.deflection_at!r}")
        for key in TEST_KINDS[self.kind]:
            value = self.params.get(key)
            if value is None or not value > 0:
                raise ValueError(f"{self.kind} test needs a positive {key}")

    @property
    def label(self) -> str:
        return f"{self.kind} {self.specimen} ({self.file.name})"


@dataclass(frozen=True)
class Fixed:
    """A known stiffness used instead of a fit."""

    specimen: str
    parameter: str
    value: float

    def __post_init__(self) -> None:
        if self.parameter not in PARAMETERS:
            raise ValueError(f"unknown parameter {self.parameter!r} (one of {', '.join(PARAMETERS)})")
        if not (math.isfinite(self.value) and self.value > 0):
            raise ValueError(f"fixed {self.parameter} must be positive and finite")


@dataclass(frozen=True)
class Study:
    name: str
    source: Path
    specimens: tuple[Specimen, ...]
    tests: tuple[Test, ...]
    fixed: tuple[Fixed, ...] = ()
    temperature: str = ""

    @property
    def root(self) -> Path:
        return self.source.parent

    def specimen(self, specimen_id: str) -> Specimen:
        for spec in self.specimens:
            if spec.id == specimen_id:
                return spec
        raise KeyError(specimen_id)

    def fixed_value(self, specimen_id: str, parameter: str) -> float | None:
        for item in self.fixed:
            if item.specimen == specimen_id and item.parameter == parameter:
                return item.value
        return None

    def tests_of(self, kind: str, specimen_id: str, *, included: bool = True) -> list[Test]:
        return [
            t
            for t in self.tests
            if t.kind == kind and t.specimen == specimen_id and not (included and t.exclude)
        ]


def resolve_study_path(path: str | Path) -> Path:
    """The study.toml for a folder or toml path (data-contract section 1)."""
    path = Path(path)
    if path.is_dir():
        path = path / "study.toml"
    if not path.is_file():
        raise DataError("study file not found", file=path)
    return path


def load_study(path: str | Path) -> Study:
    """Read and validate ``study.toml`` (or the folder holding it)."""
    source = resolve_study_path(path)
    try:
        raw = tomllib.loads(source.read_text(encoding="utf-8-sig"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"not valid TOML: {exc}", file=source) from exc

    head = raw.get("study", {})
    if not isinstance(head, dict):
        raise DataError("[study] must be a table", file=source)
    specimens = tuple(_specimen(source, i, entry) for i, entry in enumerate(_list(raw, "specimen", source)))
    ids = [s.id for s in specimens]
    duplicates = {i for i in ids if ids.count(i) > 1}
    if duplicates:
        raise DataError(f"duplicate specimen id {sorted(duplicates)[0]!r}", file=source)
    if not specimens:
        raise DataError("no [[specimen]] entries", file=source)
    tests = tuple(_test(source, i, entry, set(ids)) for i, entry in enumerate(_list(raw, "test", source)))
    if not tests:
        raise DataError("no [[test]] entries", file=source)
    fixed = tuple(_fixed(source, i, entry, set(ids)) for i, entry in enumerate(_list(raw, "fixed", source)))
    return Study(
        name=str(head.get("name", source.parent.name)),
        temperature=str(head.get("temperature", "")),
        source=source,
        specimens=specimens,
        tests=tests,
        fixed=fixed,
    )


def _list(raw: dict, key: str, source: Path) -> list[dict]:
    entries = raw.get(key, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise DataError(f"[[{key}]] must be an array of tables", file=source)
    return entries


def _quantity(source: Path, where: str, entry: dict, key: str, kind: str) -> float:
    if key not in entry:
        raise DataError(f"{where}: missing '{key}'", file=source)
    try:
        return to_si(entry[key], kind)
    except UnitError as exc:
        raise DataError(f"{where}: {key}: {exc}", file=source) from exc


def _specimen(source: Path, index: int, entry: dict) -> Specimen:
    where = f"[[specimen]] #{index + 1}"
    sid = str(entry.get("id", "")).strip()
    if not sid:
        raise DataError(f"{where}: missing 'id'", file=source)
    outer = _quantity(source, f"specimen {sid}", entry, "outer_diameter", "length")
    inner = (
        _quantity(source, f"specimen {sid}", entry, "inner_diameter", "length")
        if "inner_diameter" in entry
        else 0.0
    )
    try:
        return Specimen(sid, outer, inner)
    except ValueError as exc:
        raise DataError(str(exc), file=source) from exc


def _test(source: Path, index: int, entry: dict, ids: set[str]) -> Test:
    where = f"[[test]] #{index + 1}"
    kind = entry.get("kind")
    if kind not in TEST_KINDS:
        raise DataError(f"{where}: kind must be one of {', '.join(TEST_KINDS)}, got {kind!r}", file=source)
    specimen = str(entry.get("specimen", ""))
    if specimen not in ids:
        raise DataError(f"{where}: unknown specimen {specimen!r}", file=source)
    if not entry.get("file"):
        raise DataError(f"{where}: missing 'file'", file=source)
    params = {key: _quantity(source, where, entry, key, q) for key, q in TEST_KINDS[kind].items()}
    for key, q in OPTIONAL_KEYS.get(kind, {}).items():
        if key in entry:
            params[key] = _quantity(source, where, entry, key, q)
    try:
        return Test(
            kind=kind,
            specimen=specimen,
            file=(source.parent / str(entry["file"])).resolve(),
            params=params,
            exclude=bool(entry.get("exclude", False)),
            note=str(entry.get("note", "")),
            index=index,
        )
    except ValueError as exc:
        raise DataError(f"{where}: {exc}", file=source) from exc


def _fixed(source: Path, index: int, entry: dict, ids: set[str]) -> Fixed:
    where = f"[[fixed]] #{index + 1}"
    specimen = str(entry.get("specimen", ""))
    if specimen not in ids:
        raise DataError(f"{where}: unknown specimen {specimen!r}", file=source)
    parameter = str(entry.get("parameter", ""))
    if parameter not in PARAMETERS:
        raise DataError(f"{where}: unknown parameter {parameter!r}", file=source)
    value = _quantity(source, where, entry, "value", PARAMETERS[parameter])
    try:
        return Fixed(specimen, parameter, value)
    except ValueError as exc:
        raise DataError(f"{where}: {exc}", file=source) from exc
