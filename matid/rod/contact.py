"""Three-point bend: frictionless sliding contact of the tube with three cylinders.

Half model by symmetry: s in [0, L/2] from mid-span (s = 0, where z = 0 and
theta = 0) to the free end. In the plane, x is vertical (up) and z runs along
the span. Contact is between the tube surface and a cylinder, i.e. between the
centreline and a circle of radius rho = R + R_o (physics.md section 4):

    support: centre (-rho_s, S/2),  nose: centre (rho_n - d, 0)

so that the straight tube at x = 0 touches all three at d = 0.

Which cross-section touches? The contact acts on the cross-section whose plane
holds the cylinder axis:

    h(u, s) = (r(s) - c) . d3(s) = 0,     gap g(u) = |r(s_c) - c| - rho

(the tube surface point r + R_o d1 of that section is the one on the cylinder).
For an unshearable rod d3 = r'/|r'| and this is the closest point. For a
shear-deformable rod it is the right condition, and the closest point is not:
a point load puts a corner of angle nu1 = lam/E_s into the centreline, which P2
elements smooth over one element, so on fine meshes the discrete centreline
conforms to the circle and its closest point degenerates (measured: Newton
2-cycles at 24 elements). h is continuous with dh/ds = nu3 + ... > 0, so s_c is
unique and moves smoothly; at mid-span symmetry puts it at s = 0, the load
point of the classic Timoshenko formula.

Each contact is a constraint g = 0 with a Lagrange multiplier lam >= 0 (the
contact force). Derivatives by the implicit function theorem on the element
holding s_c, with phi(u, t) = |r - c| and h(u, t) as jets in (u_e, t):

    t_u  = -h_u / h_t
    t_uu = -(h_uu + h_ut t_u^T + t_u h_tu + h_tt t_u t_u^T) / h_t
    g_u  = phi_u + phi_t t_u
    g_uu = phi_uu + phi_ut t_u^T + t_u phi_tu + phi_tt t_u t_u^T + phi_t t_uu

The nose force of the whole tube is F = 2 lam_nose (-n_x), n = (r - c)/|r - c|.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.rod import jet
from matid.rod.fem import Discretisation

# P2 shape functions on the reference element [0, 1], local dofs (vertex 0, vertex 1, midpoint)
_N = (lambda t: (1 - t) * (1 - 2 * t), lambda t: t * (2 * t - 1), lambda t: 4 * t * (1 - t))
_DN = (lambda t: 4 * t - 3, lambda t: 4 * t - 1, lambda t: 4 - 8 * t)
_DDN = np.array([4.0, 4.0, -8.0])


def _shape(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t, float)
    return np.stack([f(t) for f in _N]), np.stack([f(t) for f in _DN])


@dataclass(frozen=True)
class ClosestPoint:
    element: int
    t: float  # reference coordinate in the element
    s: float  # arc length
    distance: float
    normal: np.ndarray  # (x, z) unit vector from the centre to the rod
    nodes: np.ndarray  # scalar dofs of the element (3,)
    N: np.ndarray  # shape functions at t (3,)
    interior: bool  # False when clamped at an end of the rod


class Circle:
    """A rigid circle (cylinder axis out of the plane) the tube must stay outside of."""

    def __init__(self, disc: Discretisation, centre: tuple[float, float], radius: float):
        self.disc = disc
        self.centre = np.asarray(centre, float)
        self.radius = radius

    def _h_at_vertices(self, U: np.ndarray) -> np.ndarray:
        """h = (r - c).d3 at the mesh vertices (P2 vertices are the first scalar dofs)."""
        nv = self.disc.vertices.size
        x, z, th = U[:nv, 0], U[:nv, 1], U[:nv, 2]
        return (x - self.centre[0]) * np.sin(th) + (z - self.centre[1]) * np.cos(th)

    def _local(self, nodal: np.ndarray, t: object):
        """phi and h on one element as functions of the nodal (x, z, theta) and t (jets or values)."""
        N = [f(t) for f in _N]
        x = sum(N[i] * nodal[i][0] for i in range(3))
        z = sum(N[i] * nodal[i][1] for i in range(3))
        th = sum(N[i] * nodal[i][2] for i in range(3))
        dx, dz = x - self.centre[0], z - self.centre[1]
        h = dx * jet.sin(th) + dz * jet.cos(th)
        return dx * dx + dz * dz, h

    def locate(self, U: np.ndarray) -> ClosestPoint:
        """The contact section: the root of h(s), bracketed at vertices, refined by Newton in t."""
        hv = self._h_at_vertices(U)
        sign = np.nonzero(np.diff(np.sign(hv)) != 0)[0]
        if hv[0] == 0.0 or sign.size == 0 and hv[0] > 0:
            e, t = 0, 0.0  # the root is at (or, by symmetry, before) s = 0
        elif sign.size == 0:
            e, t = self.disc.ne - 1, 1.0  # past the free end: the tube slips off
        else:
            e = int(sign[0])
            t = float(hv[e] / (hv[e] - hv[e + 1]))
        nodal = U[self.disc.edofs[:, e]]
        if 0.0 < t < 1.0:
            for _ in range(30):
                tj = jet.Jet.variables(np.array([[t]]))[0]
                _, h = self._local(nodal, tj)
                step = -float(h.v[0]) / float(h.g[0, 0])
                t_new = min(max(t + step, 0.0), 1.0)
                if abs(t_new - t) < 1e-15:
                    break
                t = t_new
        verts = self.disc.vertices
        N, _ = _shape(t)
        r = N @ nodal[:, :2]
        dist = float(np.linalg.norm(r - self.centre))
        interior = 0.0 < t < 1.0 or (t == 0.0 and e > 0) or (t == 1.0 and e < self.disc.ne - 1)
        return ClosestPoint(
            e,
            t,
            float(verts[e] + t * (verts[e + 1] - verts[e])),
            dist,
            (r - self.centre) / dist,
            self.disc.edofs[:, e].copy(),
            N,
            interior,
        )

    def vertex_gap(self, U: np.ndarray, vertex: int) -> tuple[float, np.ndarray, np.ndarray]:
        """Gap at a mesh vertex, g = |r_v - c| - rho, with dg/d(x_v, z_v, theta_v) and d2g."""
        r = U[vertex, :2]
        d = max(float(np.linalg.norm(r - self.centre)), 1e-300)  # a wild iterate may hit the centre
        n = (r - self.centre) / d
        grad = np.array([n[0], n[1], 0.0])
        hess = np.zeros((3, 3))
        hess[:2, :2] = (np.eye(2) - np.outer(n, n)) / d
        return d - self.radius, grad, hess

    def gap_derivatives(self, U: np.ndarray, cp: ClosestPoint) -> tuple[float, np.ndarray, np.ndarray]:
        """Gap g, dg/du (9,) and d2g/du2 (9, 9) over the element dofs, local order (node i, field c)."""
        nodal = U[cp.nodes]
        values = np.concatenate([nodal.ravel(), [cp.t]])[:, None]
        v = jet.Jet.variables(values)
        d2, h = self._local(np.array(v[:9], dtype=object).reshape(3, 3), v[9])
        dist = jet.Jet(
            np.sqrt(d2.v),
            d2.g / (2 * np.sqrt(d2.v))[:, None],
            d2.h / (2 * np.sqrt(d2.v))[:, None, None]
            - np.einsum("pi,pj->pij", d2.g, d2.g) / (4 * d2.v**1.5)[:, None, None],
        )
        pu, pt = dist.g[0, :9], dist.g[0, 9]
        puu, put, ptt = dist.h[0, :9, :9], dist.h[0, :9, 9], dist.h[0, 9, 9]
        if not cp.interior:  # the section sits at an end of the rod: t is held there
            return float(dist.v[0]) - self.radius, pu, puu
        hu, ht = h.g[0, :9], h.g[0, 9]
        huu, hut, htt = h.h[0, :9, :9], h.h[0, :9, 9], h.h[0, 9, 9]
        tu = -hu / ht
        tuu = -(huu + np.outer(hut, tu) + np.outer(tu, hut) + htt * np.outer(tu, tu)) / ht
        grad = pu + pt * tu
        hess = puu + np.outer(put, tu) + np.outer(tu, put) + ptt * np.outer(tu, tu) + pt * tuu
        return float(dist.v[0]) - self.radius, grad, hess
