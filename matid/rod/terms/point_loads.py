"""Dead forces and moments at interior points (``[[point_load]]``, contract section 9).

Planar: potential -lam (F.r + M theta) at the point's node. Full model: the force's potential
-lam F.r and the moment's virtual work (as the tip's, :mod:`matid.rod.terms.tip`: unsymmetric).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.physics import full
from matid.rod.models import PLANAR
from matid.rod.terms.base import Scale, Term, node, q_dofs


@dataclass(frozen=True)
class PointLoads(Term):
    #: (s, force, moment) scaled; planar: (transverse, -, axial), (-, M, -)
    loads: tuple[tuple[float, tuple[float, ...], tuple[float, ...]], ...]

    label = "point loads"

    @classmethod
    def from_scene(cls, scene, scale: Scale) -> PointLoads | None:
        if not scene.loads.point_loads:
            return None
        L = scale.L
        return cls(tuple((at / L, scale.force(F), scale.torque(M)) for at, F, M in scene.loads.point_loads))

    def prepare(self, system):
        nodes = [(node(system, s), np.asarray(F), np.asarray(M)) for s, F, M in self.loads]
        if system.model == PLANAR:
            return nodes, None
        loaded = [(n, M) for n, _, M in nodes if any(M)]
        dofs = q_dofs([n for n, _ in loaded], system.disc.nf)
        moments = np.array([M for _, M in loaded], float).reshape(-1, 3)
        pattern = system.disc.block_pattern(dofs) if loaded else None
        return nodes, (dofs, moments, pattern)

    def symmetric(self, system) -> bool:
        return system.model == PLANAR or not any(any(M) for _, _, M in self.loads)

    def nodal(self, system, prep, U, lam, R, blocks) -> None:
        nodes, moments = prep
        nf = system.disc.nf
        if system.model == PLANAR:
            for n, F, M in nodes:  # dead loads in the plane: potential -F.r - M theta
                R[n * nf : n * nf + 3] -= lam * np.array([F[0], F[2], M[1]])
            return
        for n, F, _ in nodes:
            R[n * nf : n * nf + 3] -= lam * F
        dofs, Ms, pattern = moments
        if pattern is not None:
            pairs = [full.dead_moment(U[d], M) for d, M in zip(dofs, Ms, strict=True)]
            R[dofs] -= lam * np.array([g for g, _ in pairs])
            blocks.append((pattern, -lam * np.array([h for _, h in pairs])))
