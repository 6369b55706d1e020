"""A study: specimens, tests and fixed stiffnesses, loaded from ``study.toml``.

docs/contract.md sections 1 and 7. Every quantity is converted to SI here,
once; every problem is a DataError naming the toml file, the entry and the key.
Unknown keys are errors with the nearest valid key suggested (a misspelled
``exlude`` must not silently fit the test); a bare number for a dimensional
quantity is SI only where that is plausible for its kind
(:data:`matid.units.PLAUSIBLE_BARE`); booleans must be TOML booleans; free text is bounded
(:data:`matid.limits.MAX_TEXT`); the toml is read by :func:`matid.toml.load_toml` (docs/limits.md).
"""

from __future__ import annotations

import unicodedata
from pathlib import Path

from matid.errors import DataError
from matid.fits.kinds import BY_NAME
from matid.io import study_keys as keys
from matid.io.ingest.checks import DYNAMIC_RANGE
from matid.io.study_keys import bounded_text, nearest
from matid.limits import MAX_ENTRIES
from matid.model.study import DEFLECTION_AT, PARAMETERS, Fixed, Specimen, Study, Test
from matid.toml import load_toml, shown
from matid.units import PHYSICAL_BOUND, PLAUSIBLE_BARE, UnitError, to_si

#: Keys whose strings are free text: any length (cut at MAX_TEXT), not bounded by MAX_VALUE_CHARS.
FREE_TEXT = ("name", "temperature", "note")
#: Keys every [[test]] may carry besides its kind's quantities (sections 1 and 7).
TEST_COMMON_KEYS = ("kind", "specimen", "file", "exclude", "note", *keys.READING_KEYS)
TABLE_KEYS: dict[str, tuple[str, ...]] = {
    "": ("study", "specimen", "test", "fixed"),
    "study": ("name", "temperature", "allow_outside"),
    "specimen": ("id", "outer_diameter", "inner_diameter", "poisson_ratio", *keys.SECTION_KEYS),
    "fixed": ("specimen", "parameter", "value"),
}


def resolve_study_path(path: str | Path) -> Path:
    """The study.toml for a folder or toml path (docs/contract.md section 1)."""
    path = Path(path)
    if path.is_dir():
        path = path / "study.toml"
    if not path.is_file():
        raise DataError("study file not found", file=path)
    return path


def load_study(path: str | Path) -> Study:
    """Read and validate ``study.toml`` (or the folder holding it)."""
    source = resolve_study_path(path)
    raw = load_toml(source, "study file", FREE_TEXT)
    _check_keys(source, "the top level", raw, TABLE_KEYS[""])
    head = raw.get("study", {})
    if not isinstance(head, dict):
        raise DataError("[study] must be a table", file=source)
    _check_keys(source, "[study]", head, TABLE_KEYS["study"])
    outside = keys.boolean(source, "[study]", head, "allow_outside")
    specimens = tuple(_specimen(source, i, entry) for i, entry in enumerate(_list(raw, "specimen", source)))
    ids = [s.id for s in specimens]
    duplicates = {i for i in ids if ids.count(i) > 1}
    if duplicates:
        raise DataError(f"duplicate specimen id '{shown(sorted(duplicates)[0])}'", file=source)
    _check_look_alikes(source, ids)
    if not specimens:
        raise DataError("no [[specimen]] entries", file=source)
    tests = tuple(_test(source, i, e, set(ids), outside) for i, e in enumerate(_list(raw, "test", source)))
    if not tests:
        raise DataError("no [[test]] entries", file=source)
    fixed = tuple(_fixed(source, i, entry, set(ids)) for i, entry in enumerate(_list(raw, "fixed", source)))
    _check_fixed_once(source, fixed)
    return Study(
        name=bounded_text(head.get("name", source.parent.name)),
        temperature=bounded_text(head.get("temperature", "")),
        source=source,
        specimens=specimens,
        tests=tests,
        fixed=fixed,
    )


def _check_keys(source: Path, where: str, entry: dict, valid: tuple[str, ...], other: str = "") -> None:
    """Reject a key not in ``valid``, naming it and the nearest valid key."""
    for key in entry:
        if key not in valid:
            hint = nearest(str(key), valid) or f" (valid keys: {', '.join(valid)})"
            raise DataError(f"{where}: unknown key `{shown(key)}`{other}{hint}", file=source)


def _list(raw: dict, key: str, source: Path) -> list[dict]:
    entries = raw.get(key, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise DataError(f"[[{key}]] must be an array of tables", file=source)
    if len(entries) > MAX_ENTRIES:
        raise DataError(f"{len(entries)} [[{key}]] entries, more than MAX_ENTRIES = {MAX_ENTRIES}",
                        file=source)  # fmt: skip
    return entries


def _quantity(source: Path, where: str, entry: dict, key: str, kind: str) -> float:
    if key not in entry:
        raise DataError(f"{where}: missing '{key}'", file=source)
    return _value(source, where, key, entry[key], kind)


def _value(source: Path, where: str, key: str, value: object, kind: str) -> float:
    """One quantity in SI: units parsed, bare numbers checked for plausibility, bounds checked."""
    try:
        number = to_si(value, kind)
    except UnitError as exc:
        raise DataError(f"{where}: {key}: {exc}", file=source) from exc
    bare = isinstance(value, (int, float)) and not isinstance(value, bool)
    if bare and number != 0 and kind in PLAUSIBLE_BARE:
        low, high, unit = PLAUSIBLE_BARE[kind]
        if not low <= abs(number) <= high:
            raise DataError(
                f"{where}: {key} = {value} is a bare number, read as SI ({number:g} in SI units of "
                f"{kind}), which is not plausible here (expected {low:g} to {high:g}); write the unit, "
                f'e.g. {key} = "{value} {unit}"',
                file=source,
            )
    bound = PHYSICAL_BOUND.get(kind)
    if bound is not None and abs(number) > bound:
        raise DataError(
            f"{where}: {key} = '{shown(value)}' is {number:g} in SI, beyond the physical "
            f"bound {bound:g} for a {kind}",
            file=source,
        )
    if bound is not None and 0 < abs(number) < bound / DYNAMIC_RANGE:  # the data columns' floor
        raise DataError(
            f"{where}: {key} = '{shown(value)}' is {number:g} in SI, below {bound / DYNAMIC_RANGE:g}, "
            f"the smallest {kind} matid reads (a unit or export mistake): check its unit",
            file=source,
        )
    return number


def specimen_id(text: object) -> str:
    """A specimen id as matid keeps it: stripped, in Unicode normal form NFC (an id typed as
    ``u`` + combining diaeresis is the same id as ``ü``)."""
    return unicodedata.normalize("NFC", str(text).strip())


def look_alike_key(sid: str) -> str:
    """Two ids with the same key look alike on a page: equal after NFKC (width, ligatures),
    case folding and removal of format characters (Unicode category Cf: zero-width, bidi controls)."""
    text = unicodedata.normalize("NFKC", sid).casefold()
    return unicodedata.normalize("NFKC", "".join(c for c in text if unicodedata.category(c) != "Cf"))


def _check_look_alikes(source: Path, ids: list[str]) -> None:
    seen: dict[str, str] = {}
    for sid in ids:
        other = seen.setdefault(look_alike_key(sid), sid)
        if other != sid:
            raise DataError(
                f"specimen ids '{shown(other)}' and '{shown(sid)}' look alike (they differ only by case, "
                "width or invisible characters) and would be printed alike; rename one",
                file=source,
            )


def _check_fixed_once(source: Path, fixed: tuple[Fixed, ...]) -> None:
    first: dict[tuple[str, str], int] = {}
    for i, f in enumerate(fixed):
        j = first.setdefault((f.specimen, f.parameter), i)
        if j != i:
            raise DataError(
                f"[[fixed]] #{i + 1}: a second value of {f.parameter} of specimen {shown(f.specimen)} "
                f"(the first is [[fixed]] #{j + 1}); keep one",
                file=source,
            )


def _specimen(source: Path, index: int, entry: dict) -> Specimen:
    where = f"[[specimen]] #{index + 1}"
    _check_keys(source, where, entry, TABLE_KEYS["specimen"])
    sid = specimen_id(entry.get("id", ""))
    if not sid:
        raise DataError(f"{where}: missing 'id'", file=source)
    invisible = next((c for c in sid if unicodedata.category(c) == "Cf"), None)
    if invisible is not None:
        raise DataError(
            f"{where}: id '{shown(sid)}' holds the invisible format character U+{ord(invisible):04X} "
            f"({unicodedata.name(invisible, 'unnamed')}); an id is printed in every table: remove it",
            file=source,
        )
    sid = bounded_text(sid, 200)
    nu = entry.get("poisson_ratio")
    if nu is not None and (isinstance(nu, bool) or not isinstance(nu, (int, float)) or not -1.0 < nu <= 0.5):
        raise DataError(
            f"specimen {sid}: poisson_ratio must be a number in (-1, 0.5], got '{shown(nu)}'",
            file=source,
        )
    where = f"specimen {sid}"
    dims = keys.section(source, where, entry, lambda key: _quantity(source, where, entry, key, "length"))
    try:
        return Specimen(sid, poisson_ratio=None if nu is None else float(nu), **dims)
    except ValueError as exc:
        raise DataError(str(exc), file=source) from exc


def _test(source: Path, index: int, entry: dict, ids: set[str], outside: bool = False) -> Test:
    where = f"[[test]] #{index + 1}"
    kind = entry.get("kind")
    if not isinstance(kind, str) or kind not in BY_NAME:
        hint = nearest(str(kind), list(BY_NAME))
        raise DataError(
            f"{where}: kind must be one of {', '.join(BY_NAME)}, got '{shown(kind)}'{hint}",
            file=source,
        )
    _check_test_keys(source, where, entry, kind)
    specimen = _specimen_of(source, where, entry, ids)
    if not entry.get("file") or not isinstance(entry["file"], str):
        raise DataError(f"{where}: missing 'file' (a file name string)", file=source)
    params = {key: _quantity(source, where, entry, key, q) for key, q in BY_NAME[kind].keys.items()}
    for key, q in BY_NAME[kind].optional.items():
        if key in entry:
            params[key] = _quantity(source, where, entry, key, q)
    given = dict(
        file=keys.data_file(source, where, entry["file"], outside),
        exclude=keys.boolean(source, where, entry, "exclude"),
        note=keys.text(source, where, entry, "note"),
        window=keys.window(source, where, entry, kind, _value),
        deflection_at=keys.text(source, where, entry, "deflection_at", "nose"),
        columns=keys.columns(source, where, entry, kind),
        units=keys.units(source, where, entry, kind),
        negate=keys.negate(source, where, entry, kind),
        encoding=keys.encoding(source, where, entry),
    )
    if given["deflection_at"] not in DEFLECTION_AT:
        got = shown(given["deflection_at"])
        raise DataError(f"{where}: deflection_at must be 'nose' or 'centreline', got '{got}'", file=source)
    for key in BY_NAME[kind].keys:
        if not params[key] > 0:
            raise DataError(f"{where}: {kind} test needs a positive {key}", file=source)
    return Test(kind=kind, specimen=specimen, params=params, index=index, **given)


def _specimen_of(source: Path, where: str, entry: dict, ids: set[str]) -> str:
    specimen = specimen_id(entry.get("specimen", ""))
    if specimen not in ids:
        raise DataError(f"{where}: unknown specimen '{shown(specimen)}'", file=source)
    return specimen


def _check_test_keys(source: Path, where: str, entry: dict, kind: str) -> None:
    own = (*TEST_COMMON_KEYS, *BY_NAME[kind].test_keys)
    for key in entry:
        if key not in own:
            owners = [name for name, k in BY_NAME.items() if key in k.test_keys]
            other = f", a key of {' and '.join(owners)} tests, not of {kind} tests" if owners else ""
            _check_keys(source, where, {key: None}, own, other)


def _fixed(source: Path, index: int, entry: dict, ids: set[str]) -> Fixed:
    where = f"[[fixed]] #{index + 1}"
    _check_keys(source, where, entry, TABLE_KEYS["fixed"])
    specimen = _specimen_of(source, where, entry, ids)
    parameter = str(entry.get("parameter", ""))
    if parameter not in PARAMETERS:
        hint = nearest(parameter, list(PARAMETERS))
        raise DataError(f"{where}: unknown parameter '{shown(parameter)}'{hint}", file=source)
    value = _quantity(source, where, entry, "value", PARAMETERS[parameter])
    try:
        return Fixed(specimen, parameter, value)
    except ValueError as exc:
        raise DataError(f"{where}: {exc}", file=source) from exc
