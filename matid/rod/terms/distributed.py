"""A dead force per length (``[load] distributed_force``): potential -lam f.r per length, so the
pointwise gradient -lam f in r (planar: in (x, z)) and no Hessian."""

from __future__ import annotations

from dataclasses import dataclass

from matid.rod.models import PLANAR
from matid.rod.terms.base import Scale, Term


@dataclass(frozen=True)
class DistributedForce(Term):
    f: tuple[float, float, float]  # planar: (transverse, -, axial)

    kind = "distributed"

    @classmethod
    def from_scene(cls, scene, scale: Scale) -> DistributedForce | None:
        f = scene.loads.distributed_force
        return cls(scale.vec(f, scale.L**3 / scale.E_b)) if any(f) else None

    def derivatives(self, system, prep, z, lam, g, H) -> None:
        f = self.f
        if system.model == PLANAR:
            g[..., 0] -= lam * f[0]
            g[..., 1] -= lam * f[2]
        else:
            g[..., :3] -= [lam * f[0], lam * f[1], lam * f[2]]

    def density(self, system, prep, u, du, lam):
        f = self.f
        if system.model == PLANAR:
            return -lam * (f[0] * u[0] + f[2] * u[1])
        return -lam * (f[0] * u[0] + f[1] * u[1] + f[2] * u[2])
