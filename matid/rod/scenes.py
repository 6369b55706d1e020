"""Scenes: a rod, its loads and supports, as data (docs/contract.md section 6; every key: docs/scenes.md,
made from :mod:`matid.rod.schema`).

``load_scene`` reads a scene TOML into a frozen :class:`Scene` in SI; the
solver (:mod:`matid.rod.cantilever`) turns it into a :class:`Solution`. A cantilever
scene is planar when every load lies in one plane through the rod axis: the
field, the forces and the in-plane component of each vector span one
transverse direction e_a, and every moment and precurvature is about the
normal n = e3 x e_a. :func:`plane_of` finds that plane or says there is none.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from matid.errors import DataError
from matid.rod.accuracy import MAX_ELEMENTS
from matid.rod.scene_contact import Lumen, Wall, check_contact, contact_directions, contact_keys
from matid.rod.scene_values import (
    ZERO,
    Vector,
    array_of_tables,
    as_table,
    direction,
    one_table,
    read,
    read_small_file,
    short,
    stiffness_from_json,
)
from matid.rod.schema import MAX_DEFLECTIONS, MIN_TOLERANCE, SCENE_KEYS
from matid.toml import parse_toml
from matid.units import UnitError, to_si

#: Most elements a scene may ask for: the automatic meshing stops there too.
MAX_SCENE_ELEMENTS = MAX_ELEMENTS
__all__ = ["MAX_DEFLECTIONS", "MAX_SCENE_ELEMENTS", "MIN_TOLERANCE"]  # also kept here (matid.rod.schema)


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
                raise DataError(f"rod {name} must be positive and finite, got {value}")
        _check_vector("precurvature", self.precurvature)
        for i, seg in enumerate(self.segments):
            if seg.precurvature is not None:
                _check_vector(f"segments[{i}] precurvature", seg.precurvature)
        for seg in self.segments:
            if not 0.0 <= seg.start < seg.end <= self.length * (1 + 1e-12):
                raise DataError(
                    f"segment [{seg.start}, {seg.end}] m is not inside the rod [0, {self.length}] m"
                )
        pieces = sorted(self.segments, key=lambda seg: seg.start)
        for a, b in zip(pieces, pieces[1:], strict=False):
            if b.start < a.end:
                raise DataError(
                    f"segments [{a.start:g}, {a.end:g}] m and [{b.start:g}, {b.end:g}] m overlap: "
                    "each point of the rod belongs to one piece at most"
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
    #: (docs/scenes.md, ``direction``); empty: every one along d3
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
                raise DataError(f"{name}_directions: one direction per {name} ({len(items)})")
            for i, a in enumerate(directions):
                _check_vector(f"{name}_directions[{i}]", a)
                if abs(math.hypot(*a) - 1.0) > 1e-9:
                    raise DataError(f"{name} direction {a} is not a unit vector")

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
            raise DataError("three_point_bend needs span > 0 and radii >= 0")
        if not self.deflections or any(d < 0 or not math.isfinite(d) for d in self.deflections):
            raise DataError("three_point_bend needs deflections >= 0")
        for name in ("support_radius", "nose_radius"):
            if not getattr(self, name) < self.span / 2:
                raise DataError(
                    f"three_point_bend.{name}: must be less than half the span ({self.span / 2:.6g} m), "
                    f"got {getattr(self, name):.6g} m"
                )
        if max(self.deflections) > self.span:
            raise DataError(
                f"three_point_bend.deflection: at most the span ({self.span:.6g} m), got {max(self.deflections):.6g} m"
            )


@dataclass(frozen=True)
class Aim:
    """``[aim]`` (docs/scenes.md): the tip's d3 wanted (lab frame, unit) and the field magnitude held (T)."""

    tip_direction: Vector
    field_magnitude: float

    def __post_init__(self) -> None:
        _check_vector("aim.tip_direction", self.tip_direction)
        if abs(math.hypot(*self.tip_direction) - 1.0) > 1e-9:
            raise DataError(f"aim.tip_direction {self.tip_direction} is not a unit vector")
        if not (math.isfinite(self.field_magnitude) and self.field_magnitude > 0):
            raise DataError(f"aim.field_magnitude must be positive and finite, got {self.field_magnitude}")


@dataclass(frozen=True)
class Scene:
    kind: str  # "cantilever" | "three_point_bend"
    rod: Rod
    loads: Loads = Loads()
    bend: BendSetup | None = None
    elements: int | None = None
    tolerance: float = 1e-6
    aim: Aim | None = None  # the inverse problem: the field direction is solved for
    walls: tuple[Wall, ...] = ()  # contract section 12 (matid.rod.scene_contact)
    lumen: Lumen | None = None
    advance: tuple[float, ...] | None = None  # free lengths, solved in order

    def __post_init__(self) -> None:
        if self.kind not in ("cantilever", "three_point_bend"):
            raise DataError(f"scene must be cantilever or three_point_bend, got {self.kind!r}")
        if (self.kind == "three_point_bend") != (self.bend is not None):
            raise DataError("a three_point_bend scene needs a [three_point_bend] table (and only it)")
        if self.kind == "three_point_bend" and self.rod.length <= self.bend.span:
            raise DataError("three_point_bend: rod length must exceed the span")
        if self.kind == "three_point_bend" and not self.rod.outer_diameter > 0:
            raise DataError("three_point_bend: rod outer_diameter is needed for contact")
        if self.kind == "three_point_bend" and not self.rod.outer_diameter < self.bend.span:
            raise DataError("three_point_bend: the tube's outer_diameter must be less than the span")
        self._check_ranges()
        if self.elements is not None and not 1 <= self.elements <= MAX_SCENE_ELEMENTS:
            raise DataError(f"elements must be between 1 and {MAX_SCENE_ELEMENTS}, got {self.elements}")
        if not MIN_TOLERANCE <= self.tolerance < 1:
            raise DataError(f"tolerance must be in [{MIN_TOLERANCE:g}, 1), got {self.tolerance:g}")
        if self.aim is not None and self.kind != "cantilever":
            raise DataError("[aim] applies to cantilever scenes only")
        if self.aim is not None and not (self.loads.magnets or self.loads.magnetization):
            raise DataError("[aim] needs a magnet or a magnetisation: a field turns nothing else")
        check_contact(self)


    def _check_ranges(self) -> None:
        """Every magnet, point load and magnetised piece lies on the rod: nothing is dropped or cut."""
        L = self.rod.length * (1 + 1e-12)
        for i, (start, end, _) in enumerate(self.loads.magnetization):
            if not 0.0 <= start < end <= L:
                raise DataError(
                    f"[[magnetization]] #{i + 1}: from {start:.6g} m to {end:.6g} m is not a range inside "
                    f"the rod [0, {self.rod.length:.6g}] m (from < to <= length)"
                )
        for name, ats in (("magnet", [m[0] for m in self.loads.magnets]),
                          ("point_load", [p[0] for p in self.loads.point_loads])):  # fmt: skip
            for i, at in enumerate(ats):
                if not 0.0 < at <= L:
                    raise DataError(f"[[{name}]] #{i + 1}: at {at:.6g} m is not on the rod (0, {self.rod.length:.6g}] m")


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
    # in scaled units (matid.rod.models: a load negligible at 1e-12 is so for the rod), in floats
    L, Eb = rod.length, rod.E_b
    field = max([abs(m) * L / Eb for _, m in loads.magnets] + [abs(mu) * L**2 / Eb for *_, mu in loads.magnetization] + [0.0])  # fmt: skip
    forces = [[float(c) * f for c in v] for v, f in ((loads.B, field), (loads.distributed_force, L**3 / Eb),
                                                      (loads.tip_force, L**2 / Eb))]  # fmt: skip
    forces += [[float(c) * L**2 / Eb for c in f] for _, f, _ in loads.point_loads]
    moments = [[float(c) * L / Eb for c in loads.tip_moment], [float(c) * L for c in rod.precurvature]]
    moments += [[float(c) * L / Eb for c in m] for _, _, m in loads.point_loads]
    moments += [[float(c) * L for c in seg.precurvature] for seg in rod.segments if seg.precurvature]
    scale = max([max(abs(c) for c in v) for v in forces + moments] + [1e-300])
    candidates = [v[:2] for v in forces] + [[m[1], -m[0]] for m in moments]  # n x e3
    candidates += [[float(c[0]) * scale, float(c[1]) * scale] for c in contact_directions(scene)]
    first = next((c for c in candidates if math.hypot(*c) > tol * scale), None)
    direction = [1.0, 0.0] if first is None else (np.asarray(first) / (np.linalg.norm(first) or math.hypot(*first))).tolist()  # fmt: skip  # noqa: E501 (norm underflows at 1e-300)
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
    except DataError as exc:  # found in the scene's values: name the scene file
        raise exc if exc.file else DataError(exc.detail, file=path) from exc


#: The size and stiffness keys of [rod]; all but the length are [[segment]] overrides.
SIZES = ("length", "E_b", "E_t", "E_s", "E_e", "outer_diameter")


def _rod(raw: dict, root: Path | None) -> Rod:
    table = dict(one_table(raw, "rod", {}))
    if not table:
        raise DataError("missing [rod] table")
    if "stiffness" in table:
        fitted = stiffness_from_json(as_table(table.pop("stiffness"), "rod.stiffness"), root)
        clash = sorted(set(fitted) & set(table))
        if clash:
            raise DataError(
                f"rod.{clash[0]}: given both here and by rod.stiffness (from a fit); keep one of them"
            )
        table.update(fitted)
    segments = []
    for where, seg in array_of_tables(raw, "segment"):
        overrides = {k: read(seg, "segment", k, where) for k in SIZES[1:] if k in seg}
        start, end = read(seg, "segment", "from", where), read(seg, "segment", "to", where)
        rigid = seg.get("rigid", False)
        if not isinstance(rigid, bool):
            raise DataError(f"{where}.rigid: expected true or false, got {short(rigid)}")
        kappa = read(seg, "segment", "precurvature", where) if "precurvature" in seg else None
        segments.append(SegmentSpec(start, end, overrides, rigid, kappa))
    sizes = {k: read(table, "rod", k, "rod") for k in SIZES}
    sizes["outer_diameter"] = sizes["outer_diameter"] or 0.0
    return Rod(**sizes, precurvature=read(table, "rod", "precurvature", "rod"), segments=tuple(segments))


def scene_from_dict(raw: dict, *, root: Path | None = None) -> Scene:
    """Build a Scene from the parsed TOML mapping (quantities as strings or SI numbers)."""
    unknown = sorted(set(raw) - SCENE_KEYS) or (["sweep (a family: matid solve or matid.rod.sweep)"]
                                                  if "sweep" in raw else [])
    if unknown:
        raise DataError(f"unknown key or table '{unknown[0]}' (known: {', '.join(sorted(SCENE_KEYS))})")
    kind = raw.get("scene", "cantilever")
    rod = _rod(raw, root)
    load, field_, tip = (one_table(raw, k, {}) for k in ("load", "field", "tip"))
    magnets = tuple(
        (read(m, "magnet", "at", w), read(m, "magnet", "moment", w)) for w, m in array_of_tables(raw, "magnet")
    )
    magnetization = tuple(
        tuple(read(m, "magnetization", k, w) for k in ("from", "to", "per_length"))
        for w, m in array_of_tables(raw, "magnetization")
    )
    for at, _ in magnets:
        if not 0 < at <= rod.length * (1 + 1e-12):
            raise DataError(f"[[magnet]] at {at} m is not on the rod (0, {rod.length}] m")
    point_loads = _point_loads(raw, rod.length)
    loads = Loads(
        B=read(field_, "field", "B", "field"),
        distributed_force=read(load, "load", "distributed_force", "load"),
        tip_force=read(tip, "tip", "force", "tip"),
        tip_moment=read(tip, "tip", "moment", "tip"),
        magnets=magnets,
        magnetization=magnetization,
        magnet_directions=_directions(raw, "magnet"),
        magnetization_directions=_directions(raw, "magnetization"),
        point_loads=point_loads,
    )
    bend = None
    if "three_point_bend" in raw:
        t = one_table(raw, "three_point_bend")
        deflections = t.get("deflection")
        if not isinstance(deflections, list) or not deflections:
            raise DataError("three_point_bend.deflection: need a list of nose displacements")
        if len(deflections) > MAX_DEFLECTIONS:
            raise DataError(f"three_point_bend.deflection: at most {MAX_DEFLECTIONS} nose displacements")
        sizes = {k: read(t, "three_point_bend", k, "three_point_bend") for k in ("span", "support_radius", "nose_radius")}
        bend = BendSetup(**sizes, deflections=tuple(_length(d) for d in deflections))
    elements = raw.get("elements")
    if elements is not None and (not isinstance(elements, int) or isinstance(elements, bool)):
        raise DataError(f"elements must be a whole number, got {short(elements)}")
    tolerance = raw.get("tolerance", 1e-6)
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)):
        raise DataError(f"tolerance must be a number, got {short(tolerance)}")
    if abs(tolerance) > 1:  # also a whole number too large for a float
        raise DataError(f"tolerance must be in [{MIN_TOLERANCE:g}, 1), got {short(tolerance)}")
    return Scene(
        kind=kind,
        rod=rod,
        loads=loads,
        bend=bend,
        elements=elements,
        tolerance=float(tolerance),
        aim=_aim(raw),
        **contact_keys(raw),
    )


def _length(value: object) -> float:
    """A length in SI; a DataError saying what is wrong with it."""
    try:
        return to_si(value, "length")
    except UnitError as exc:
        raise DataError(str(exc)) from exc


def _directions(raw: dict, key: str) -> tuple[Vector, ...]:
    """The ``direction`` of each [[magnet]] / [[magnetization]] (director frame), d3 by default."""
    return tuple(
        direction(t["direction"], f"{where}.direction") if "direction" in t else (0.0, 0.0, 1.0)
        for where, t in array_of_tables(raw, key)
    )


def _point_loads(raw: dict, length: float) -> tuple[tuple[float, Vector, Vector], ...]:
    """[[point_load]]: a dead force and moment at a point of the rod (0, L]."""
    out = []
    for where, t in array_of_tables(raw, "point_load"):
        at = read(t, "point_load", "at", where)
        if not 0 < at <= length * (1 + 1e-12):
            raise DataError(f"{where}: at {at} m is not on the rod (0, {length}] m")
        if "force" not in t and "moment" not in t:
            raise DataError(f"{where}: give a force, a moment or both")
        out.append((at, read(t, "point_load", "force", where), read(t, "point_load", "moment", where)))
    return tuple(out)


def _aim(raw: dict) -> Aim | None:
    if "aim" not in raw:
        return None
    t = one_table(raw, "aim")
    if "tip_direction" not in t:
        raise DataError("[aim]: missing 'tip_direction'")
    return Aim(direction(t["tip_direction"], "aim.tip_direction"), read(t, "aim", "field_magnitude", "aim"))
