"""Material moduli derived from the rod stiffnesses and the tube section.

The fits give section stiffnesses (physics.md): the axial stiffness ``E_e = E A`` [N], the
bending stiffness ``E_b = E I`` [N m^2] and the torsional stiffness ``E_t = G J`` [N m^2].
For a circular tube of outer radius R_o and inner radius R_i

    A = pi (R_o^2 - R_i^2),    I = pi/4 (R_o^4 - R_i^4),    J = 2 I = pi/2 (R_o^4 - R_i^4),

so the material moduli are

    E = E_e / A  (from extension),    E = E_b / I  (from bending),    G = E_t / J  (torsion).

For one isotropic, linear material the two Young's moduli agree; their disagreement
measures anisotropy, rate dependence (E_e is the long-term modulus of the standard linear
solid), or a wrong section. The diameters are taken as exact: the standard error of a
modulus carries only the stiffness's (relative error unchanged); a diameter error of
1 % moves E_b / I by about 4 % and E_e / A by about 2 %, which the agreement check cannot
tell from a material effect. Everything here is SI (Pa); the report formats MPa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Section quantity each stiffness is divided by, and the modulus it gives.
MODULUS_OF = {"E_e": ("area", "E"), "E_b": ("second_moment", "E"), "E_t": ("polar_moment", "G")}


@dataclass(frozen=True)
class Modulus:
    """A material modulus from one stiffness: ``value`` and ``stderr`` in Pa."""

    name: str  # "E" or "G"
    source: str  # the stiffness it comes from: "E_e", "E_b" or "E_t"
    value: float
    stderr: float | None


@dataclass(frozen=True)
class Agreement:
    """E from extension against E from bending: relative difference and its z score."""

    relative_difference: float  # (E_b/I - E_e/A) / mean of the two
    z: float | None  # |difference| / combined standard error (None: a stderr is missing)

    @property
    def agree(self) -> bool | None:
        """Within two combined standard errors (None when there is no error to compare with)."""
        return None if self.z is None else self.z <= 2.0


def _check_radii(outer_radius: float, inner_radius: float) -> None:
    if not (outer_radius > inner_radius >= 0.0) or not math.isfinite(outer_radius):
        raise ValueError(f"need outer radius > inner radius >= 0, got {outer_radius} and {inner_radius}")


def area(outer_radius: float, inner_radius: float = 0.0) -> float:
    """Cross-section area A = pi (R_o^2 - R_i^2) [m^2]."""
    _check_radii(outer_radius, inner_radius)
    return math.pi * (outer_radius**2 - inner_radius**2)


def second_moment(outer_radius: float, inner_radius: float = 0.0) -> float:
    """Second moment of area I = pi/4 (R_o^4 - R_i^4) [m^4]."""
    _check_radii(outer_radius, inner_radius)
    return 0.25 * math.pi * (outer_radius**4 - inner_radius**4)


def polar_moment(outer_radius: float, inner_radius: float = 0.0) -> float:
    """Polar moment of area J = 2 I = pi/2 (R_o^4 - R_i^4) [m^4]."""
    return 2.0 * second_moment(outer_radius, inner_radius)


def modulus(
    source: str, stiffness: float, stderr: float | None, *, outer_radius: float, inner_radius: float = 0.0
) -> Modulus:
    """E = E_e / A, E = E_b / I or G = E_t / J for ``source`` in ``MODULUS_OF`` (SI in, Pa out)."""
    if source not in MODULUS_OF:
        raise ValueError(f"no modulus from {source!r}; expected one of {', '.join(MODULUS_OF)}")
    section_name, name = MODULUS_OF[source]
    section = {"area": area, "second_moment": second_moment, "polar_moment": polar_moment}[section_name]
    size = section(outer_radius, inner_radius)
    return Modulus(name, source, stiffness / size, None if stderr is None else stderr / size)


def agreement(from_extension: Modulus, from_bending: Modulus) -> Agreement:
    """How far E_e/A and E_b/I are apart: relative to their mean, and in combined standard errors."""
    a, b = from_extension, from_bending
    mean = 0.5 * (a.value + b.value)
    difference = b.value - a.value
    relative = difference / mean if mean else math.inf
    if a.stderr is None or b.stderr is None:
        return Agreement(relative, None)
    combined = math.hypot(a.stderr, b.stderr)
    z = abs(difference) / combined if combined > 0 else (0.0 if difference == 0 else math.inf)
    return Agreement(relative, z)
