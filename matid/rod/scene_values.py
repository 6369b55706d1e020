"""The values of a scene file: the file itself, its tables and their known keys, quantities with
units, directions, and the ``stiffness = { from = ..., specimen = ... }`` reference to a matid
``stiffness.json`` (read as plain JSON). Every problem is a DataError naming where it is
(:func:`matid.rod.scenes.load_scene` adds the scene file) or the stiffness file.
"""

from __future__ import annotations

import json
import math
import stat
import sys
from pathlib import Path

import numpy as np

from matid.errors import DataError
from matid.rod import schema
from matid.units import UnitError, to_si, vector_to_si

Vector = tuple[float, float, float]
ZERO: Vector = (0.0, 0.0, 0.0)
#: Largest scene or stiffness.json file read (bytes): both are a few kB; more is not a scene.
MAX_FILE_BYTES = 1 << 20


def read_small_file(path: Path, what: str) -> str:
    """The UTF-8 text of a regular file of at most MAX_FILE_BYTES; a DataError naming it otherwise."""
    try:
        info = path.stat()
    except FileNotFoundError:
        raise DataError(f"{what} not found", file=path) from None
    except OSError as exc:  # a symlink loop, a name too long, no permission
        raise DataError(f"{what} cannot be read: {exc.strerror}", file=path) from exc
    if stat.S_ISDIR(info.st_mode):
        raise DataError(f"{what} is a folder, not a file", file=path)
    if not stat.S_ISREG(info.st_mode):
        raise DataError(f"{what} is not a regular file (a device, pipe or socket)", file=path)
    if info.st_size > MAX_FILE_BYTES:
        raise DataError(
            f"{what} is {info.st_size} bytes, more than the {MAX_FILE_BYTES} a {what} may have", file=path
        )
    try:
        with path.open("rb") as handle:
            data = handle.read(MAX_FILE_BYTES + 1)
        if len(data) > MAX_FILE_BYTES:
            raise DataError(f"{what} is more than {MAX_FILE_BYTES} bytes long", file=path)
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(f"{what} is not UTF-8 text: {exc.reason} at byte {exc.start}", file=path) from exc
    except OSError as exc:
        raise DataError(f"{what} cannot be read: {exc.strerror}", file=path) from exc


def as_table(value: object, where: str) -> dict:
    """A TOML table (dict), or a DataError naming where one was expected."""
    if not isinstance(value, dict):
        raise DataError(f"{where}: expected a table, got {type(value).__name__} {short(value)}")
    return value


def array_of_tables(raw: dict, key: str) -> list[tuple[str, dict]]:
    """An array of tables (``[[key]]``) as (``[[key]] #n``, table), each checked to be a table with
    known keys."""
    items = raw.get(key, [])
    if not isinstance(items, list):
        raise DataError(f"[[{key}]]: expected an array of tables, got {type(items).__name__} {short(items)}")
    most = schema.BY_NAME[key].max_entries
    if len(items) > most:
        raise DataError(f"[[{key}]]: at most {most} entries (matid.rod.schema.MAX_SCENE_ENTRIES), got {len(items)}")
    out = []
    for i, item in enumerate(items):
        where = f"[[{key}]] #{i + 1}"
        out.append((where, known(as_table(item, where), key, where)))
    return out


def one_table(raw: dict, key: str, default: object = None) -> dict:
    """The table ``[key]`` (``default`` when absent), checked to be a table with known keys."""
    return known(as_table(raw.get(key, default), f"[{key}]"), key, f"[{key}]")


def short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


#: Keys of each scene table (matid.rod.schema, docs/scenes.md); any other is a typo to report, not to ignore.
TABLE_KEYS = schema.TABLE_KEYS


def known(table: dict, name: str, where: str) -> dict:
    """``table`` itself after checking that every key is one of TABLE_KEYS[name]."""
    unknown = sorted(set(table) - TABLE_KEYS[name])
    if unknown:
        raise DataError(f"{where}: unknown key '{unknown[0]}' (known: {', '.join(sorted(TABLE_KEYS[name]))})")
    return table


def quantity(table: dict, key: str, kind: str, where: str, default: object = None) -> float:
    if key not in table:
        if default is None:
            raise DataError(f"{where}: missing '{key}'")
        return float(default)
    return si(to_si, table, key, kind, where)


def read(table: dict, name: str, key: str, where: str):
    """The SI value of ``key`` of the scene table ``name`` (a quantity or a vector), its kind, default
    and bounds taken from :mod:`matid.rod.schema`: None when it is absent and has no default (a
    vector: zero); a DataError naming ``where.key`` when it is missing, not a quantity, or out of
    bounds."""
    spec = schema.key(name, key)
    if key not in table:
        if spec.default is None:
            raise DataError(f"{where}: missing '{key}'")
        if spec.type == "vector":
            return ZERO
        return None if spec.default == schema.ABSENT else spec.default
    value = si(vector_to_si if spec.type == "vector" else to_si, table, key, spec.kind, where)
    schema.check(name, key, value, where)
    return value


def vector(table: dict, key: str, kind: str, where: str) -> Vector:
    return si(vector_to_si, table, key, kind, where) if key in table else ZERO


def si(convert, table: dict, key: str, kind: str, where: str):
    """``convert(table[key], kind)``; a unit problem is a DataError naming ``where.key``."""
    try:
        return convert(table[key], kind)
    except UnitError as exc:
        raise DataError(f"{where}.{key}: {exc}") from exc


def stiffness_from_json(ref: dict, root: Path | None) -> dict:
    """`stiffness = { from = "stiffness.json", specimen = "T1" }`: E_* from a matid fit.

    The file must be a regular file of at most MAX_FILE_BYTES holding a matid
    ``stiffness.json`` in SI; every problem is a DataError naming that file.
    """
    for key in ("from", "specimen"):
        if not isinstance(ref.get(key), str) or not ref[key]:
            raise DataError(f"rod.stiffness.{key}: expected a non-empty string, got {short(ref.get(key))}")
    fields = schema.key("rod", "stiffness").fields
    extra = sorted(set(ref) - set(fields))
    if extra:
        raise DataError(f"rod.stiffness: unknown key '{extra[0]}' (known: {', '.join(sorted(fields))})")
    outside = ref.get("allow_outside", False)
    if not isinstance(outside, bool):
        raise DataError(f"rod.stiffness.allow_outside: expected true or false, got {short(outside)}")
    file = inside(Path(ref["from"]), root, outside)
    try:
        doc = json.loads(read_small_file(file, "stiffness file"))
    except ValueError as exc:  # JSONDecodeError, or a number too large for Python's int parser
        raise DataError(f"not valid JSON: {exc}", file=file) from exc
    except RecursionError as exc:
        raise DataError("not valid JSON: nested too deeply", file=file) from exc
    specimens = doc.get("specimens") if isinstance(doc, dict) else None
    if not isinstance(specimens, dict):
        raise DataError("not a matid stiffness.json: no 'specimens' table", file=file)
    if doc.get("unit_system", "SI") != "SI":
        raise DataError("use a stiffness.json written with --units SI", file=file)
    params = specimens.get(ref["specimen"])
    if not isinstance(params, dict):
        raise DataError(
            f"no specimen '{ref['specimen']}' (it has: {', '.join(map(str, specimens))})", file=file
        )
    out = {}
    for k in ("E_b", "E_t", "E_s", "E_e"):
        if k not in params:
            continue
        value = params[k].get("value") if isinstance(params[k], dict) else None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise DataError(f"specimens.{ref['specimen']}.{k}.value: expected a finite number", file=file)
        out[k] = float(value)
    return out


def inside(file: Path, root: Path | None, outside: bool) -> Path:
    """``file`` (relative to the scene's folder ``root``), links resolved; a DataError when it lies
    outside that folder (``../x``, an absolute path, a link leading out) unless ``outside``: a scene
    handed over must not read the reader's files (as a study's data files, docs/limits.md)."""
    base = Path.cwd() if root is None else root
    try:
        resolved, folder = (base / file).resolve(), base.resolve()
    except (OSError, RuntimeError) as exc:
        raise DataError(f"rod.stiffness.from: {short(str(file))} cannot be resolved ({exc})") from exc
    if not (outside or resolved.is_relative_to(folder)):
        raise DataError(
            f"rod.stiffness.from: {short(str(file))} is {resolved}, outside the scene's folder {folder}; "
            "move it in, or set allow_outside = true in the stiffness table"
        )
    return resolved


def direction(value: object, where: str) -> Vector:
    """A direction: three plain numbers, not all zero, normalised."""
    if not isinstance(value, list) or len(value) != 3:
        raise DataError(f"{where}: expected three numbers [a1, a2, a3], got {short(value)}")
    if any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in value):
        raise DataError(f"{where}: expected plain numbers (a direction has no unit), got {short(value)}")
    if any(abs(c) > sys.float_info.max for c in value):
        raise DataError(f"{where}: a direction must be finite and not zero, got {short(value)}")
    a = np.asarray(value, float)
    big = float(np.abs(a).max())
    if np.isfinite(a).all() and big > 0 and not 1e-150 < big < 1e150:
        a = a / np.abs(a).max()  # no overflow (or underflow) in the norm of [1e300, 1e300, 0]
    norm = float(np.linalg.norm(a))
    if not (np.isfinite(a).all() and np.isfinite(norm) and norm > 0):
        raise DataError(f"{where}: a direction must be finite and not zero, got {short(value)}")
    return tuple(float(c) for c in a / norm)
