"""The peer baseline: the same Cosserat rod as a first-order BVP for scipy ``solve_bvp``.

Scaled units (L = E_b = 1), clamped at s = 0, no distributed force, so the
internal force n equals the tip force F everywhere (n' = 0). Constitutive law
as matid's: n1 = E_s nu1, n3 = E_e (nu3 - 1), m = E_b (theta' - k_ref).

Planar (matid's convention d1 = (c, -s), d3 = (s, c) in (x, z)): y = (x, z, theta, m),

    r' = nu1 d1 + nu3 d3,  theta' = k_ref + m,  m' = n3 nu1 - n1 nu3 - mu B x d3

with (n1, n3) = (F.d1, F.d3). Spatial: y = (r, q, m) (q a Hamilton quaternion,
R(q) = [d1 d2 d3], m the lab-frame moment),

    r' = R nu,  q' = q (0, kappa)/2,  m' = -r' x F,  kappa = k_ref + C^-1 R^T m.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_bvp


@dataclass(frozen=True)
class Planar:
    E_s: float
    E_e: float
    F: tuple[float, float] = (0.0, 0.0)  # (F_x, F_z)
    muB: tuple[float, float] = (0.0, 0.0)  # mu (B_x, B_z)
    turn: float = 0.0  # initial guess theta = turn s (2 - s) (from a straight rod a field past 90 deg fails)

    def rhs(self, s, y):
        c, sn = np.cos(y[2]), np.sin(y[2])
        n1, n3 = self.F[0] * c - self.F[1] * sn, self.F[0] * sn + self.F[1] * c
        nu1, nu3 = n1 / self.E_s, 1.0 + n3 / self.E_e
        couple = self.muB[0] * c - self.muB[1] * sn  # mu (d3 x B) about the plane normal
        return np.array([nu1 * c + nu3 * sn, -nu1 * sn + nu3 * c, y[3], n3 * nu1 - n1 * nu3 - couple])

    def tip(self, tol: float = 1e-6, nodes: int = 11) -> np.ndarray:
        s = np.linspace(0.0, 1.0, nodes)
        y0 = np.zeros((4, nodes))
        y0[2] = self.turn * s * (2.0 - s)
        y0[0] = np.cumsum(np.sin(y0[2])) / nodes
        y0[1] = np.cumsum(np.cos(y0[2])) / nodes
        sol = solve_bvp(
            self.rhs, lambda a, b: np.array([a[0], a[1], a[2], b[3]]), s, y0, tol=tol, max_nodes=100000
        )
        if not sol.success:
            raise RuntimeError(f"solve_bvp: {sol.message}")
        x, z = sol.y[0, -1], sol.y[1, -1]
        return np.array([x, 0.0, z])


@dataclass(frozen=True)
class Spatial:
    E_t: float
    E_s: float
    E_e: float
    kappa_ref: tuple[float, float, float]
    F: tuple[float, float, float]

    def rhs(self, s, y):
        q = y[3:7] / np.linalg.norm(y[3:7], axis=0)
        q0, q1, q2, q3 = q
        a = q0 * q0 - q1 * q1 - q2 * q2 - q3 * q3
        R = np.array(
            [
                [a + 2 * q1 * q1, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
                [2 * (q2 * q1 + q0 * q3), a + 2 * q2 * q2, 2 * (q2 * q3 - q0 * q1)],
                [2 * (q3 * q1 - q0 * q2), 2 * (q3 * q2 + q0 * q1), a + 2 * q3 * q3],
            ]
        )  # (3, 3, n)
        F = np.asarray(self.F)
        nb = np.einsum("jin,j->in", R, F)  # body-frame force
        nu = np.array([nb[0] / self.E_s, nb[1] / self.E_s, 1.0 + nb[2] / self.E_e])
        mb = np.einsum("jin,jn->in", R, y[7:10])
        k = np.array(self.kappa_ref)[:, None] + mb / np.array([1.0, 1.0, self.E_t])[:, None]
        dr = np.einsum("ijn,jn->in", R, nu)
        dq = 0.5 * np.array(
            [
                -q1 * k[0] - q2 * k[1] - q3 * k[2],
                q0 * k[0] + q2 * k[2] - q3 * k[1],
                q0 * k[1] + q3 * k[0] - q1 * k[2],
                q0 * k[2] + q1 * k[1] - q2 * k[0],
            ]
        )
        dm = -np.cross(dr, F, axis=0)
        return np.concatenate([dr, dq, dm])

    def tip(self, tol: float = 1e-6, nodes: int = 11) -> np.ndarray:
        s = np.linspace(0.0, 1.0, nodes)
        y0 = np.zeros((10, nodes))
        y0[2], y0[3] = s, 1.0
        bc = lambda a, b: np.concatenate([a[:3], a[3:7] - [1, 0, 0, 0], b[7:10]])  # noqa: E731
        sol = solve_bvp(self.rhs, bc, s, y0, tol=tol, max_nodes=100000)
        if not sol.success:
            raise RuntimeError(f"solve_bvp: {sol.message}")
        return sol.y[:3, -1].copy()
