"""The three-point bend rig's contacts: the support and the nose (:mod:`matid.rod.bend`).

Each holds one vertex of the half model outside a rigid circle (:class:`matid.physics.contact.Circle`)
by a Lagrange multiplier, an unknown of the bordered bend system
(:class:`matid.rod.bend_system.BendSystem`), not a penalty on the rod's dofs: so these terms are
of kind ``"multiplier"``, which :class:`matid.rod.system.RodSystem` does not sum itself. The bend
system binds each (:meth:`Held.prepare`: the free dofs of its vertex) and sums, at every
evaluation, its gap row g, its normal column (the residual's -G^T lam) and its Hessian entries
-lam (I - n n^T)/|r - c| on the free (x, z) dofs of its vertex. The support adds the equation of
its contact section (h = 0, whose unknown is the section's arc length); the nose moves with the
load factor (its centre at rho - lam d_max), which gives dR/dlam.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from matid.physics.contact import Circle
from matid.rod.models import PLANAR
from matid.rod.terms.base import Term


class Held(Term):
    """A rigid circle the vertex ``vertex`` of the half model stays outside of, by a multiplier."""

    models: ClassVar[tuple[str, ...]] = (PLANAR,)
    kind: ClassVar[str] = "multiplier"
    vertex: int = 0

    def circle(self, lam: float) -> Circle:
        raise NotImplementedError

    def prepare(self, system) -> np.ndarray:
        """Free-dof index of (x, z, theta) at the vertex (-1 where fixed) in the rod system."""
        return system.index[3 * self.vertex : 3 * self.vertex + 3]

    def normal_dofs(self, prep: np.ndarray) -> list[int]:
        """The components (0: x, 1: z) of the vertex that are free: where the normal goes."""
        return [a for a in (0, 1) if prep[a] >= 0]

    def gap(self, U: np.ndarray, lam: float) -> tuple[float, float, float, float]:
        """(g, n_x, n_z, |r - c|) of the vertex at the state U (all dofs)."""
        k = 3 * self.vertex
        return self.circle(lam).gap(float(U[k]), float(U[k + 1]))

    def hessian(self, prep: np.ndarray, gap: tuple, mult: float) -> tuple[list, list, list]:
        """(rows, cols, values) of -mult (I - n n^T)/|r - c| on the free (x, z) dofs of the vertex."""
        normal = self.normal_dofs(prep)
        pairs = [(a, b) for a in normal for b in normal]
        rows = [prep[a] for a, _ in pairs]
        cols = [prep[b] for _, b in pairs]
        values = [-float(mult) * ((a == b) - gap[1 + a] * gap[1 + b]) / gap[3] for a, b in pairs]
        return rows, cols, values


class Support(Held):
    """The support: a circle fixed at ``circle``, touching the vertex of the contact section."""

    def __init__(self, circle: Circle, vertex: int):
        self.fixed, self.vertex = circle, vertex

    def circle(self, lam: float) -> Circle:
        return self.fixed

    def section(self, U: np.ndarray) -> tuple[float, np.ndarray]:
        """h = (r_v - c) . d3(theta_v) of the contact section and its gradient in (x, z, theta)."""
        return self.fixed.section(U.reshape(-1, 3), self.vertex)


class Nose(Held):
    """The loading nose on the mid-span vertex (0), its centre at (rho - lam d_max, 0)."""

    vertex = 0

    def __init__(self, rho: float, d_max: float):
        self.rho, self.d_max = rho, d_max

    def circle(self, lam: float) -> Circle:
        rho = self.rho
        return Circle((rho - lam * self.d_max, 0.0), rho)

    def lam_derivative(self, prep: np.ndarray, U: np.ndarray, lam: float, mult: float):
        """dR/dlam in closed form: lam moves only the nose centre, c = (rho - lam d_max, 0).

        With n = (r - c)/|r - c|: dg/dlam = n_x d_max and dn/dlam = (I - n n^T)(d_max, 0)/|r - c|,
        which enters the residual through -G^T lam (zero when the nose vertex stays on the
        axis, z = 0, as symmetry holds it). Returns (free dofs, their values, the gap row's value:
        the row holds -g).
        """
        x0, z0 = U[:2]
        _, nx, nz, dist = self.circle(lam).gap(float(x0), float(z0))
        dn = ((1.0 - nx * nx) * self.d_max / dist, -nz * nx * self.d_max / dist)
        free = prep[:2] >= 0
        return prep[:2][free], -mult * np.array(dn)[free], -nx * self.d_max
