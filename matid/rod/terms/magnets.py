"""The field on lumped magnets (``[[magnet]]`` in ``[field]``): -lam m (R a).B at the magnet's node.

Along d3 (a = +-e3, a signed moment): planar -m (sin th Bx + cos th Bz) with its first and second
derivative in theta; full model :func:`matid.physics.full.magnet` in q. Any other direction a
(contract section 9, full model only) is the same function with its map M = sum B_j m a_i Q_ji
(:func:`matid.physics.full.directed_maps`), built once per system.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.physics import full
from matid.rod.models import PLANAR
from matid.rod.terms.base import Scale, Term, node, q_dofs

AXIS = (0.0, 0.0, 1.0)


@dataclass(frozen=True)
class Magnets(Term):
    B: tuple[float, float, float]
    along_d3: tuple[tuple[float, float], ...]  # (s, signed moment)
    #: (s, moment, direction a in the director frame) off the axis (full model)
    directed: tuple[tuple[float, float, tuple[float, float, float]], ...] = ()

    label = "magnetic"

    @classmethod
    def from_scene(cls, scene, scale: Scale) -> Magnets | None:
        loads = scene.loads
        if not (any(loads.B) and loads.magnets):
            return None
        along, directed = [], []
        L, Eb = scale.L, scale.E_b
        for (at, m), a in zip(loads.magnets, loads.directions("magnet"), strict=True):
            if a[0] == 0.0 and a[1] == 0.0:
                along.append((at / L, m * a[2] * L / Eb))
            else:
                directed.append((at / L, m * L / Eb, a))
        return cls(scale.vec(loads.B, 1.0), tuple(along), tuple(directed))

    def prepare(self, system):
        nf = system.disc.nf
        nodes = np.array([node(system, s) for s, _ in self.along_d3], int)
        dofs = nodes[:, None] * nf + 2 if system.model == PLANAR else q_dofs(nodes, nf)
        m = np.array([m for _, m in self.along_d3], float)
        pattern = system.disc.block_pattern(dofs) if self.along_d3 else None
        if system.model == PLANAR:
            return dofs, m, pattern, None
        ddofs = q_dofs([node(system, s) for s, _, _ in self.directed], nf)
        moments = np.array([m * np.asarray(a, float) for _, m, a in self.directed]).reshape(-1, 3)
        dpattern = system.disc.block_pattern(ddofs) if self.directed else None
        return dofs, m, pattern, (ddofs, full.directed_maps(self.B, moments), dpattern)

    def nodal(self, system, prep, U, lam, R, blocks) -> None:
        dofs, m, pattern, directed = prep
        B = self.B
        if system.model == PLANAR:  # -m (sin th Bx + cos th Bz): first and second derivative in theta
            if pattern is not None:
                th, m = U[dofs[:, 0]], lam * m
                R[dofs[:, 0]] -= m * (np.cos(th) * B[0] - np.sin(th) * B[2])
                blocks.append((pattern, m * (np.sin(th) * B[0] + np.cos(th) * B[2])))
            return
        if pattern is not None:
            g, h = full.magnet(U[dofs], B, system.variant)
            m = lam * m
            R[dofs] += m[:, None] * g
            blocks.append((pattern, m[:, None, None] * h))
        ddofs, M, dpattern = directed
        if dpattern is not None:
            g, h = full.magnet(U[ddofs], B, system.variant, M=M)
            R[ddofs] += lam * g
            blocks.append((dpattern, lam * h))

    def softens_straight_rod(self) -> bool:
        """Whether some magnet's m B_3 < 0: the straight rod's tangent may be indefinite."""
        return any(m * self.B[2] < 0.0 for _, m in self.along_d3)
