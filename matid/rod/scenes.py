"""Scenes: a rod, its loads and supports, as data (docs/contract.md section 6).

``load_scene`` reads a scene TOML into a frozen :class:`Scene` in SI; the
solver (:mod:`matid.rod.solve`) turns it into a :class:`Solution`. A cantilever
scene is planar when every load lies in one plane through the rod axis: the
field, the forces and the in-plane component of each vector span one
transverse direction e_a, and every moment and precurvature is about the
normal n = e3 x e_a. :func:`plane_of` finds that plane or says there is none.
"""

from __future__ import annotations

import math
import stat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from matid.errors import DataError
from matid.io.toml import parse_toml
from matid.rod.accuracy import MAX_ELEMENTS
from matid.units import UnitError, to_si, vector_to_si

Vector = tuple[float, float, float]
ZERO: Vector = (0.0, 0.0, 0.0)
#: Largest scene or stiffness.json file read (bytes): both are a few kB; more is not a scene.
MAX_FILE_BYTES = 1 << 20
#: Most elements a scene may ask for: the automatic meshing stops there too.
MAX_SCENE_ELEMENTS = MAX_ELEMENTS
#: Most nose displacements a three-point-bend scene may list (each is a continuation solve).
MAX_DEFLECTIONS = 1000
#: Smallest tolerance: the error estimate never claims better than round-off (accuracy.ROUNDOFF).
MIN_TOLERANCE = 1e-12


@dataclass(frozen=True)
class SegmentSpec:
    start: float
    end: float
    overrides: dict = field(default_factory=dict, hash=False)  # E_b, E_t, E_s, E_e, outer_diameter
    rigid: bool = False
    precurvature: Vector | None = None  # this segment's kappa_ref (director frame); None: the rod's


def _check_vector(where: str, value: object) -> None:
    """A DataError naming ``where`` unless ``value`` is three real numbers (x, y, z): the scene's
    dataclasses are also built by hand (the Python API), not only by :func:`load_scene`."""
    try:
        if isinstance(value, (str, bytes)):
            raise TypeError(value)
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{where}: expected 3 components (x, y, z), got {value!r:.60}") from None
    if a.shape != (3,):
        got = a.shape[0] if a.ndim == 1 else f"an array of shape {a.shape}"
        raise DataError(f"{where}: expected 3 components (x, y, z), got {got}")


@dataclass(frozen=True)
class Rod:
    length: float
    E_b: float
    E_t: float
    E_s: float
    E_e: float
    outer_diameter: float = 0.0
    precurvature: Vector = ZERO
    segments: tuple[SegmentSpec, ...] = ()

    def __post_init__(self) -> None:
        for name in ("length", "E_b", "E_t", "E_s", "E_e"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"rod {name} must be positive and finite, got {value}")
        _check_vector("precurvature", self.precurvature)
        for i, seg in enumerate(self.segments):
            if seg.precurvature is not None:
                _check_vector(f"segments[{i}] precurvature", seg.precurvature)
        for seg in self.segments:
            if not 0.0 <= seg.start < seg.end <= self.length * (1 + 1e-12):
                raise ValueError(
                    f"segment [{seg.start}, {seg.end}] m is not inside the rod [0, {self.length}] m"
                )


@dataclass(frozen=True)
class Loads:
    B: Vector = ZERO
    distributed_force: Vector = ZERO
    tip_force: Vector = ZERO
    tip_moment: Vector = ZERO
    magnets: tuple[tuple[float, float], ...] = ()  # (at, moment)
    magnetization: tuple[tuple[float, float, float], ...] = ()  # (from, to, per_length)
    #: unit magnetisation directions in the director frame, one per magnet / magnetised piece
    #: (contract section 9); empty: every one along d3
    magnet_directions: tuple[Vector, ...] = ()
    magnetization_directions: tuple[Vector, ...] = ()
    point_loads: tuple[tuple[float, Vector, Vector], ...] = ()  # (at, dead force, dead moment)

    def __post_init__(self) -> None:
        for name in ("B", "distributed_force", "tip_force", "tip_moment"):
            _check_vector(name, getattr(self, name))
        for i, (_, force, moment) in enumerate(self.point_loads):
            _check_vector(f"point_loads[{i}] force", force)
            _check_vector(f"point_loads[{i}] moment", moment)
        for name, items in (("magnet", self.magnets), ("magnetization", self.magnetization)):
            directions = getattr(self, f"{name}_directions")
            if directions and len(directions) != len(items):
                raise ValueError(f"{name}_directions: one direction per {name} ({len(items)})")
            for i, a in enumerate(directions):
                _check_vector(f"{name}_directions[{i}]", a)
                if abs(math.hypot(*a) - 1.0) > 1e-9:
                    raise ValueError(f"{name} direction {a} is not a unit vector")

    def directions(self, name: str) -> tuple[Vector, ...]:
        """The unit directions of the magnets (``name`` "magnet") or magnetised pieces, d3 by default."""
        items = self.magnets if name == "magnet" else self.magnetization
        return getattr(self, f"{name}_directions") or ((0.0, 0.0, 1.0),) * len(items)


@dataclass(frozen=True)
class BendSetup:
    span: float
    support_radius: float
    nose_radius: float
    deflections: tuple[float, ...]

    def __post_init__(self) -> None:
        if not (self.span > 0 and self.support_radius >= 0 and self.nose_radius >= 0):
            raise ValueError("three_point_bend needs span > 0 and radii >= 0")
        if not self.deflections or any(d < 0 or not math.isfinite(d) for d in self.deflections):
            raise ValueError("three_point_bend needs deflections >= 0")


@dataclass(frozen=True)
class Aim:
    """Contract section 9: the tip's d3 wanted (lab frame, unit) and the field magnitude held (T)."""

    tip_direction: Vector
    field_magnitude: float

    def __post_init__(self) -> None:
        _check_vector("aim.tip_direction", self.tip_direction)
        if abs(math.hypot(*self.tip_direction) - 1.0) > 1e-9:
            raise ValueError(f"aim.tip_direction {self.tip_direction} is not a unit vector")
        if not (math.isfinite(self.field_magnitude) and self.field_magnitude > 0):
            raise ValueError(f"aim.field_magnitude must be positive and finite, got {self.field_magnitude}")


@dataclass(frozen=True)
class Scene:
    kind: str  # "cantilever" | "three_point_bend"
    rod: Rod
    loads: Loads = Loads()
    bend: BendSetup | None = None
    elements: int | None = None
    tolerance: float = 1e-6
    aim: Aim | None = None  # the inverse problem: the field direction is solved for

    def __post_init__(self) -> None:
        if self.kind not in ("cantilever", "three_point_bend"):
            raise ValueError(f"scene must be cantilever or three_point_bend, got {self.kind!r}")
        if (self.kind == "three_point_bend") != (self.bend is not None):
            raise ValueError("a three_point_bend scene needs a [three_point_bend] table (and only it)")
        if self.kind == "three_point_bend" and self.rod.length <= self.bend.span:
            raise ValueError("three_point_bend: rod length must exceed the span")
        if self.kind == "three_point_bend" and not self.rod.outer_diameter > 0:
            raise ValueError("three_point_bend: rod outer_diameter is needed for contact")
        if self.elements is not None and not 1 <= self.elements <= MAX_SCENE_ELEMENTS:
            raise ValueError(f"elements must be between 1 and {MAX_SCENE_ELEMENTS}, got {self.elements}")
        if not MIN_TOLERANCE <= self.tolerance < 1:
            raise ValueError(f"tolerance must be in [{MIN_TOLERANCE:g}, 1), got {self.tolerance:g}")
        if self.aim is not None and self.kind != "cantilever":
            raise ValueError("[aim] applies to cantilever scenes only")
        if self.aim is not None and not (self.loads.magnets or self.loads.magnetization):
            raise ValueError("[aim] needs a magnet or a magnetisation: a field turns nothing else")


def plane_of(scene: Scene, *, tol: float = 1e-12) -> Vector | None:
    """The transverse unit direction e_a of the scene's plane, or None when it is 3D.

    Force-like vectors must lie in span(e_a, e3); moments and the precurvature
    must be along n = e3 x e_a (no twist). A scene with no transverse load at all
    is planar with e_a = e1.
    """
    loads, rod = scene.loads, scene.rod
    directions = loads.directions("magnet") + loads.directions("magnetization")
    if any(a[0] != 0.0 or a[1] != 0.0 for a in directions):
        return None  # a magnetisation off +-d3 twists the rod (contract section 9): the full model runs
    forces = [np.asarray(v, float) for v in (loads.B, loads.distributed_force, loads.tip_force)]
    forces += [np.asarray(f, float) for _, f, _ in loads.point_loads]
    moments = [np.asarray(v, float) for v in (loads.tip_moment, rod.precurvature)]
    moments += [np.asarray(m, float) for _, _, m in loads.point_loads]
    moments += [np.asarray(seg.precurvature, float) for seg in rod.segments if seg.precurvature]
    scale = max([np.abs(v).max() for v in forces + moments] + [1e-300])
    candidates = [v[:2] for v in forces] + [np.array([m[1], -m[0]]) for m in moments]  # n x e3
    unit = (c / np.linalg.norm(c) for c in candidates if np.linalg.norm(c) > tol * scale)
    direction = next(unit, np.array([1.0, 0.0]))
    if any(abs(m[2]) > tol * scale for m in moments):
        return None  # twist moment or twist precurvature
    for c in candidates:
        if abs(c[0] * direction[1] - c[1] * direction[0]) > tol * scale:
            return None
    return (float(direction[0]), float(direction[1]), 0.0)


# -- loading -----------------------------------------------------------------


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene TOML; every problem is a DataError naming the file and key."""
    path = Path(path)
    raw = parse_toml(read_small_file(path, "scene file"), path)  # nesting, control characters, lengths
    try:
        return scene_from_dict(raw, root=path.parent)
    except DataError:
        raise
    except (UnitError, ValueError, KeyError, TypeError, OverflowError) as exc:
        # KeyError's str() is the quoted key; its argument is the message itself
        message = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        raise DataError(str(message), file=path) from exc


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


def _table(value: object, where: str) -> dict:
    """A TOML table (dict), or a ValueError naming where one was expected."""
    if not isinstance(value, dict):
        raise ValueError(f"{where}: expected a table, got {type(value).__name__} {_short(value)}")
    return value


def _tables(raw: dict, key: str) -> list[tuple[str, dict]]:
    """An array of tables (``[[key]]``) as (``[[key]] #n``, table), each checked to be a table with
    known keys."""
    items = raw.get(key, [])
    if not isinstance(items, list):
        raise ValueError(
            f"[[{key}]]: expected an array of tables, got {type(items).__name__} {_short(items)}"
        )
    out = []
    for i, item in enumerate(items):
        where = f"[[{key}]] #{i + 1}"
        out.append((where, _known(_table(item, where), key, where)))
    return out


def _single(raw: dict, key: str, default: object = None) -> dict:
    """The table ``[key]`` (``default`` when absent), checked to be a table with known keys."""
    return _known(_table(raw.get(key, default), f"[{key}]"), key, f"[{key}]")


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


#: Keys of each scene table (docs/contract.md section 6); any other is a typo to report, not to ignore.
TABLE_KEYS = {
    "rod": {"length", "E_b", "E_t", "E_s", "E_e", "outer_diameter", "precurvature", "stiffness"},
    "segment": {"from", "to", "E_b", "E_t", "E_s", "E_e", "outer_diameter", "rigid", "precurvature"},
    "load": {"distributed_force"},
    "magnet": {"at", "moment", "direction"},
    "magnetization": {"from", "to", "per_length", "direction"},
    "point_load": {"at", "force", "moment"},
    "aim": {"tip_direction", "field_magnitude"},
    "field": {"B"},
    "tip": {"force", "moment"},
    "three_point_bend": {"span", "support_radius", "nose_radius", "deflection"},
}


def _known(table: dict, name: str, where: str) -> dict:
    """``table`` itself after checking that every key is one of TABLE_KEYS[name]."""
    unknown = sorted(set(table) - TABLE_KEYS[name])
    if unknown:
        raise ValueError(
            f"{where}: unknown key '{unknown[0]}' (known: {', '.join(sorted(TABLE_KEYS[name]))})"
        )
    return table


def _q(table: dict, key: str, kind: str, where: str, default: object = None) -> float:
    if key not in table:
        if default is None:
            raise ValueError(f"{where}: missing '{key}'")
        return float(default)
    return _si(to_si, table, key, kind, where)


def _v(table: dict, key: str, kind: str, where: str) -> Vector:
    return _si(vector_to_si, table, key, kind, where) if key in table else ZERO


def _si(convert, table: dict, key: str, kind: str, where: str):
    """``convert(table[key], kind)``; a unit problem is a ValueError naming ``where.key``."""
    try:
        return convert(table[key], kind)
    except UnitError as exc:
        raise ValueError(f"{where}.{key}: {exc}") from exc


#: Unit kind of each size and stiffness key of [rod]; all but the length are [[segment]] overrides.
KINDS = {
    "length": "length",
    "E_b": "bending_stiffness",
    "E_t": "bending_stiffness",
    "E_s": "force",
    "E_e": "force",
    "outer_diameter": "length",
}


def _rod(raw: dict, root: Path | None) -> Rod:
    table = dict(_single(raw, "rod", {}))
    if not table:
        raise ValueError("missing [rod] table")
    if "stiffness" in table:
        table.update(_stiffness_from_json(_table(table.pop("stiffness"), "rod.stiffness"), root))
    segments = []
    for where, seg in _tables(raw, "segment"):
        overrides = {k: _q(seg, k, kind, where) for k, kind in KINDS.items() if k != "length" and k in seg}
        start, end = _q(seg, "from", "length", where), _q(seg, "to", "length", where)
        rigid = seg.get("rigid", False)
        if not isinstance(rigid, bool):
            raise ValueError(f"{where}.rigid: expected true or false, got {_short(rigid)}")
        kappa = _v(seg, "precurvature", "curvature", where) if "precurvature" in seg else None
        segments.append(SegmentSpec(start, end, overrides, rigid, kappa))
    sizes = {
        k: _q(table, k, kind, "rod", 0.0 if k == "outer_diameter" else None) for k, kind in KINDS.items()
    }
    return Rod(**sizes, precurvature=_v(table, "precurvature", "curvature", "rod"), segments=tuple(segments))


def _stiffness_from_json(ref: dict, root: Path | None) -> dict:
    """`stiffness = { from = "stiffness.json", specimen = "T1" }`: E_* from a matid fit.

    The file must be a regular file of at most MAX_FILE_BYTES holding a matid
    ``stiffness.json`` in SI; every problem is a DataError naming that file.
    """
    import json

    for key in ("from", "specimen"):
        if not isinstance(ref.get(key), str) or not ref[key]:
            raise ValueError(f"rod.stiffness.{key}: expected a non-empty string, got {_short(ref.get(key))}")
    extra = sorted(set(ref) - {"from", "specimen"})
    if extra:
        raise ValueError(f"rod.stiffness: unknown key '{extra[0]}' (known: from, specimen)")
    file = Path(ref["from"])
    if root is not None and not file.is_absolute():
        file = root / file
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


#: Top-level keys of a scene file (docs/contract.md section 6); anything else is a typo to report.
SCENE_KEYS = {"scene", "elements", "tolerance", *TABLE_KEYS}


def scene_from_dict(raw: dict, *, root: Path | None = None) -> Scene:
    """Build a Scene from the parsed TOML mapping (quantities as strings or SI numbers)."""
    unknown = sorted(set(raw) - SCENE_KEYS)
    if unknown:
        raise ValueError(f"unknown key or table '{unknown[0]}' (known: {', '.join(sorted(SCENE_KEYS))})")
    kind = raw.get("scene", "cantilever")
    rod = _rod(raw, root)
    load, field_, tip = (_single(raw, k, {}) for k in ("load", "field", "tip"))
    magnets = tuple(
        (_q(m, "at", "length", w), _q(m, "moment", "moment", w)) for w, m in _tables(raw, "magnet")
    )
    magnetization = tuple(
        (_q(m, "from", "length", w), _q(m, "to", "length", w), _q(m, "per_length", "moment_per_length", w))
        for w, m in _tables(raw, "magnetization")
    )
    for at, _ in magnets:
        if not 0 < at <= rod.length * (1 + 1e-12):
            raise ValueError(f"[[magnet]] at {at} m is not on the rod (0, {rod.length}] m")
    point_loads = _point_loads(raw, rod.length)
    loads = Loads(
        B=_v(field_, "B", "field", "field"),
        distributed_force=_v(load, "distributed_force", "force_per_length", "load"),
        tip_force=_v(tip, "force", "force", "tip"),
        tip_moment=_v(tip, "moment", "torque", "tip"),
        magnets=magnets,
        magnetization=magnetization,
        magnet_directions=_directions(raw, "magnet"),
        magnetization_directions=_directions(raw, "magnetization"),
        point_loads=point_loads,
    )
    bend = None
    if "three_point_bend" in raw:
        t = _single(raw, "three_point_bend")
        deflections = t.get("deflection")
        if not isinstance(deflections, list) or not deflections:
            raise ValueError("three_point_bend.deflection: need a list of nose displacements")
        if len(deflections) > MAX_DEFLECTIONS:
            raise ValueError(f"three_point_bend.deflection: at most {MAX_DEFLECTIONS} nose displacements")
        sizes = {k: _q(t, k, "length", "three_point_bend") for k in ("span", "support_radius", "nose_radius")}
        bend = BendSetup(**sizes, deflections=tuple(to_si(d, "length") for d in deflections))
    elements = raw.get("elements")
    if elements is not None and (not isinstance(elements, int) or isinstance(elements, bool)):
        raise ValueError(f"elements must be a whole number, got {_short(elements)}")
    tolerance = raw.get("tolerance", 1e-6)
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)):
        raise ValueError(f"tolerance must be a number, got {_short(tolerance)}")
    return Scene(
        kind=kind,
        rod=rod,
        loads=loads,
        bend=bend,
        elements=elements,
        tolerance=float(tolerance),
        aim=_aim(raw),
    )


def _unit(value: object, where: str) -> Vector:
    """A direction: three plain numbers, not all zero, normalised."""
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError(f"{where}: expected three numbers [a1, a2, a3], got {_short(value)}")
    if any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in value):
        raise ValueError(f"{where}: expected plain numbers (a direction has no unit), got {_short(value)}")
    a = np.asarray(value, float)
    norm = float(np.linalg.norm(a))
    if not (np.isfinite(a).all() and np.isfinite(norm) and norm > 0):
        raise ValueError(f"{where}: a direction must be finite and not zero, got {_short(value)}")
    return tuple(float(c) for c in a / norm)


def _directions(raw: dict, key: str) -> tuple[Vector, ...]:
    """The ``direction`` of each [[magnet]] / [[magnetization]] (director frame), d3 by default."""
    return tuple(
        _unit(t["direction"], f"{where}.direction") if "direction" in t else (0.0, 0.0, 1.0)
        for where, t in _tables(raw, key)
    )


def _point_loads(raw: dict, length: float) -> tuple[tuple[float, Vector, Vector], ...]:
    """[[point_load]]: a dead force and moment at a point of the rod (0, L]."""
    out = []
    for where, t in _tables(raw, "point_load"):
        at = _q(t, "at", "length", where)
        if not 0 < at <= length * (1 + 1e-12):
            raise ValueError(f"{where}: at {at} m is not on the rod (0, {length}] m")
        if "force" not in t and "moment" not in t:
            raise ValueError(f"{where}: give a force, a moment or both")
        out.append((at, _v(t, "force", "force", where), _v(t, "moment", "torque", where)))
    return tuple(out)


def _aim(raw: dict) -> Aim | None:
    if "aim" not in raw:
        return None
    t = _single(raw, "aim")
    if "tip_direction" not in t:
        raise ValueError("[aim]: missing 'tip_direction'")
    return Aim(_unit(t["tip_direction"], "aim.tip_direction"), _q(t, "field_magnitude", "field", "aim"))
