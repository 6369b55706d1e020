"""The demo's three-point bend, solved in strong form by shooting (SYNTHETIC data's generator).

An independent model of the test that :mod:`matid.rod.bend` fits: it shares no code with
matid.rod (no mesh, no energy, no Newton of matid's); only the physics is the same
(physics.md sections 3-4, the planar Reissner rod with shear and extension):

    r' = nu1 d1 + nu3 d3,  theta' = m / E_b,  m' = nu1 n3 - nu3 n1,  n' = 0 between loads,
    nu1 = n1 / E_s,  nu3 = 1 + n3 / E_e,  (n1, n3) = (n.d1, n.d3),

with d3 = (sin theta, cos theta) and d1 = (cos theta, -sin theta) in (x, z), z along the
straight tube, x up. Half model by symmetry: s = 0 at mid-span with z(0) = 0, theta(0) = 0 and
the nose (a circle of radius R_nose + R_o about the centreline) touching it, x(0) = -d. The
internal force n = (N_x, N_z) is constant up to the support's contact section s = sigma, and
zero beyond it (the overhang is free and straight). At sigma the centreline lies on the offset
roller (radius R_support + R_o about its axis at z = S/2, x = -(R_support + R_o)), the section
is the one through the roller axis ((r - c).d3 = 0, physics.md section 7, alpha = 0), the
moment vanishes and the roller pushes along its normal, frictionless (n.d3 = 0 there). The
four unknowns (N_x, N_z, m(0), sigma) solve these four conditions: each trial integrates
the ODE by ``solve_ivp`` (DOP853, rtol 1e-11) and ``scipy.optimize.root`` (hybr) closes
them; the path is followed in nose deflection, each point starting from the last two.
The nose force is 2 N_x. Scaled: lengths by the span S, forces by E_b / S^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root

RTOL, ATOL = 1e-11, 1e-13


@dataclass(frozen=True)
class Rig:
    """A three-point bend in scaled units (span 1): half specimen length, offset radii, stiffnesses."""

    half: float  # half specimen length / S
    rho_support: float  # (R_support + R_o) / S
    rho_nose: float  # (R_nose + R_o) / S
    E_s: float  # E_s S^2 / E_b
    E_e: float  # E_e S^2 / E_b

    def rhs(self, N: tuple[float, float]):
        Nx, Nz = N

        def f(_s, y):
            x, z, th, m = y
            c, s = math.cos(th), math.sin(th)
            n1, n3 = Nx * c - Nz * s, Nx * s + Nz * c
            nu1, nu3 = n1 / self.E_s, 1.0 + n3 / self.E_e
            return [nu1 * c + nu3 * s, -nu1 * s + nu3 * c, m, nu1 * n3 - nu3 * n1]

        return f

    def shoot(self, unknowns: np.ndarray, d: float, stops: tuple[float, ...] = ()) -> tuple:
        """(residuals of the four conditions at sigma, states at ``stops`` inside (0, sigma))."""
        Nx, Nz, M0, sigma = (float(v) for v in unknowns)
        if not 0.0 < sigma < self.half:
            raise ValueError(f"the support contact section left the tube (s = {sigma:.4g} span)")
        inner = sorted(t for t in stops if 0.0 < t < sigma)
        sol = solve_ivp(
            self.rhs((Nx, Nz)), (0.0, sigma), [-d, 0.0, 0.0, M0], method="DOP853",
            t_eval=[*inner, sigma], rtol=RTOL, atol=ATOL,
        )  # fmt: skip
        if not sol.success:
            raise ValueError(f"shooting integration failed: {sol.message}")
        x, z, th, m = sol.y[:, -1]
        rho = self.rho_support
        residual = np.array([
            x - (-rho + rho * math.cos(th)),  # on the offset roller, r = c + rho d1
            z - (0.5 - rho * math.sin(th)),
            m,  # free of moment
            Nx * math.sin(th) + Nz * math.cos(th),  # frictionless: n along the roller normal d1
        ])  # fmt: skip
        return residual, dict(zip(inner, sol.y[:, :-1].T, strict=True)), sol.y[:, -1]

    def solve(self, d: float, guess: np.ndarray) -> np.ndarray:
        """The unknowns (N_x, N_z, m(0), sigma) at scaled nose deflection ``d``."""
        out = root(lambda u: self.shoot(u, d)[0], guess, method="hybr", options={"xtol": 1e-13})
        residual = self.shoot(out.x, d)[0]
        if not out.success and np.max(np.abs(residual)) > 1e-11:
            raise ValueError(f"shooting did not close at d = {d:.4g} span: {out.message}")
        return out.x

    def centreline(self, unknowns: np.ndarray, d: float) -> float:
        """x(S/2) - x(0): the material section at S/2 relative to mid-span (scaled)."""
        sigma = float(unknowns[-1])
        _, inner, end = self.shoot(unknowns, d, stops=(0.5,))
        if 0.5 in inner:
            return float(inner[0.5][0] + d)
        x, _, th, _ = end  # beyond sigma the overhang is straight along d3(sigma)
        return float(x + (0.5 - sigma) * math.sin(th) + d)


def bend_path(
    d: np.ndarray,
    *,
    E_b: float,
    E_s: float,
    E_e: float,
    span: float,
    specimen_length: float,
    support_radius: float,
    nose_radius: float,
    outer_diameter: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(nose force [N], mid-span centreline deflection relative to the sections at S/2 [m],
    support contact arc length from mid-span [m]) at increasing nose deflections ``d`` [m]."""
    d = np.asarray(d, dtype=float)
    if d.ndim != 1 or np.any(d < 0) or np.any(np.diff(d) < 0):
        raise ValueError("deflections must be non-negative and increasing")
    for name, value in [("E_b", E_b), ("E_s", E_s), ("E_e", E_e)]:
        if not value > 0.0:
            raise ValueError(f"{name} must be positive, got {value}")
    if not specimen_length > span > 0 or not outer_diameter > 0:
        raise ValueError("three-point bend needs specimen_length > span > 0 and outer_diameter > 0")
    S, R_o = span, 0.5 * outer_diameter
    rig = Rig(
        half=0.5 * specimen_length / S, rho_support=(support_radius + R_o) / S,
        rho_nose=(nose_radius + R_o) / S, E_s=E_s * S**2 / E_b, E_e=E_e * S**2 / E_b,
    )  # fmt: skip
    compliance = 1.0 / 48.0 + 1.0 / (4.0 * rig.E_s)  # small-deflection guess (Timoshenko)
    known: list[tuple[float, np.ndarray]] = []
    force, centre, sigma = (np.zeros(d.size) for _ in range(3))
    for i, di in enumerate(d / S):
        if len(known) >= 2 and known[-1][0] > known[-2][0]:
            (d0, u0), (d1, u1) = known[-2:]
            guess = u1 + (u1 - u0) * (di - d1) / (d1 - d0)
        elif known:
            guess = known[-1][1] * (di / known[-1][0] if known[-1][0] > 0 else 1.0)
            guess[-1] = known[-1][1][-1]
        else:
            F = di / compliance
            guess = np.array([0.5 * F, 0.0, 0.25 * F, 0.5])
        if di == 0.0:
            u = np.array([0.0, 0.0, 0.0, 0.5])  # unloaded: straight, the section at S/2 on the roller
        else:
            u = rig.solve(di, guess)
        known.append((di, u))
        force[i] = 2.0 * u[0] * E_b / S**2
        centre[i] = (rig.centreline(u, di) if di > 0 else 0.0) * S
        sigma[i] = u[-1] * S
    return force, centre, sigma
