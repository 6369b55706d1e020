"""Newton's start for a magnetised rod in a field beyond buckling: the rod turned into the field
(issue 32.3).

A planar rod of uniform bending stiffness (E_b = 1 scaled) magnetised along d3 by mu per length
over its whole length, in a uniform field B, bends as theta'' = |mu B| sin(theta - psi), psi the
angle at which mu d3 lies along B (taken the short way: the way the field's torque turns the
straight rod). With phi = psi - theta: phi'' = k^2 sin(phi), k = sqrt(|mu B|), phi(0) = psi (the
clamp), phi'(1) = 0 (a free tip). On a half-infinite rod its decaying solution is
tan(phi / 4) = tan(psi / 4) e^{-k s}; the free tip is its image about s = 1:

    tan(phi / 4) = tan(psi / 4) cosh(k (1 - s)) / cosh(k),

exact at both ends, in the linear limit (phi = psi cosh(k (1 - s)) / cosh(k)) and as k grows.
Positions integrate (sin theta, cos theta) (no shear, no extension); the internal force is zero
(the field only turns the rod), so the mixed Newton's first tangent starts from zero stresses.

Only where the straight rod is buckled by the field (the axial part -mu B_3 beyond the straight
rod's buckling load (pi / 2)^2, where the continuation's definite probe fails at the full load,
:func:`matid.rod.newton.definite_step`) and the field is not within NEAR_REVERSAL of reversed
(there the straight rod is at or near a bifurcation: the side is no longer the torque's to
choose). :func:`matid.rod.cantilever.equilibrium` runs Newton at the full load from this start,
with the continuation from the straight rod as the fallback when it fails or is rejected.
Measured: theta within 8.9e-3 rad of the elastica at q = |mu B| = 6.4, 120 deg (1.5e-4 at q = 20,
2.4e-9 at 100; the linearised phi = psi cosh(k (1 - s)) / cosh(k): 8.5e-2, 7.8e-2, 7.8e-2); P1's
4-element mesh (q = 6.4, 120 deg) from it: corrections 9.1e-3, 3.1e-5, 4.3e-10, 3 evaluations
against 13 for the probe and the continuation (4 with the displacements' stresses in the first
tangent: second correction 9e-3).
"""

from __future__ import annotations

import math

import numpy as np

from matid.rod.models import PLANAR
from matid.rod.terms.magnetisation import Magnetisation

#: The straight clamped-free rod's buckling load in scaled units: theta'' + c theta = 0 with
#: theta(0) = 0, theta'(1) = 0 has a nonzero solution first at c = (pi / 2)^2.
BUCKLING = (math.pi / 2.0) ** 2
#: Fields closer than this to reversed (psi = 180 deg) keep the continuation. Measured (P1's rod,
#: q = 2.4 .. 50): the start and the continuation agree to round-off up to 179.8 deg; closer, the
#: continuation takes the mirror branch or fails (a ConvergenceError), and at 180 deg (the
#: straight rod an equilibrium, buckled beyond the bifurcation) it must fail: the bench's
#: "field reversal" case.
NEAR_REVERSAL = math.radians(1.0)
#: Gauss-Legendre rule integrating (sin theta, cos theta) between neighbouring dofs.
_GAUSS = np.polynomial.legendre.leggauss(5)


def aligned(system) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`turned` of a system (a :class:`matid.rod.system.RodSystem`)."""
    return turned(system.model, system.rod, system.loads, system.disc)


def turned(model: str, rod, loads, disc) -> tuple[np.ndarray, np.ndarray] | None:
    """(the rod turned into the field at every dof of ``disc`` (nscalar, 3), zero point stresses
    (ne, nq, 2)), or None where the start does not apply (module docstring): not planar, segments
    or precurvature, any load but one magnetisation along d3 over the whole rod, a field the
    straight rod does not buckle in or within NEAR_REVERSAL of reversed."""
    if model != PLANAR or rod.segments or any(rod.kappa_ref) or len(loads) != 1:
        return None
    term = loads[0]
    if not isinstance(term, Magnetisation) or term.directed or len(term.along_d3) != 1:
        return None
    start, end, mu = term.along_d3[0]
    bx, bz = mu * term.B[0], mu * term.B[2]  # d3 = (sin theta, cos theta) lines up with mu B
    psi = math.atan2(bx, bz)
    if start > 0.0 or end < 1.0 or -bz <= BUCKLING or math.pi - abs(psi) < NEAR_REVERSAL:
        return None
    k, tan4 = math.sqrt(math.hypot(bx, bz)), math.tan(psi / 4.0)
    order = np.argsort(disc.s_dof, kind="stable")
    s = disc.s_dof[order]
    h = np.diff(s)
    x, w = _GAUSS
    points = np.concatenate([s, (s[:-1, None] + (0.5 * h)[:, None] * (x + 1.0)).ravel()])
    theta = psi - 4.0 * np.arctan(tan4 * np.cosh(k * (1.0 - points)) / math.cosh(k))
    inner = theta[s.size :].reshape(-1, x.size)
    U = np.empty((s.size, 3))
    U[order[0], :2] = 0.0
    U[order[1:], 0] = np.cumsum(0.5 * h * (np.sin(inner) @ w))
    U[order[1:], 1] = np.cumsum(0.5 * h * (np.cos(inner) @ w))
    U[order, 2] = theta[: s.size]
    return U, np.zeros(disc.s_quad.shape + (2,))
