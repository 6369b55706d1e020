"""Forward models that make the SYNTHETIC demo data (SI units throughout).

Each function computes the noise-free response of one lab test from known
stiffnesses; :mod:`matid.example.generate` adds the seeded noise and writes
the files. The equations are those of ``physics.md``:

- standard linear solid, section 1: ``F = k1 eps + f2``,
  ``f2' + (k2/eta) f2 = k2 eps'``, integrated exactly for a piecewise-linear
  strain history with ``f2 <- a f2 + eta r (1 - a)``, ``a = exp(-k2 dt/eta)``;
- tip magnet in a uniform field, section 5: ``theta = (m B L/E_b) sin(psi - theta)``;
- torsion: ``tau = E_t phi/L`` in the linear range, plus a documented
  departure beyond an onset twist per length (``torsion_torque``);
- three-point bend: ``bend_force``, a strong-form shooting model of the bend
  (:mod:`matid.example.bend_shooting`), independent of matid's rod model that the fit uses;
  for nose travel, ``bend_force_nose`` adds the local contact travel at the
  three contacts that a real tube shows (``contact_travel``, physics.md section 7).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

from matid.example.bend_shooting import bend_path
from matid.fits.shear.torsion import CONTACT_N, CONTACT_REF


def sls_force(
    t: np.ndarray,
    knots_t: np.ndarray,
    knots_eps: np.ndarray,
    *,
    k1: float,
    k2: float,
    eta: float,
) -> np.ndarray:
    """Force of the standard linear solid for a piecewise-linear strain history.

    The history is linear between ``(knots_t, knots_eps)`` and starts from rest
    (``knots_eps[0] == 0``). Merging the knots into the sample times makes the
    strain rate ``r`` constant on every step, so the exponential update
    ``f2_i = a f2_{i-1} + eta r (1 - a)``, ``a = exp(-k2 dt / eta)``, is exact
    (physics.md section 1); ``F = k1 eps + f2``. For a ramp ``eps = r t`` this
    is ``F = k1 r t + eta r (1 - exp(-k2 t / eta))``.
    """
    t = np.asarray(t, dtype=float)
    knots_t = np.asarray(knots_t, dtype=float)
    knots_eps = np.asarray(knots_eps, dtype=float)
    if knots_eps[0] != 0.0 or np.any(np.diff(knots_t) <= 0.0):
        raise ValueError("knots must start from rest (eps = 0) at increasing times")
    if t.min() < knots_t[0] or t.max() > knots_t[-1]:
        raise ValueError("sample times must lie within the strain history")
    grid = np.union1d(t, knots_t)
    eps = np.interp(grid, knots_t, knots_eps)
    f2 = np.zeros_like(grid)
    for i in range(1, grid.size):
        dt = grid[i] - grid[i - 1]
        rate = (eps[i] - eps[i - 1]) / dt
        a = math.exp(-k2 * dt / eta)
        f2[i] = a * f2[i - 1] + eta * rate * (1.0 - a)
    force = k1 * eps + f2
    return force[np.searchsorted(grid, t)]


def ramp(rate: float, eps_max: float, *, hold: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Knots of a constant-rate ramp from rest to ``eps_max``, optionally held ``hold`` s."""
    t_ramp = eps_max / rate
    if hold > 0.0:
        return np.array([0.0, t_ramp, t_ramp + hold]), np.array([0.0, eps_max, eps_max])
    return np.array([0.0, t_ramp]), np.array([0.0, eps_max])


def cycles(rate: float, eps_max: float, n: int, *, eps_min: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Knots of a ramp from rest to ``eps_max`` followed by ``n`` unload-reload cycles
    down to ``eps_min`` (ending unloaded at ``eps_min``), all at ``rate``."""
    knots_eps = np.array([0.0] + [eps_max, eps_min] * n)
    knots_t = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(knots_eps)))]) / rate
    return knots_t, knots_eps


def tip_angle(
    field: np.ndarray, field_angle: np.ndarray, *, moment: float, length: float, E_b: float
) -> np.ndarray:
    """Tip angle of a cantilever with a tip magnet in a uniform field.

    Solves ``theta = (m B L / E_b) sin(psi - theta)`` per point with brentq
    (physics.md section 5); the root lies between 0 and psi for |psi| < pi.
    """
    field, field_angle = np.broadcast_arrays(np.asarray(field, float), np.asarray(field_angle, float))
    theta = np.zeros(field.shape)
    for i, (b, psi) in enumerate(zip(field.flat, field_angle.flat, strict=True)):
        if not abs(psi) < math.pi:
            raise ValueError(f"field_angle {psi} rad outside (-pi, pi)")
        c = moment * b * length / E_b
        if c == 0.0 or psi == 0.0:
            continue
        theta.flat[i] = brentq(
            lambda th, c=c, psi=psi: th - c * math.sin(psi - th),
            min(0.0, psi),
            max(0.0, psi),
            xtol=1e-15,
            rtol=4 * np.finfo(float).eps,
        )
    return theta


def torsion_torque(
    twist_angle: np.ndarray,
    *,
    length: float,
    E_t: float,
    onset: float,
    scale: float,
    sign: float = -1.0,
) -> np.ndarray:
    """Torque of a twisted tube: linear up to an onset twist per length, then curved.

    With ``k = phi / L`` and ``x = max(|k| - onset, 0)``::

        tau = E_t (k + sign * sgn(k) * x^2 / (2 scale))

    i.e. ``tau = E_t phi / L`` exactly while ``|phi|/L <= onset`` (rad/m), and
    beyond it the tangent stiffness changes linearly with the excess twist,
    ``dtau/dk = E_t (1 + sign x / scale)``: softening for ``sign = -1``
    (zero slope at ``x = scale``), stiffening for ``sign = +1``. The law is a
    material property in twist per length, so a long tube twisted by the same
    angle stays linear while a short one leaves the linear range (paper, Fig. 3).
    """
    k = np.asarray(twist_angle, dtype=float) / length
    excess = np.maximum(np.abs(k) - onset, 0.0)
    if sign < 0 and np.any(excess >= scale):
        raise ValueError("twist beyond the softening law's peak torque")
    return E_t * (k + sign * np.sign(k) * excess**2 / (2.0 * scale))


def bend_force(d: np.ndarray, *, E_b: float, E_s: float, E_e: float, **geometry: float) -> np.ndarray:
    """Nose force of the three-point bend test against nose deflection ``d``; ``geometry``: span,
    specimen_length, support_radius, nose_radius, outer_diameter (SI).

    The strong-form shooting model of :mod:`matid.example.bend_shooting` (half model, sliding
    contact with the rollers and the nose, large deflection, shear and extension): a model
    other than the one matid fits (matid.rod.bend), agreeing with it to its discretisation
    error (tests/example/test_bend_shooting.py). In the small-deflection limit it tends to
    the Timoshenko closed form ``d = F S^3 / (48 E_b) + F S / (4 E_s)``.
    """
    d = np.asarray(d, dtype=float)
    flat = np.atleast_1d(d)
    order = np.argsort(flat, kind="stable")
    force = np.empty_like(flat)
    force[order] = bend_path(flat[order], E_b=E_b, E_s=E_s, E_e=E_e, **geometry)[0]
    return force.reshape(d.shape)


#: The 3D continuum tube's local contact travel (benchmarks/README.md, "The 3D tube"):
#: u = CONTACT_C (F / N)^CONTACT_N on the tube CONTACT_REF (E 50 MPa, R_m 1 mm, t 0.4 mm),
#: 2 mm rollers (spans 6-12 mm); CONTACT_N and CONTACT_REF are the fits' (shear_torsion).
CONTACT_C = 0.154e-3


def contact_travel(force, *, outer_diameter: float, inner_diameter: float, E: float) -> np.ndarray:
    """Nose travel taken up locally at the three contacts (indentation, ovalisation of the wall) [m].

    The law the 3D continuum tube measured, ``u = 0.154 mm (F/N)^0.82`` (secant
    compliance 0.23 mm/N at 0.1 N, falling with load), carried to another tube by
    dimensional analysis at fixed shape (u depends on F/E only, so ``F -> F E_ref/E``)
    and by the wall scaling ``R_m^1.5 / t^2.5`` of
    :func:`matid.fits.shear.torsion.local_compliance`. Good for tubes near the
    reference wall (t/R_m ~ 0.4); it is what makes synthetic nose travel look like
    a real tube's, not a correction.
    """
    R_m = 0.25 * (outer_diameter + inner_diameter)
    t = 0.5 * (outer_diameter - inner_diameter)
    ref = CONTACT_REF
    shape = (R_m / ref["R_m"]) ** 1.5 * (ref["t"] / t) ** 2.5
    F = np.maximum(np.asarray(force, dtype=float), 0.0)
    return CONTACT_C * shape * (F * ref["E"] / E) ** CONTACT_N


def bend_force_nose(d: np.ndarray, *, inner_diameter: float, E: float, **kwargs) -> np.ndarray:
    """Nose force against nose travel ``d`` of a real tube: the rod's deflection plus the local
    contact travel, ``d = d_rod(F) + contact_travel(F)`` (same keywords as :func:`bend_force`).

    Solved on the rod's own path: 161 rod deflections up to ``max(d)``, their total
    travel, and a monotone cubic (PCHIP) interpolation of F at ``d``.
    """
    from scipy.interpolate import PchipInterpolator

    d = np.asarray(d, dtype=float)
    rod = np.linspace(0.0, float(np.max(d)), 161)
    F = bend_force(rod, **kwargs)
    total = rod + contact_travel(
        F, outer_diameter=kwargs["outer_diameter"], inner_diameter=inner_diameter, E=E
    )
    return PchipInterpolator(total, F)(d)


def bend_centreline(
    d: np.ndarray, *, E_b: float, E_s: float, E_e: float, **geometry: float
) -> tuple[np.ndarray, np.ndarray]:
    """(centreline deflection, force) at increasing nose deflections ``d`` (same keywords as
    :func:`bend_force`): the mid-span centreline relative to the material sections at S/2, as
    a side camera measures it (what matid.fits.shear.centreline compares), from the same
    shooting model."""
    force, centre, _ = bend_path(np.asarray(d, dtype=float), E_b=E_b, E_s=E_s, E_e=E_e, **geometry)
    return centre, force


def unloading_force(
    d: np.ndarray, loading_force: np.ndarray, *, d_max: float, hysteresis: float
) -> np.ndarray:
    """Force on the unloading branch: below the loading curve by a fraction growing to
    ``hysteresis`` as the deflection returns to zero, ``F_u = F_l (1 - h (1 - d/d_max))``."""
    return np.asarray(loading_force) * (1.0 - hysteresis * (1.0 - np.asarray(d) / d_max))
