"""Newton's start for a planar rod turned by a field beyond buckling or by a dead tip force: the
rod turned into the field or the force (issue 32.3).

A planar rod of uniform bending stiffness (E_b = 1 scaled) magnetised along d3 by mu per length
over its whole length, in a uniform field B, bends as theta'' = |mu B| sin(theta - psi), psi the
angle at which mu d3 lies along B (taken the short way: the way the field's torque turns the
straight rod). A dead tip force F (and no tip moment) gives the same equation with |F| for
|mu B| and psi its angle from the unloaded d3: the moment (r(1) - r(s)) x F has M' = -r' x F.
With phi = psi - theta: phi'' = k^2 sin(phi), k = sqrt(|mu B|) or sqrt(|F|), phi(0) = psi (the
clamp), phi'(1) = 0 (a free tip). On a half-infinite rod its decaying solution is
tan(phi / 4) = tan(psi / 4) e^{-k s}; the free tip is its image about s = 1:

    tan(phi / 4) = tan(psi / 4) cosh(k (1 - s)) / cosh(k),

exact at both ends, in the linear limit (phi = psi cosh(k (1 - s)) / cosh(k)) and as k grows.
In between, k is replaced by the kappa that makes it satisfy the equation's first integral
between the ends, phi'(0)^2 = 2 k^2 (cos phi(1) - cos psi) (:func:`_fitted`: a few secant steps
in floats). Positions integrate (sin theta, cos theta) (no shear, no extension). The internal
force, the mixed Newton's first point stresses: zero in the field (it only turns the rod), F
everywhere under the tip force, (n1, n3) = (F.d1, F.d3) on the start's directors.

In a field only where the straight rod is buckled (the axial part -mu B_3 beyond the straight
rod's buckling load (pi / 2)^2, where the continuation's definite probe fails at the full load,
:func:`matid.rod.newton.definite_step`) and the field is not within NEAR_REVERSAL of reversed
(there the straight rod is at or near a bifurcation: the side is no longer the torque's to
choose); under a tip force at any load but near axial compression (COMPRESSED, BEYOND).
:func:`matid.rod.cantilever.equilibrium` runs Newton at the full load from this start, with the
continuation from the straight rod as the fallback when it fails or is rejected.

Measured against scipy's elastica, largest error in theta (rad), fitted / with k / linearised:
q = |mu B| = 6.4 at 120 deg 1.1e-3 / 8.9e-3 / 8.5e-2; q = 20 at 150 deg 6.3e-5 / 3.7e-4 / 1.6e-1;
at q = 4, 170 deg kappa = 0.88 k is beyond KAPPA_SPREAD and k stays (1.6e-1). P1's 4-element mesh (q = 6.4,
120 deg) from it: corrections 1.0e-3, 3.9e-7, 2 evaluations (with k: 9.1e-3, 3.1e-5, 4.3e-10, 3;
with the displacements' stresses in the first tangent, 4), against 13 for the probe and the
continuation. P2 (alpha = |F| = 5 at 90 deg): 4.1e-4 in theta, its stresses 1.9e-3 from the
converged ones (of 5); its 4-element mesh 2 evaluations (zero or the displacements' stresses: 3;
the straight rod: 7). Far from the half-infinite rod (small k, large psi) the start is poorer
(alpha = 1 at 120 deg: 0.17) yet still no dearer than the straight rod (module constants).
"""

from __future__ import annotations

import math

import numpy as np

from matid.rod.models import PLANAR
from matid.rod.terms.magnetisation import Magnetisation
from matid.rod.terms.tip import Tip

#: The straight clamped-free rod's buckling load in scaled units: theta'' + c theta = 0 with
#: theta(0) = 0, theta'(1) = 0 has a nonzero solution first at c = (pi / 2)^2.
BUCKLING = (math.pi / 2.0) ** 2
#: Fields closer than this to reversed (psi = 180 deg) keep the continuation. Measured (P1's rod,
#: q = 2.4 .. 50): the start and the continuation agree to round-off up to 179.8 deg; closer, the
#: continuation takes the mirror branch or fails (a ConvergenceError), and at 180 deg (the
#: straight rod an equilibrium, buckled beyond the bifurcation) it must fail: the bench's
#: "field reversal" case.
NEAR_REVERSAL = math.radians(1.0)
#: A dead tip force within COMPRESSED of compressing the straight rod along its axis keeps the
#: continuation unless it is beyond BEYOND times the buckling load (then within NEAR_REVERSAL).
#: Measured (solve() with and without the start, alpha 0.1..50 x beta 0..180 deg): below buckling
#: from 165 deg (alpha = 0.3) to 178 deg (2.4) the start took more evaluations (up to 26 against 21;
#: there the straight rod is stable and bent little, the start turned far over), as it did at
#: 178.5..179 deg up to 1.3 % beyond buckling (alpha 2.47, 2.5: 36-38 against 32); from 3.4 % beyond
#: (2.55) never.
COMPRESSED = math.radians(20.0)
BEYOND = 1.05
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
    """(the rod turned into the field or force at every dof of ``disc`` (nscalar, 3), point
    stresses (ne, nq, 2): zero in a field, a tip force's (n1, n3) on the start's directors), or None
    where the start does not apply (module docstring): not planar, segments or precurvature, any
    load but one magnetisation along d3 over the whole rod or one dead tip force, a field the
    straight rod does not buckle in, within NEAR_REVERSAL of reversed or beyond MAX_Q."""
    if model != PLANAR or rod.segments or any(rod.kappa_ref) or len(loads) != 1:
        return None
    pull = _pull(loads[0])
    if pull is None:
        return None
    bx, bz, force = pull
    psi = math.atan2(bx, bz)
    axial = math.pi - abs(psi)  # the angle from compressing the straight rod along its axis
    if force is None:  # a field that buckles the straight rod, not near reversed
        applies = -bz > BUCKLING and axial >= NEAR_REVERSAL
    else:  # a force near the axis only when it buckles the straight rod by BEYOND
        applies = axial >= (NEAR_REVERSAL if -bz > BEYOND * BUCKLING else COMPRESSED)
    if not applies or math.hypot(bx, bz) > MAX_Q:
        return None
    tan4 = math.tan(psi / 4.0)
    k = _fitted(math.sqrt(math.hypot(bx, bz)), tan4, psi)
    order = np.argsort(disc.s_dof, kind="stable")
    s = disc.s_dof[order]
    h = np.diff(s)
    x, w = _GAUSS
    inner = (s[:-1, None] + (0.5 * h)[:, None] * (x + 1.0)).ravel()
    points = np.concatenate([s, inner, disc.s_quad.ravel()])
    decay = (np.exp(-k * points) + np.exp(k * (points - 2.0))) / (1.0 + math.exp(-2.0 * k))  # cosh ratio
    theta = psi - 4.0 * np.arctan(tan4 * decay)
    U = np.empty((s.size, 3))
    U[order[0], :2] = 0.0
    along = theta[s.size : s.size + inner.size].reshape(-1, x.size)
    U[order[1:], 0] = np.cumsum(0.5 * h * (np.sin(along) @ w))
    U[order[1:], 1] = np.cumsum(0.5 * h * (np.cos(along) @ w))
    U[order, 2] = theta[: s.size]
    stress = np.zeros(disc.s_quad.shape + (2,))
    if force is not None:  # n = F everywhere: n1 = F.d1, n3 = F.d3, d1 = (cos, -sin), d3 = (sin, cos)
        at = theta[s.size + inner.size :].reshape(disc.s_quad.shape)
        c, sn = np.cos(at), np.sin(at)
        stress[..., 0], stress[..., 1] = bx * c - bz * sn, bx * sn + bz * c
    return U, stress


def _pull(term) -> tuple[float, float, bool | None] | None:
    """(x, z components of the vector d3 turns to, |.| = k^2; the tip force's True or None in a
    field) of the one load, or None when the start does not apply to it."""
    if isinstance(term, Tip):
        return None if any(term.moment) else (term.force[0], term.force[2], True)
    if not isinstance(term, Magnetisation) or term.directed or len(term.along_d3) != 1:
        return None
    start, end, mu = term.along_d3[0]
    if start > 0.0 or end < 1.0:
        return None
    return mu * term.B[0], mu * term.B[2], None  # d3 = (sin theta, cos theta) lines up with mu B


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
