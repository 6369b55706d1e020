"""matid's bend half model with the support contact section placed by a convention alpha.

matid (alpha = 0) makes the contact section the cross-section through the
roller axis: h = (r_k - c) . d3(theta_k) = 0. Here d3 is replaced by the unit
vector at angle beta = theta_k + alpha (psi_in - theta_k), where psi_in is the
angle of the span-side one-sided centreline tangent at the support vertex k:
alpha = 1 makes the contact normal perpendicular to that tangent (closest
point on the span side), alpha = 1/2 is the mean of the one-sided tangents
(the overhang carries no shear force, so its tangent is d3). The P2 element
k-1 = (vertex k-1, vertex k, mid node m) gives r'(end) ~ r_{k-1} + 3 r_k - 4 r_m.

For benchmarks only (not part of matid): it subclasses BendModel/BendSystem
and adds the h row's coupling to the neighbour nodes to the Newton tangent.
"""

from __future__ import annotations

import numpy as np

from matid.physics.contact import Circle
from matid.rod.bend import BendModel, BendSystem
from matid.rod.fem import Discretisation
from matid.rod.models import PLANAR, ScaledRod
from matid.rod.system import RodSystem


class AlphaCircle(Circle):
    def __init__(self, centre, radius, alpha: float):
        super().__init__(centre, radius)
        self.alpha = alpha
        self.system: AlphaSystem | None = None
        self.extra: list[tuple[int, np.ndarray]] = []  # (scalar dof, dh/d(x, z, theta)) off the vertex

    def angles(self, U: np.ndarray, vertex: int) -> tuple[float, float, np.ndarray, tuple[int, int]]:
        """(theta_k, psi_in, t, (a, m)) at the support vertex."""
        e = vertex - 1
        a, b, m = self.system.rod.disc.edofs[:, e]
        assert b == vertex
        t = U[a, :2] + 3 * U[vertex, :2] - 4 * U[m, :2]
        return float(U[vertex, 2]), float(np.arctan2(t[0], t[1])), t, (int(a), int(m))

    def section(self, U: np.ndarray, vertex: int) -> tuple[float, np.ndarray]:
        al = self.alpha
        th, psi, t, (a, m) = self.angles(U, vertex)
        beta = th + al * (psi - th)
        d = U[vertex, :2] - self.centre
        e3 = np.array([np.sin(beta), np.cos(beta)])
        h = float(d @ e3)
        dh_db = float(d @ np.array([np.cos(beta), -np.sin(beta)]))
        dpsi_dt = np.array([t[1], -t[0]]) / float(t @ t)
        g = dh_db * al * dpsi_dt  # dh/dt
        grad_k = np.array([e3[0] + 3 * g[0], e3[1] + 3 * g[1], dh_db * (1 - al)])
        self.extra = [(a, np.array([g[0], g[1], 0.0])), (m, np.array([-4 * g[0], -4 * g[1], 0.0]))]
        return h, grad_k


class AlphaSystem(BendSystem):
    def evaluate(self, X, lam, *, tangent: bool = True):
        R, A = super().evaluate(X, lam, tangent=tangent)
        if not tangent or self.support.alpha == 0:
            return R, A
        A.C = A.C.copy()  # the support row dh/du (border row 2) gains the neighbours' coupling
        for node, g in self.support.extra:
            idx = self.rod.index[node * 3 + np.arange(3)]
            for c in range(3):
                if idx[c] >= 0 and g[c] != 0:
                    A.C[2, idx[c]] += g[c]
        return R, A


class AlphaModel(BendModel):
    """BendModel whose support section follows convention ``alpha``."""

    def __init__(self, geometry, *, alpha: float = 0.0, elements: int = 48):
        super().__init__(geometry, elements=elements)
        self.alpha = alpha

    def system(self, E_b, E_s, E_e, d_max):
        S = self.geometry.span
        disc = Discretisation(self.vertices(0.5), 3, intorder=2)
        scaled = ScaledRod(E_t=1.0, E_s=E_s * S**2 / E_b, E_e=E_e * S**2 / E_b)
        rod = RodSystem(disc, scaled, model=PLANAR, fixed=(1, 2), banded=True)
        support = AlphaCircle((-self.support_rho, 0.5), self.support_rho, self.alpha)
        system = AlphaSystem(rod, self, support, d_max / S)
        support.system = system
        return system


def support_angles(model: BendModel, path, index: int) -> dict:
    """Rod support quantities at one path state: force tilt from vertical, theta, psi_in (rad)."""
    S = model.geometry.span
    system = model.system(1.0, 1.0, 1.0, float(path.deflection[-1]) or 1.0)
    X = path.states[index]
    system.at(X[-1])
    U = system.rod.expand(X[: system.nu]).reshape(-1, 3)
    k = model.support_vertex
    c = system.support.centre
    nvec = (U[k, :2] - c) / np.linalg.norm(U[k, :2] - c)
    e = k - 1
    a, _, m = system.rod.disc.edofs[:, e]
    t = U[a, :2] + 3 * U[k, :2] - 4 * U[m, :2]
    s, x, _, _ = model.half_state(path, index)
    return {
        "angle": float(np.arctan2(-nvec[1], nvec[0])),
        "theta": float(U[k, 2]),
        "psi_in": float(np.arctan2(t[0], t[1])),
        "delta_centroid": float(np.interp(0.5 * S, s, x) - x[0]),
        "support_s": float(X[-1] * S),
    }
