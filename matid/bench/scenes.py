"""The bench scenes, built as scene dictionaries in SI (matid.rod.scenes.scene_from_dict).

Every scene is a 30 mm rod. Loads are given by their scaled size, so the
numbers of physics.md section 5 can be read off directly:

- magnetic cantilever: q = mu B L^2/E_b, magnetisation over the whole rod,
  field at ``psi`` from the undeflected axis (towards +x);
- tip force: alpha = F L^2/E_b along +x (perpendicular to the rod);
- end moment: M = 2 pi ``turns`` E_b/L about +y (a closed circle for one turn);
- stiffnesses E_s, E_e given scaled (E L^2/E_b).
"""

from __future__ import annotations

import math

from matid.rod.bend import BendGeometry
from matid.rod.scenes import Scene, scene_from_dict

L = 0.03  # m
E_B = 9e-5  # N m^2
B = 0.04  # T
STIFF = 1e8  # scaled E_s, E_e of the "practically inextensible, unshearable" scenes
SPAN = 0.01  # three-point bend span, m
BEND_E = (6.5e-5, 21.0, 120.0)  # E_b [N m^2], E_s [N], E_e [N] of the bend (demo tube)


def _rod(E_s: float = STIFF, E_e: float = STIFF, length: float = L, **extra) -> dict:
    scale = E_B / L**2
    return {"length": length, "E_b": E_B, "E_t": E_B, "E_s": E_s * scale, "E_e": E_e * scale, **extra}


def field(psi_deg: float, strength: float = B) -> list[float]:
    psi = math.radians(psi_deg)
    return [strength * math.sin(psi), 0.0, strength * math.cos(psi)]


def magnetic(q: float = 6.4, psi_deg: float = 120.0, *, E_s: float = STIFF, E_e: float = STIFF) -> Scene:
    """Distributed magnetisation mu = q E_b/(B L^2) over the whole rod, field at psi."""
    mu = q * E_B / (B * L**2)
    return scene_from_dict(
        {
            "rod": _rod(E_s, E_e),
            "field": {"B": field(psi_deg)},
            "magnetization": [{"from": 0.0, "to": L, "per_length": mu}],
        }
    )


def tip_force(alpha: float = 2.0, *, E_s: float = STIFF, E_e: float = STIFF) -> Scene:
    """Dead tip force F = alpha E_b/L^2 along +x."""
    return scene_from_dict({"rod": _rod(E_s, E_e), "tip": {"force": [alpha * E_B / L**2, 0.0, 0.0]}})


def end_moment(turns: float = 1.0, *, E_s: float = STIFF, E_e: float = STIFF) -> Scene:
    """Pure end moment M = 2 pi turns E_b/L about +y: the rod curls into an arc of ``turns`` circles."""
    M = 2.0 * math.pi * turns * E_B / L
    return scene_from_dict({"rod": _rod(E_s, E_e), "tip": {"moment": [0.0, M, 0.0]}})


def rigid_tip_magnet(
    *, stiff: float = STIFF, rigid_length: float = 0.1, moment: float = 2.0, psi_deg: float = 120.0
) -> Scene:
    """A tip magnet (scaled m B L/E_b = ``moment``) in a rigid body over the last ``rigid_length`` L."""
    m = moment * E_B / (B * L)
    return scene_from_dict(
        {
            "rod": _rod(stiff, stiff),
            "field": {"B": field(psi_deg)},
            "segment": [{"from": (1.0 - rigid_length) * L, "to": L, "rigid": True}],
            "magnet": [{"at": L, "moment": m}],
        }
    )


def spatial(*, stiff: float = 1e6, rigid: bool = False) -> Scene:
    """A 3D scene: precurved (kappa_ref along e2), tip magnet in a field along +y, compressive tip force.

    No plane holds every load, so the full (r, q) model runs. ``rigid`` puts the
    magnet in a rigid body over the last 3 mm.
    """
    scale = E_B / L**2
    raw = {
        "rod": _rod(stiff, stiff, E_t=0.7 * E_B, precurvature=[0.0, 20.0, 0.0]),
        "magnet": [{"at": L, "moment": 0.0125}],
        "field": {"B": [0.0, 0.005, 0.0]},
        "tip": {"force": [-scale, 0.0, -scale]},
    }
    if rigid:
        raw["segment"] = [{"from": 0.9 * L, "to": L, "rigid": True}]
    return scene_from_dict(raw)


def bend_geometry(specimen_length: float = 0.03) -> BendGeometry:
    """The 10 mm three-point bend of the demo tube (supports and nose of 2 mm radius, 2.4 mm tube)."""
    return BendGeometry(
        span=SPAN,
        specimen_length=specimen_length,
        support_radius=0.002,
        nose_radius=0.002,
        outer_diameter=0.0024,
    )


# -- contact (issue 31): walls and a lumen; the tube is 1 mm across -------------------------------

R_O = 0.0005  # outer radius of the contact scenes' tube, m (L/60)


def wall(point_xz: tuple[float, float], normal_xz: tuple[float, float]) -> dict:
    """A [[wall]] entry in the x-z plane: ``point_xz`` in units of L, the normal towards the tube."""
    n = math.hypot(*normal_xz)
    return {
        "point": [point_xz[0] * L, 0.0, point_xz[1] * L],
        "normal": [normal_xz[0] / n, 0.0, normal_xz[1] / n],
    }


def touching(angle_deg: float) -> dict:
    """A wall at ``angle_deg`` from the rod's axis (towards +x) that touches the tube's surface at the
    clamp: its point is R_O from the clamp along -normal, so the gap there is exactly zero."""
    a = math.radians(angle_deg)
    n = (-math.cos(a), math.sin(a))
    return wall((-R_O * n[0] / L, -R_O * n[1] / L), n)


def with_contact(raw: dict, *, walls: tuple[dict, ...] = (), lumen: dict | None = None,
                 advance: list[float] | None = None) -> Scene:  # fmt: skip
    """A scene dictionary of this module (``raw``) with the tube's diameter, walls, a lumen and steps."""
    out = {**raw, "rod": {**raw["rod"], "outer_diameter": 2 * R_O}}
    if walls:
        out["wall"] = list(walls)
    if lumen is not None:
        out["lumen"] = lumen
    if advance is not None:
        out["advance"] = {"free_lengths": advance}
    return scene_from_dict(out)


def magnetic_raw(q: float = 6.4, psi_deg: float = 120.0, *, length: float = L) -> dict:
    """:func:`magnetic` as a dictionary (magnetisation over ``length``, q scaled by L)."""
    mu = q * E_B / (B * L**2)
    return {"rod": _rod(length=length), "field": {"B": field(psi_deg)},
            "magnetization": [{"from": 0.0, "to": length, "per_length": mu}]}  # fmt: skip


def tip_magnet_raw(moment: float, psi_deg: float, *, length: float = L, rigid: float = 0.0) -> dict:
    """A tip magnet of m B L/E_b = ``moment`` (L = 30 mm) at ``length``, in a rigid body over the last
    ``rigid`` L when given."""
    raw = {"rod": _rod(length=length), "field": {"B": field(psi_deg)},
           "magnet": [{"at": length, "moment": moment * E_B / (B * L)}]}  # fmt: skip
    if rigid:
        raw["segment"] = [{"from": length - rigid * L, "to": length, "rigid": True}]
    return raw


def tip_force_raw(alpha: float) -> dict:
    """:func:`tip_force` as a dictionary."""
    return {"rod": _rod(), "tip": {"force": [alpha * E_B / L**2, 0.0, 0.0]}}
