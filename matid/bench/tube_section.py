"""The tube of the ``vs_3d`` section: material, hollow circular section, and Timoshenko closed forms.

Material and section (isotropic, Pebax-like): E = 50 MPa, nu = 0.45, hollow circular tube
R_o = 1.2 mm, R_i = 0.8 mm. The 1D model gets the stiffnesses of that section,

    E_b = E I,  E_e = E A,  E_t = G J,  E_s = k G A,  G = E / (2 (1 + nu)),
    k = 6 (1 + nu)(1 + m^2)^2 / ((7 + 6 nu)(1 + m^2)^2 + (20 + 12 nu) m^2),  m = R_i / R_o

(Cowper's shear coefficient of a hollow circle, k = 0.576 here). The cases (cantilever, three-point
bend with cos^2 load patches) are described in :mod:`matid.bench.vs3d`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import cumulative_trapezoid, trapezoid

E = 50e6
NU = 0.45
R_O = 1.2e-3
R_I = 0.8e-3
CANTILEVER_LENGTH = 30e-3
SPAN = 10e-3
SPECIMEN_LENGTH = 30e-3
PATCH_HALF_LENGTH = 0.5e-3
PATCH_HALF_ANGLE = math.pi / 4

# -- section and closed forms --------------------------------------------------


@dataclass(frozen=True)
class Section:
    """Isotropic hollow circular tube: areas, shear coefficient and the 1D stiffnesses."""

    E: float = E
    nu: float = NU
    R_o: float = R_O
    R_i: float = R_I

    def __post_init__(self) -> None:
        if not (self.R_o > self.R_i >= 0 and self.E > 0 and -1 < self.nu < 0.5):
            raise ValueError("Section needs R_o > R_i >= 0, E > 0 and -1 < nu < 0.5")

    @property
    def G(self) -> float:
        return self.E / (2 * (1 + self.nu))

    @property
    def A(self) -> float:
        return math.pi * (self.R_o**2 - self.R_i**2)

    @property
    def I(self) -> float:  # noqa: E743 - the second moment of area is I in every textbook
        return math.pi / 4 * (self.R_o**4 - self.R_i**4)

    @property
    def k(self) -> float:
        """Cowper (1966) shear coefficient of a hollow circular section."""
        m2, nu = (self.R_i / self.R_o) ** 2, self.nu
        return 6 * (1 + nu) * (1 + m2) ** 2 / ((7 + 6 * nu) * (1 + m2) ** 2 + (20 + 12 * nu) * m2)

    def stiffness(self) -> dict[str, float]:
        """E_b, E_s, E_e, E_t of the 1D rod [N m^2, N, N, N m^2]."""
        return {
            "E_b": self.E * self.I,
            "E_s": self.k * self.G * self.A,
            "E_e": self.E * self.A,
            "E_t": self.G * 2 * self.I,
        }


def cantilever_compliance(sec: Section) -> float:
    """Timoshenko tip deflection per unit tip force: L^3/(3 E I) + L/(k G A) [m/N]."""
    L = CANTILEVER_LENGTH
    return L**3 / (3 * sec.E * sec.I) + L / (sec.k * sec.G * sec.A)


def bend_stiffness_point(sec: Section) -> float:
    """Timoshenko three-point bend, point loads: F/d = 1 / (S^3/(48 E I) + S/(4 k G A)) [N/m]."""
    return 1.0 / (SPAN**3 / (48 * sec.E * sec.I) + SPAN / (4 * sec.k * sec.G * sec.A))


def bend_stiffness_patch(sec: Section, half_length: float = PATCH_HALF_LENGTH) -> float:
    """Timoshenko three-point bend under the cos^2 load profiles of the 3D patches [N/m].

    Unit-load theorem on the half beam z in [0, specimen/2] (F = 1):
    d = 2 int (M^2 / EI + V^2 / kGA) dz, with q = -psi(z) + psi(z - S/2)/2 and
    psi(z) = cos^2(pi z / 2b) / b on |z| < b (unit integral over the full beam).
    """
    z = np.linspace(0.0, SPECIMEN_LENGTH / 2, 400_001)
    b = half_length

    def cum(u):  # int_{-b}^{u} psi, clipped to [0, 1]
        u = np.clip(u, -b, b)
        return (u + b) / (2 * b) + np.sin(math.pi * u / b) / (2 * math.pi)

    # shear force V(z) = sum of the loads beyond z (free end at specimen/2): nose half + support
    V = -(1.0 - cum(z)) + 0.5 * (1.0 - cum(z - SPAN / 2))
    M = cumulative_trapezoid(V, z, initial=0.0)
    M = M[-1] - M  # M(z) = int_z^end V: zero moment at the free end
    integrand = M**2 / (sec.E * sec.I) + V**2 / (sec.k * sec.G * sec.A)
    d = 2 * trapezoid(integrand, z)
    return 1.0 / d


#: The section of every ``vs_3d`` case (the default of the model runs).
TUBE = Section()
