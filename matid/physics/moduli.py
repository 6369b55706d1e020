"""Material moduli derived from the rod stiffnesses and the tube section.

The fits give section stiffnesses (physics.md): the axial stiffness ``E_e = E A`` [N], the
bending stiffness ``E_b = E I`` [N m^2] and the torsional stiffness ``E_t = G J`` [N m^2].
For a circular tube of outer radius R_o and inner radius R_i

    A = pi (R_o^2 - R_i^2),    I = pi/4 (R_o^4 - R_i^4),    J = 2 I = pi/2 (R_o^4 - R_i^4),

so the material moduli are

    E = E_e / A  (from extension),    E = E_b / I  (from bending),    G = E_t / J  (torsion).

Other sections (docs/contract.md section 10, :class:`Section`; Roark's Formulas for Stress
and Strain, 7th ed., tables A.1 and 10.1):

* a rectangle of width b and height h (h along the bending load): A = b h, I = b h^3 / 12,
  and Saint-Venant's torsion constant of a rectangle, long side a >= short side c,

      J = a c^3 / 3 [1 - (192 / pi^5) (c / a) sum_{n = 1, 3, 5, ...} tanh(n pi a / (2 c)) / n^5];

* an open (slit) tube, the slit taken as of zero width: A and I those of the closed tube
  (the slit removes no material from them), and the thin open section's torsion constant
  J = (1/3) s t^3 with s = pi (R_o + R_i) the wall's mid-line length and t = R_o - R_i
  the wall thickness (the closed tube's J is about 3 (R_m / t)^2 times larger).

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

import numpy as np

#: Section quantity (a Section property) each stiffness is divided by, and the modulus it gives.
MODULUS_OF = {"E_e": ("A", "E"), "E_b": ("I", "E"), "E_t": ("J", "G")}
#: Section shapes (docs/contract.md section 10).
SHAPES = ("tube", "slit", "rectangle")
#: Terms of the rectangle's torsion series: the tail after n terms is below (c/a) 192/pi^5 / (4 n^4).
SERIES_TERMS = 50


@dataclass(frozen=True)
class Section:
    """A specimen's cross-section in m: a tube (``inner_diameter`` 0: a rod), an open ``slit``
    tube, or a ``rectangle`` of ``width`` x ``height`` (height along the bending load)."""

    shape: str
    outer_diameter: float = 0.0
    inner_diameter: float = 0.0
    width: float = 0.0
    height: float = 0.0

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"section shape must be one of {', '.join(SHAPES)}, got {self.shape!r}")
        if self.shape == "rectangle":
            if not (0 < self.width < math.inf and 0 < self.height < math.inf):
                raise ValueError(f"need width > 0 and height > 0, got {self.width} and {self.height}")
            if self.outer_diameter or self.inner_diameter:
                raise ValueError("a rectangular section has no diameters")
            return
        _check_radii(0.5 * self.outer_diameter, 0.5 * self.inner_diameter)
        if self.width or self.height:
            raise ValueError("a tube section has no width or height")
        if self.shape == "slit" and not self.inner_diameter > 0:
            raise ValueError("a slit (open) tube needs an inner_diameter > 0: a slit rod is not a section")

    @property
    def radii(self) -> tuple[float, float]:
        return 0.5 * self.outer_diameter, 0.5 * self.inner_diameter

    @property
    def depth(self) -> float:
        """Outer extent along the bending load [m] (the contact geometry of a bend)."""
        return self.height if self.shape == "rectangle" else self.outer_diameter

    @property
    def A(self) -> float:
        """Cross-section area [m^2]."""
        return self.width * self.height if self.shape == "rectangle" else area(*self.radii)

    @property
    def I(self) -> float:  # noqa: E743 (the symbol of the formula)
        """Second moment of area about the bending axis [m^4]."""
        if self.shape == "rectangle":
            return self.width * self.height**3 / 12.0  # b h^3 / 12, bent along its height
        return second_moment(*self.radii)

    @property
    def J(self) -> float:
        """Saint-Venant torsion constant [m^4] (the polar moment only for a closed circular tube)."""
        if self.shape == "rectangle":
            return rectangle_torsion_constant(self.width, self.height)
        if self.shape == "slit":
            return open_tube_torsion_constant(*self.radii)
        return polar_moment(*self.radii)

    def describe(self) -> str:
        if self.shape == "rectangle":
            return f"rectangle {self.width * 1e3:.4g} mm x {self.height * 1e3:.4g} mm"
        kind = "slit (open) tube" if self.shape == "slit" else "tube" if self.inner_diameter else "rod"
        return f"{kind} {self.outer_diameter * 1e3:.4g}/{self.inner_diameter * 1e3:.4g} mm"


def rectangle_torsion_constant(width: float, height: float, terms: int = SERIES_TERMS) -> float:
    """Saint-Venant's series J = a c^3/3 [1 - 192/pi^5 (c/a) sum_odd tanh(n pi a/2c)/n^5] [m^4]."""
    a, c = max(width, height), min(width, height)
    n = 2 * np.arange(terms) + 1
    series = float(np.sum(np.tanh(n * math.pi * a / (2 * c)) / n**5))
    return a * c**3 / 3.0 * (1.0 - 192.0 / math.pi**5 * (c / a) * series)


def open_tube_torsion_constant(outer_radius: float, inner_radius: float) -> float:
    """Thin open section of a slit tube: J = (1/3) s t^3, s = pi (R_o + R_i), t = R_o - R_i [m^4]."""
    _check_radii(outer_radius, inner_radius)
    t = outer_radius - inner_radius
    return math.pi * (outer_radius + inner_radius) * t**3 / 3.0


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
    source: str,
    stiffness: float,
    stderr: float | None,
    *,
    section: Section | None = None,
    outer_radius: float | None = None,
    inner_radius: float = 0.0,
) -> Modulus:
    """E = E_e / A, E = E_b / I or G = E_t / J for ``source`` in ``MODULUS_OF`` (SI in, Pa out).

    The section is ``section`` or, for a closed circular tube, its radii.
    """
    if source not in MODULUS_OF:
        raise ValueError(f"no modulus from {source!r}; expected one of {', '.join(MODULUS_OF)}")
    if section is None:
        if outer_radius is None:
            raise ValueError("modulus needs a section or an outer radius")
        section = Section("tube", 2.0 * outer_radius, 2.0 * inner_radius)
    quantity, name = MODULUS_OF[source]
    size = getattr(section, quantity)
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
