"""Scenes: a rod, its loads and supports, as data (data-contract section 6).

``load_scene`` reads a scene TOML into a frozen :class:`Scene` in SI; the
solver (:mod:`matid.rod.solve`) turns it into a :class:`Solution`. A cantilever
scene is planar when every load lies in one plane through the rod axis: the
field, the forces and the in-plane component of each vector span one
transverse direction e_a, and every moment and precurvature is about the
normal n = e3 x e_a. :func:`plane_of` finds that plane or says there is none.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from matid.errors import DataError
from matid.units import UnitError, to_si, vector_to_si

Vector = tuple[float, float, float]
ZERO: Vector = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class SegmentSpec:
    start: float
    end: float
    overrides: dict = field(default_factory=dict, hash=False)  # E_b, E_t, E_s, E_e, outer_diameter
    rigid: bool = False


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
class Scene:
    kind: str  # "cantilever" | "three_point_bend"
    rod: Rod
    loads: Loads = Loads()
    bend: BendSetup | None = None
    elements: int | None = None
    tolerance: float = 1e-6

    def __post_init__(self) -> None:
        if self.kind not in ("cantilever", "three_point_bend"):
            raise ValueError(f"scene must be cantilever or three_point_bend, got {self.kind!r}")
        if (self.kind == "three_point_bend") != (self.bend is not None):
            raise ValueError("a three_point_bend scene needs a [three_point_bend] table (and only it)")
        if self.kind == "three_point_bend" and self.rod.length <= self.bend.span:
            raise ValueError("three_point_bend: rod length must exceed the span")
        if self.kind == "three_point_bend" and not self.rod.outer_diameter > 0:
            raise ValueError("three_point_bend: rod outer_diameter is needed for contact")
        if self.elements is not None and self.elements < 1:
            raise ValueError("elements must be at least 1")
        if not 0 < self.tolerance < 1:
            raise ValueError("tolerance must be in (0, 1)")


def plane_of(scene: Scene, *, tol: float = 1e-12) -> Vector | None:
    """The transverse unit direction e_a of the scene's plane, or None when it is 3D.

    Force-like vectors must lie in span(e_a, e3); moments and the precurvature
    must be along n = e3 x e_a (no twist). A scene with no transverse load at all
    is planar with e_a = e1.
    """
    loads, rod = scene.loads, scene.rod
    forces = [np.asarray(v, float) for v in (loads.B, loads.distributed_force, loads.tip_force)]
    moments = [np.asarray(v, float) for v in (loads.tip_moment, rod.precurvature)]
    scale = max([np.abs(v).max() for v in forces + moments] + [1e-300])
    candidates = [v[:2] for v in forces] + [np.array([m[1], -m[0]]) for m in moments]  # n x e3
    direction = next((c / np.linalg.norm(c) for c in candidates if np.linalg.norm(c) > tol * scale), None)
    if direction is None:
        direction = np.array([1.0, 0.0])
    if any(abs(m[2]) > tol * scale for m in moments):
        return None  # twist moment or twist precurvature
    for c in candidates:
        if abs(c[0] * direction[1] - c[1] * direction[0]) > tol * max(scale, 1e-300):
            return None
    return (float(direction[0]), float(direction[1]), 0.0)


# -- loading -----------------------------------------------------------------


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene TOML; every problem is a DataError naming the file and key."""
    path = Path(path)
    if not path.is_file():
        raise DataError("scene file not found", file=path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"not valid TOML: {exc}", file=path) from exc
    try:
        return scene_from_dict(raw, root=path.parent)
    except (UnitError, ValueError, KeyError, TypeError) as exc:
        raise DataError(str(exc).strip("'\""), file=path) from exc


def _q(table: dict, key: str, kind: str, where: str, default: object = None) -> float:
    if key not in table:
        if default is None:
            raise ValueError(f"{where}: missing '{key}'")
        return float(default)
    try:
        return to_si(table[key], kind)
    except UnitError as exc:
        raise ValueError(f"{where}.{key}: {exc}") from exc


def _v(table: dict, key: str, kind: str, where: str) -> Vector:
    if key not in table:
        return ZERO
    try:
        return vector_to_si(table[key], kind)
    except UnitError as exc:
        raise ValueError(f"{where}.{key}: {exc}") from exc


def _rod(raw: dict, root: Path | None) -> Rod:
    table = dict(raw.get("rod") or {})
    if not table:
        raise ValueError("missing [rod] table")
    if "stiffness" in table:
        table.update(_stiffness_from_json(table.pop("stiffness"), root))
    segments = []
    for i, seg in enumerate(raw.get("segment", [])):
        where = f"[[segment]] #{i + 1}"
        overrides = {
            k: _q(
                seg,
                k,
                "bending_stiffness"
                if k in ("E_b", "E_t")
                else "length"
                if k == "outer_diameter"
                else "force",
                where,
            )
            for k in ("E_b", "E_t", "E_s", "E_e", "outer_diameter")
            if k in seg
        }
        segments.append(
            SegmentSpec(
                _q(seg, "from", "length", where),
                _q(seg, "to", "length", where),
                overrides,
                bool(seg.get("rigid", False)),
            )
        )
    return Rod(
        length=_q(table, "length", "length", "rod"),
        E_b=_q(table, "E_b", "bending_stiffness", "rod"),
        E_t=_q(table, "E_t", "bending_stiffness", "rod"),
        E_s=_q(table, "E_s", "force", "rod"),
        E_e=_q(table, "E_e", "force", "rod"),
        outer_diameter=_q(table, "outer_diameter", "length", "rod", default=0.0),
        precurvature=_v(table, "precurvature", "curvature", "rod"),
        segments=tuple(segments),
    )


def _stiffness_from_json(ref: dict, root: Path | None) -> dict:
    """`stiffness = { from = "stiffness.json", specimen = "T1" }`: E_* from a matid fit."""
    import json

    file = Path(ref["from"])
    if root is not None and not file.is_absolute():
        file = root / file
    doc = json.loads(file.read_text(encoding="utf-8"))
    params = doc["specimens"][ref["specimen"]]
    factor = {"SI": 1.0, "cgs": None}[doc.get("unit_system", "SI")]
    if factor is None:
        raise ValueError(f"{file}: use a stiffness.json written with --units SI")
    return {k: float(params[k]["value"]) for k in ("E_b", "E_t", "E_s", "E_e") if k in params}


#: Top-level keys of a scene file (data-contract section 6); anything else is a typo to report.
SCENE_KEYS = {
    "scene",
    "elements",
    "tolerance",
    "rod",
    "segment",
    "load",
    "magnet",
    "magnetization",
    "field",
    "tip",
    "three_point_bend",
}


def scene_from_dict(raw: dict, *, root: Path | None = None) -> Scene:
    """Build a Scene from the parsed TOML mapping (quantities as strings or SI numbers)."""
    unknown = sorted(set(raw) - SCENE_KEYS)
    if unknown:
        raise ValueError(f"unknown key or table '{unknown[0]}' (known: {', '.join(sorted(SCENE_KEYS))})")
    kind = raw.get("scene", "cantilever")
    rod = _rod(raw, root)
    load, field_ = raw.get("load", {}), raw.get("field", {})
    tip = raw.get("tip", {})
    magnets = tuple(
        (_q(m, "at", "length", f"[[magnet]] #{i + 1}"), _q(m, "moment", "moment", f"[[magnet]] #{i + 1}"))
        for i, m in enumerate(raw.get("magnet", []))
    )
    magnetization = tuple(
        (_q(m, "from", "length", w), _q(m, "to", "length", w), _q(m, "per_length", "moment_per_length", w))
        for i, m in enumerate(raw.get("magnetization", []))
        for w in [f"[[magnetization]] #{i + 1}"]
    )
    for at, _ in magnets:
        if not 0 < at <= rod.length * (1 + 1e-12):
            raise ValueError(f"[[magnet]] at {at} m is not on the rod (0, {rod.length}] m")
    loads = Loads(
        B=_v(field_, "B", "field", "field"),
        distributed_force=_v(load, "distributed_force", "force_per_length", "load"),
        tip_force=_v(tip, "force", "force", "tip"),
        tip_moment=_v(tip, "moment", "torque", "tip"),
        magnets=magnets,
        magnetization=magnetization,
    )
    bend = None
    if "three_point_bend" in raw:
        t = raw["three_point_bend"]
        deflections = t.get("deflection")
        if not isinstance(deflections, list) or not deflections:
            raise ValueError("three_point_bend.deflection: need a list of nose displacements")
        bend = BendSetup(
            span=_q(t, "span", "length", "three_point_bend"),
            support_radius=_q(t, "support_radius", "length", "three_point_bend"),
            nose_radius=_q(t, "nose_radius", "length", "three_point_bend"),
            deflections=tuple(to_si(d, "length") for d in deflections),
        )
    elements = raw.get("elements")
    if elements is not None and (not isinstance(elements, int) or isinstance(elements, bool)):
        raise ValueError(f"elements must be a whole number, got {elements!r}")
    return Scene(
        kind=kind,
        rod=rod,
        loads=loads,
        bend=bend,
        elements=elements,
        tolerance=float(raw.get("tolerance", 1e-6)),
    )
