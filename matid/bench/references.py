"""Independent references for the bench: closed forms, an elastica BVP, Richardson.

Planar rod in scaled units (lengths by L, forces by E_b/L^2, moments by E_b/L),
angle theta from the undeflected axis e3 towards e_x, d1 = (cos t, -sin t) and
d3 = (sin t, cos t) in (x, z). With a dead tip force F, a tip moment M and a
magnetisation q = mu B L^2/E_b along d3 in a field of unit direction b, the
internal force is n = F everywhere and (Reissner's planar rod, physics.md s. 3)

    theta' = m,   m' = -[(r' x F)_y + q (d3 x b)_y] = -[z' F_x - x' F_z + q (cos t b_x - sin t b_z)]
    r' = nu1 d1 + nu3 d3,   nu1 = F.d1 / E_s,   nu3 = 1 + F.d3 / E_e
    theta(0) = 0, r(0) = 0, m(1) = M + m_tip sin(psi - theta(1)) + a (d3 x F)_y

(m_tip = m B L/E_b of a tip magnet along d3; a the arm of a rigid tip body, scaled, see Elastica.arm).

With E_s, E_e -> infinity this is Kirchhoff's elastica. It is solved twice,
with :func:`scipy.integrate.solve_bvp` (collocation) and by shooting on m(0)
with :func:`scipy.integrate.solve_ivp` (DOP853): their difference is the
reference's own accuracy. Nothing here calls the matid solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_bvp, solve_ivp
from scipy.optimize import brentq, newton

BVP_TOL = 1e-10
IVP_TOL = 1e-13


@dataclass(frozen=True)
class Elastica:
    """A planar clamped rod in scaled units (see the module docstring)."""

    force: tuple[float, float] = (0.0, 0.0)  # (F_x, F_z)
    moment: float = 0.0
    q: float = 0.0
    field_angle: float = 0.0  # radians from e3 towards e_x
    E_s: float = math.inf
    E_e: float = math.inf
    tip_magnet: float = 0.0  # m B L/E_b of a magnet along d3 at the tip, in the same field
    arm: float = 0.0  # a rigid body of this length (scaled) continues the rod along d3; F acts at its end

    def end_moment(self, theta: float) -> float:
        """m(1): the tip moment, the tip magnet's couple (d3 x b)_y m B = m B sin(psi - theta) and the
        moment of the force at the end of the rigid arm, a (d3 x F)_y = a (cos t F_x - sin t F_z)."""
        Fx, Fz = self.force
        arm = self.arm * (math.cos(theta) * Fx - math.sin(theta) * Fz)
        return self.moment + self.tip_magnet * math.sin(self.field_angle - theta) + arm

    def rhs(self, s: np.ndarray, y: np.ndarray) -> np.ndarray:
        t, m = y[0], y[1]
        c, sn = np.cos(t), np.sin(t)
        Fx, Fz = self.force
        nu1 = (Fx * c - Fz * sn) / self.E_s
        nu3 = 1.0 + (Fx * sn + Fz * c) / self.E_e
        dx, dz = nu1 * c + nu3 * sn, -nu1 * sn + nu3 * c
        bx, bz = math.sin(self.field_angle), math.cos(self.field_angle)
        dm = -(dz * Fx - dx * Fz + self.q * (c * bx - sn * bz))
        return np.array([m, dm, dx, dz])


def solve_elastica(rod: Elastica, *, guess: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
    """Tip (x, z, theta) by shooting, checked by collocation; 'agreement' is their largest difference.

    ``guess``: (s, y) of a nearby solution (selects the branch); default the straight rod.
    """
    if guess is None:
        s = np.linspace(0.0, 1.0, 50)
        y = np.zeros((4, s.size))
        y[3] = s
    else:
        s, y = guess

    def bc(ya, yb):
        return np.array([ya[0], ya[2], ya[3], yb[1] - rod.end_moment(yb[0])])

    sol = solve_bvp(rod.rhs, bc, s, y, tol=BVP_TOL, max_nodes=100000)
    if sol.status != 0:
        raise RuntimeError(f"reference BVP did not converge: {sol.message}")
    bvp_tip = sol.y[[2, 3, 0], -1]
    shot_tip = _shoot(rod, float(sol.y[1, 0]))
    return {
        "tip": shot_tip,
        "agreement": float(np.max(np.abs(shot_tip - bvp_tip))),
        "solution": (sol.x, sol.y),
    }


def _integrate(rod: Elastica, m0: float, **options):
    """The initial-value problem from the clamp with m(0) = m0 (DOP853 at IVP_TOL)."""
    return solve_ivp(
        rod.rhs, (0.0, 1.0), [0.0, m0, 0.0, 0.0], method="DOP853", rtol=IVP_TOL, atol=IVP_TOL, **options
    )


def _moment_miss(rod: Elastica, m0: float) -> float:
    """m(1) - M of the initial-value problem: the shooting function."""
    y = _integrate(rod, m0).y[:, -1]
    return y[1] - rod.end_moment(y[0])


def _shoot(rod: Elastica, m0: float) -> np.ndarray:
    """Tip (x, z, theta) of the shooting solution, Newton on m(0) from ``m0``."""
    y = _integrate(rod, newton(lambda a: _moment_miss(rod, a), m0, tol=1e-14, maxiter=50)).y[:, -1]
    return np.array([y[2], y[3], y[0]])


def shooting(rod: Elastica, m0: float, samples: int = 2001) -> tuple[float, np.ndarray]:
    """(m(0), y = (theta, m, x, z) at ``samples`` even s in [0, 1]) of the shooting solution, Newton on
    m(0) from ``m0`` (a nearby solution's: the branch)."""
    m0 = newton(lambda a: _moment_miss(rod, a), m0, tol=1e-14, maxiter=50)
    return float(m0), _integrate(rod, m0, t_eval=np.linspace(0.0, 1.0, samples)).y


def end_state(rod: Elastica, m0: float) -> np.ndarray:
    """(theta, m, x, z) at s = 1 of the initial-value problem with m(0) = m0."""
    return _integrate(rod, m0).y[:, -1]


def follow_elastica(rod: Elastica, steps: int = 8) -> dict:
    """Solve by continuation in the load (q, F, M scaled together from 0), to stay on the natural branch."""
    guess = None
    for k in range(1, steps + 1):
        f = k / steps
        part = Elastica(
            (rod.force[0] * f, rod.force[1] * f),
            rod.moment * f,
            rod.q * f,
            rod.field_angle,
            rod.E_s,
            rod.E_e,
            rod.tip_magnet * f,
            rod.arm,
        )
        out = solve_elastica(part, guess=guess)
        guess = out["solution"]
    return out


def first_branch(rod: Elastica, *, k_max: float = 20.0, samples: int = 400) -> dict:
    """The solution with the smallest positive root m(0) > 0 of m(1; m(0)) = M (shooting, then collocation).

    Used where continuation can jump branches (near a bifurcation): scanning m(0)
    upwards from 0+ finds the first-mode branch bending towards +x, the natural
    branch of a field slightly to the +x side of the reversed axis.
    """
    grid = np.geomspace(1e-4, k_max, samples)
    g = np.array([_moment_miss(rod, k) for k in grid])
    cross = np.nonzero(np.sign(g[:-1]) != np.sign(g[1:]))[0]
    if cross.size == 0:
        raise RuntimeError("no root of the shooting function on the scanned interval")
    k = cross[0]
    m0 = brentq(lambda a: _moment_miss(rod, a), grid[k], grid[k + 1], xtol=1e-15, rtol=1e-15)
    ivp = _integrate(rod, m0, dense_output=True)
    s = np.linspace(0.0, 1.0, 200)
    return solve_elastica(rod, guess=(s, ivp.sol(s)))


def circle_shape(s: np.ndarray, turns: float) -> np.ndarray:
    """Exact centreline (x, z)/L under a pure end moment M = 2 pi turns E_b/L: a circular arc."""
    theta = 2.0 * math.pi * turns * s
    rho = 1.0 / (2.0 * math.pi * turns)
    return np.column_stack([rho * (1.0 - np.cos(theta)), rho * np.sin(theta)])


def rigid_tip_magnet(flexible: float, rigid: float, moment: float, psi: float) -> np.ndarray:
    """Tip (x, z, theta)/L: flexible part [0, a] bent into an arc by the tip magnet's torque, rigid rest.

    The field exerts no force, so the flexible part carries the constant moment
    tau = m sin(psi - theta) (scaled m = m B L/E_b): theta = tau a, theta = m a sin(psi - theta).
    """
    a, ell = flexible, rigid
    theta = brentq(lambda t: t - moment * a * math.sin(psi - t), 0.0, psi)
    x = a / theta * (1.0 - math.cos(theta)) + ell * math.sin(theta)
    z = a / theta * math.sin(theta) + ell * math.cos(theta)
    return np.array([x, z, theta])


def richardson(coarse: np.ndarray, fine: np.ndarray, order: float = 4.0) -> np.ndarray:
    """Extrapolate values on meshes h and h/2 with the asymptotic order: f + (f - f_H) / (2^p - 1)."""
    return fine + (fine - coarse) / (2.0**order - 1.0)
