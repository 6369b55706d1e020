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


def _rod(E_s: float = STIFF, E_e: float = STIFF, **extra) -> dict:
    scale = E_B / L**2
    return {"length": L, "E_b": E_B, "E_t": E_B, "E_s": E_s * scale, "E_e": E_e * scale, **extra}


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
