"""The field on a distributed magnetisation (``[[magnetization]]`` in ``[field]``): -lam mu (R a).B
per length, eq. (9).

Along d3 (a = +-e3, a signed mu): planar :func:`matid.physics.planar.magnetic`; in the full model
the field's row q^T M q n2^p of the strain kernel :func:`matid.physics.full.derivatives`, which
differentiates it with the strain numerators in one batched product (the term hands it mu).
Any other direction a (full model, contract section 9): :func:`matid.physics.full.directed_magnetic`
with the maps of mu a at the points, built once per system.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.physics import full, planar
from matid.physics import kinematics as kin
from matid.rod.models import PLANAR
from matid.rod.terms.base import Scale, Term, at_points


@dataclass(frozen=True)
class Magnetisation(Term):
    B: tuple[float, float, float]
    along_d3: tuple[tuple[float, float, float], ...]  # (from, to, signed moment per length)
    #: (from, to, moment per length, direction a in the director frame) off the axis (full model)
    directed: tuple[tuple[float, float, float, tuple[float, float, float]], ...] = ()

    label = "magnetic"
    kind = "distributed"

    @classmethod
    def from_scene(cls, scene, scale: Scale) -> Magnetisation | None:
        loads = scene.loads
        if not (any(loads.B) and loads.magnetization):
            return None
        along, directed = [], []
        L = scale.L
        for (s0, s1, m), a in zip(loads.magnetization, loads.directions("magnetization"), strict=True):
            axial = a[0] == 0.0 and a[1] == 0.0
            piece = (s0 / L, s1 / L, m * (a[2] if axial else 1.0) * L**2 / scale.E_b)
            along.append(piece) if axial else directed.append(piece + (a,))
        return cls(scale.vec(loads.B, 1.0), tuple(along), tuple(directed))

    def mu_at(self, s: np.ndarray) -> np.ndarray:
        """The signed moment per length along d3 at points s."""
        out = np.zeros_like(s)
        for start, end, value in self.along_d3:
            out += np.where((s >= start) & (s <= end), value, 0.0)
        return out

    def directed_at(self, s: np.ndarray) -> np.ndarray | None:
        """Sum of mu a (director frame) of the off-axis pieces at points s (P + (3,)), or None."""
        if not self.directed:
            return None
        out = np.zeros(s.shape + (3,))
        for start, end, value, a in self.directed:
            out += np.where((s >= start) & (s <= end), value, 0.0)[..., None] * np.asarray(a, float)
        return out

    def prepare(self, system):
        s = system.disc.s_quad
        mu = at_points(system, self, lambda: self.mu_at(s))
        directed = self.directed_at(s)
        maps = None if directed is None else full.directed_maps(self.B, directed.reshape(-1, 3))
        return mu, directed, maps

    def kernel(self, system, prep) -> tuple | None:
        return None if system.model == PLANAR else (prep[0], self.B)

    def derivatives(self, system, prep, z, lam, g, H) -> None:
        mu, _, maps = prep
        if system.model == PLANAR:
            planar.magnetic(g, H, z, lam * mu, self.B)
        elif maps is not None:  # the d3 part rides in the kernel (:meth:`kernel`)
            full.directed_magnetic(g, H, z, lam, maps, system.variant)

    def density(self, system, prep, u, du, lam):
        mu, directed, _ = prep
        B = self.B
        if system.model == PLANAR:
            th = u[2]
            return kin.magnetic_energy(lam * mu, [kin.jet.sin(th), 0.0, kin.jet.cos(th)], [B[0], 0.0, B[2]])
        q = u[3:]
        w = kin.magnetic_energy(lam * mu, kin.d3(q, system.variant), B)
        if directed is not None:
            w = w + sum(
                kin.magnetic_energy(lam * directed[..., j], kin.director(q, j, system.variant), B)
                for j in range(3)
            )
        return w

    def softens_straight_rod(self) -> bool:
        """Whether some piece's mu B_3 < 0: the straight rod's tangent may be indefinite."""
        return any(m * self.B[2] < 0.0 for _, _, m in self.along_d3)
