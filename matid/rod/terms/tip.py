"""Dead force and moment at the free end (``[tip]``).

Potential -lam F.r(1) and, planar, -lam M theta(1): constant residual entries. A dead moment in
3D has no potential: its virtual work lam M.dphi with the spatial spin dphi (physics.md section 8,
:func:`matid.physics.full.dead_moment`) enters the residual, and its tangent is not symmetric.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.physics import full
from matid.rod.models import PLANAR
from matid.rod.terms.base import Scale, Term


@dataclass(frozen=True)
class Tip(Term):
    force: tuple[float, float, float]
    moment: tuple[float, float, float]

    @classmethod
    def from_scene(cls, scene, scale: Scale) -> Tip | None:
        loads = scene.loads
        if not (any(loads.tip_force) or any(loads.tip_moment)):
            return None
        return cls(scale.force(loads.tip_force), scale.torque(loads.tip_moment))

    def prepare(self, system):
        nf = system.disc.nf
        dofs = np.arange(system.tip * nf, system.tip * nf + nf)
        pattern = None if system.model == PLANAR else system.disc.block_pattern(dofs[3:])
        return dofs, pattern

    def symmetric(self, system) -> bool:
        return system.model == PLANAR or not any(self.moment)

    def nodal(self, system, prep, U, lam, R, blocks) -> None:
        tip, pattern = prep
        if system.model == PLANAR:
            R[tip] -= lam * np.array([self.force[0], self.force[2], self.moment[1]])
            return
        R[tip[:3]] -= lam * np.asarray(self.force)
        if any(self.moment):
            g, h = full.dead_moment(U[tip[3:]], self.moment)
            R[tip[3:]] -= lam * g
            blocks.append((pattern, -lam * h))
