"""The contact keys of a scene (contract section 12): ``[[wall]]``, ``[lumen]`` and ``[advance]``.

Parsed in one place (:func:`contact_keys`) into frozen data in SI; the rules that make a scene
impossible before any solve (a wall that cuts the clamp, a lumen narrower than the tube or not
holding the clamp) are :func:`check_contact`. The tube's outer radius at arc length s is
:func:`outer_radius` (the rod's ``outer_diameter / 2``, a segment's where it overrides it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.errors import DataError
from matid.physics.boundaries import Centreline, lumen_gap, wall_gap
from matid.rod import schema
from matid.rod.scene_values import Vector, array_of_tables, direction, one_table, quantity, read
from matid.rod.terms.contact import CONTACT_FRACTION
from matid.units import to_si, vector_to_si

#: Default corner radius of a lumen's centreline, in lumen radii (contract section 12).
CORNER_RADII = 5.0
#: Most steps an [advance] may list (each is a solve with its error estimate).
MAX_STEPS = 200


@dataclass(frozen=True)
class Wall:
    point: Vector
    normal: Vector  # unit, towards the side the tube stays on


@dataclass(frozen=True)
class Lumen:
    centreline: tuple[Vector, ...]
    radius: float
    corner_radius: float

    def line(self) -> Centreline:
        return Centreline.rounded(self.centreline, self.corner_radius)


def contact_keys(raw: dict) -> dict:
    """{"walls", "lumen", "advance"} of a parsed scene (empty, None, None when absent)."""
    walls = []
    for where, t in array_of_tables(raw, "wall"):
        point = read(t, "wall", "point", where)
        walls.append(Wall(point, direction(t.get("normal"), f"{where}.normal")))
    walls = tuple(walls)
    lumen = None
    if "lumen" in raw:
        t = one_table(raw, "lumen")
        points = t.get("centreline")
        if not isinstance(points, list) or len(points) < 2:
            raise DataError("[lumen].centreline: need a list of at least two points [x, y, z]")
        line = tuple(_point(p, f"[lumen].centreline #{i + 1}") for i, p in enumerate(points))
        for p in line:  # 1e300 mm: the gaps' round-off ~1e281 m, rounds that never settle
            schema.check("lumen", "centreline", p, "[lumen]")
        radius = quantity(t, "radius", "length", "[lumen]")
        corner = quantity(t, "corner_radius", "length", "[lumen]", CORNER_RADII * radius)
        schema.check("lumen", "radius", radius, "[lumen]")
        schema.check("lumen", "corner_radius", corner, "[lumen]")
        lumen = Lumen(line, radius, corner)
        try:
            lumen.line()
        except ValueError as exc:
            raise DataError(f"[lumen].centreline: {exc}") from exc
    advance = None
    if "advance" in raw:
        t = one_table(raw, "advance")
        lengths = t.get("free_lengths")
        if not isinstance(lengths, list) or not lengths or len(lengths) > MAX_STEPS:
            raise DataError(f"[advance].free_lengths: need a list of 1 to {MAX_STEPS} lengths")
        advance = tuple(_length(v, "[advance].free_lengths") for v in lengths)
        for free in advance:
            schema.check("advance", "free_lengths", free, "[advance]")
    return {"walls": walls, "lumen": lumen, "advance": advance}


def _point(value: object, where: str) -> Vector:
    try:
        return vector_to_si(value, "length")
    except Exception as exc:  # UnitError or a malformed entry
        raise DataError(f"{where}: {exc}") from exc


def _length(value: object, where: str) -> float:
    try:
        return to_si(value, "length")
    except Exception as exc:
        raise DataError(f"{where}: {exc}") from exc


def outer_radius(rod, s: np.ndarray) -> np.ndarray:
    """The tube's outer radius (m) at arc lengths s (m) of ``rod`` (a scenes.Rod)."""
    s = np.asarray(s, float)
    out = np.full(s.shape, 0.5 * rod.outer_diameter)
    for seg in rod.segments:
        if "outer_diameter" in seg.overrides:
            out = np.where((s >= seg.start) & (s < seg.end), 0.5 * seg.overrides["outer_diameter"], out)
    return out


def check_contact(scene) -> None:
    """A DataError for a scene that no state can satisfy: a wall that cuts the clamp, a lumen
    narrower than the tube or whose wall the clamp lies outside of, free lengths not in (0, L]."""
    rod = scene.rod
    if (scene.walls or scene.lumen is not None) and scene.kind != "cantilever":
        raise DataError("[[wall]] and [lumen] apply to cantilever scenes only")
    advance = scene.advance or ()
    for k, free in enumerate(advance):
        if not 0 < free <= rod.length * (1 + 1e-12):
            raise DataError(f"[advance].free_lengths #{k + 1}: {free} m is not in (0, {rod.length}] m")
    if scene.advance is not None and scene.aim is not None:
        raise DataError("[advance] and [aim] cannot be combined")
    # the clamp (the sheath's exit under [advance]): the first point of every free length
    firsts = [rod.length - free for free in advance] or [0.0]
    R0 = outer_radius(rod, np.asarray(firsts))
    origin = np.zeros((len(firsts), 3))
    tol = 1e-12 * rod.length
    for i, wall in enumerate(scene.walls):
        g, _ = wall_gap(origin, wall.point, wall.normal, R0)
        if g.min() < -tol:
            raise DataError(
                f"[[wall]] #{i + 1} cuts the clamp: the tube's surface at the clamp is "
                f"{-g.min():.3g} m on the wrong side of it"
            )
    _coincident(scene.walls, tol)
    if scene.lumen is not None:
        widest = float(outer_radius(rod, np.array([0.0] + [seg.start for seg in rod.segments])).max())
        if scene.lumen.radius < widest:
            raise DataError(
                f"[lumen] radius {scene.lumen.radius:.4g} m is narrower than the tube "
                f"(outer radius {widest:.4g} m)"
            )
        _check_room(scene.lumen.radius - widest, CONTACT_FRACTION * scene.tolerance * rod.length)
        g, _, _ = lumen_gap(origin, scene.lumen.line(), scene.lumen.radius, R0)
        if g.min() < -tol:
            raise DataError("[lumen]: the clamp is outside the lumen (its wall cuts the tube at the clamp)")


def _check_room(clearance: float, contact_tolerance: float) -> None:
    """A DataError for a lumen that leaves the tube no room (a clearance within the contact
    tolerance): the tube then fills it and touches it all round, on its centreline, where the
    wall's direction is undefined and the reaction is not determined. Found by the scene fuzz:
    the magnetic workspace in a straight lumen of the tube's own radius placed a contact at
    nearly every node (8871 at 9458 elements after 12 s) and ran past 60 s; a clearance of 1e-12 m
    already solves or fails by name within 0.1 s per state."""
    if clearance <= contact_tolerance:
        raise DataError(
            f"[lumen] leaves the tube no room: its clearance {clearance:.3g} m is within the contact "
            f"tolerance {contact_tolerance:.3g} m (a tube that fills its lumen touches it all round, "
            "and its reaction is not determined); make the lumen wider than the tube"
        )


def _coincident(walls, tol: float) -> None:
    """A DataError for two walls on one plane facing one way: the rod's reaction would split between
    them in any proportion, so their forces are not determined (before: 5120 elements, an estimate
    of 2.4e-3 for a tolerance of 1e-8, 40 s, where one such wall solves in 3 s)."""
    normals = [np.asarray(w.normal, float) / np.linalg.norm(w.normal) for w in walls]
    for j, (wall, n) in enumerate(zip(walls, normals, strict=True)):
        for i in range(j):
            same_way = float(normals[i] @ n) > 1.0 - 1e-12
            if same_way and abs(float(n @ (np.asarray(wall.point) - np.asarray(walls[i].point)))) <= tol:
                said = f"[[wall]] #{j + 1} is the plane of [[wall]] #{i + 1}, facing the same way: keep one"
                raise DataError(said)


def contact_directions(scene) -> list[np.ndarray]:
    """Unit transverse directions a planar solve must keep in its plane: of each wall's normal and
    each lumen centreline point (a wall or lumen off the plane makes the scene 3D)."""
    vectors = [np.asarray(w.normal, float) for w in scene.walls]
    if scene.lumen is not None:
        size = max(float(np.abs(np.asarray(scene.lumen.centreline)).max()), scene.lumen.radius)
        vectors += [np.asarray(p, float) / size for p in scene.lumen.centreline]
    return [v[:2] / np.linalg.norm(v[:2]) for v in vectors if np.linalg.norm(v[:2]) > 1e-12]
