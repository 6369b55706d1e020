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
In between, k is replaced by the kappa that makes it satisfy the equation's first integral
between the ends, phi'(0)^2 = 2 k^2 (cos phi(1) - cos psi) (:func:`_fitted`: a few secant steps
in floats). Positions integrate (sin theta, cos theta) (no shear, no extension); the internal
force is zero (the field only turns the rod), so the mixed Newton's first tangent starts from
zero stresses.

Only where the straight rod is buckled by the field (the axial part -mu B_3 beyond the straight
rod's buckling load (pi / 2)^2, where the continuation's definite probe fails at the full load,
:func:`matid.rod.newton.definite_step`) and the field is not within NEAR_REVERSAL of reversed
(there the straight rod is at or near a bifurcation: the side is no longer the torque's to
choose). :func:`matid.rod.cantilever.equilibrium` runs Newton at the full load from this start,
with the continuation from the straight rod as the fallback when it fails or is rejected.

Measured against scipy's elastica, largest error in theta (rad), fitted / with k / linearised:
q = |mu B| = 6.4 at 120 deg 1.1e-3 / 8.9e-3 / 8.5e-2; q = 20 at 150 deg 6.3e-5 / 3.7e-4 / 1.6e-1;
at q = 4, 170 deg kappa = 0.88 k is beyond KAPPA_SPREAD and k stays (1.6e-1). P1's 4-element mesh (q = 6.4,
120 deg) from it: corrections 1.0e-3, 3.9e-7, 2 evaluations (with k: 9.1e-3, 3.1e-5, 4.3e-10, 3;
with the displacements' stresses in the first tangent, 4), against 13 for the probe and the
continuation.
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
#: Fields beyond this |mu B| (scaled) keep the continuation. Measured (P1's rod at 120 deg): up to
#: 2e6 solve() gives the same tips with and without the start, within their estimates of the
#: elastica's; at 3e6 (a boundary layer 6e-4 L thick) the continuation fails, while from the start
#: Newton converges on every mesh and the estimate stops at 128 elements claiming 5.5e-7 for a true
#: tip error of 2e-4.
MAX_Q = 1e6
#: The first integral's kappa is used within this fraction of k (:func:`_fitted`). Measured
#: (P1's rod, field 90..179.5 deg, q 0.5..50): beyond it, near buckling and reversal (176 deg,
#: q = 2.8; 177 deg, q = 3), Newton failed from the fitted start where it converged from k.
KAPPA_SPREAD = 0.05
#: Gauss-Legendre rule integrating (sin theta, cos theta) between neighbouring dofs.
_GAUSS = np.polynomial.legendre.leggauss(5)


def aligned(system) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`turned` of a system (a :class:`matid.rod.system.RodSystem`)."""
    return turned(system.model, system.rod, system.loads, system.disc)


def turned(model: str, rod, loads, disc) -> tuple[np.ndarray, np.ndarray] | None:
    """(the rod turned into the field at every dof of ``disc`` (nscalar, 3), zero point stresses
    (ne, nq, 2)), or None where the start does not apply (module docstring): not planar, segments
    or precurvature, any load but one magnetisation along d3 over the whole rod, a field the
    straight rod does not buckle in, within NEAR_REVERSAL of reversed or beyond MAX_Q."""
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
    if math.hypot(bx, bz) > MAX_Q:
        return None
    tan4 = math.tan(psi / 4.0)
    k = _fitted(math.sqrt(math.hypot(bx, bz)), tan4, psi)
    order = np.argsort(disc.s_dof, kind="stable")
    s = disc.s_dof[order]
    h = np.diff(s)
    x, w = _GAUSS
    points = np.concatenate([s, (s[:-1, None] + (0.5 * h)[:, None] * (x + 1.0)).ravel()])
    decay = (np.exp(-k * points) + np.exp(k * (points - 2.0))) / (1.0 + math.exp(-2.0 * k))  # cosh ratio
    theta = psi - 4.0 * np.arctan(tan4 * decay)
    inner = theta[s.size :].reshape(-1, x.size)
    U = np.empty((s.size, 3))
    U[order[0], :2] = 0.0
    U[order[1:], 0] = np.cumsum(0.5 * h * (np.sin(inner) @ w))
    U[order[1:], 1] = np.cumsum(0.5 * h * (np.cos(inner) @ w))
    U[order, 2] = theta[: s.size]
    return U, np.zeros(disc.s_quad.shape + (2,))


def _fitted(k: float, t: float, psi: float) -> float:
    """kappa for tan(phi / 4) = t cosh(kappa (1 - s)) / cosh(kappa), t = tan(psi / 4), such that
    the first integral of phi'' = k^2 sin(phi), phi'(0)^2 = 2 k^2 (cos phi(1) - cos psi), holds
    (secant iterations from kappa = k); k when they find none within KAPPA_SPREAD of it."""

    def gap(kappa):
        slope = 4.0 * t * kappa * math.tanh(kappa) / (1.0 + t * t)  # -phi'(0)
        tip = 4.0 * math.atan(2.0 * t * math.exp(-kappa) / (1.0 + math.exp(-2.0 * kappa)))  # phi(1)
        return slope * slope - 2.0 * k * k * (math.cos(tip) - math.cos(psi))

    a, b = k, (1.0 - KAPPA_SPREAD) * k
    fa, fb = gap(a), gap(b)
    for _ in range(12):
        if fb == fa:
            break
        a, b, fa = b, b - fb * (b - a) / (fb - fa), fb
        if abs(b - k) > KAPPA_SPREAD * k:
            break
        fb = gap(b)
        if abs(b - a) < 1e-12 * k:
            return b
    return k
