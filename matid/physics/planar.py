"""Closed-form gradient and Hessian of the planar density (the numpy Newton path).

Variables per point z = (x, z, t, x', z', t') (6); with c, s = cos t, sin t,

    nu1 = x'c - z's,  nu3 = x's + z'c,  dnu1/dt = -nu3,  dnu3/dt = nu1,
    W = 1/2 [E_b (t' - lam k_ref)^2 + E_s nu1^2 + E_e (nu3 - 1)^2] - lam mu (s Bx + c Bz) - lam f.r,

so with the director-frame forces n = (n1, n3) = (E_s nu1, E_e (nu3 - 1)) and
J = d(nu1, nu3)/d(t, x', z') = [[-nu3, c, -s], [nu1, s, c]],

    g_(t, x', z') = J^T n,   H_(t, x', z') = J^T C J + G,
    G_tt = -n.nu,  G_(t, x') = -s n1 + c n3,  G_(t, z') = -c n1 - s n3

(G = n1 Hess(nu1) + n3 Hess(nu3)), g_t' = E_b (t' - lam k_ref), H_t't' = E_b, plus the
field term in t. In the mixed tangent (:meth:`matid.rod.models.RodSystem.mixed_update`) n in
G is the iteration's independent point stress instead of that of the displacements.
The same model as the jets of :meth:`RodSystem.density` (compared in the tests).
"""

from __future__ import annotations

import numpy as np

#: (t, x', z') among the point variables, and the (row, column) pairs of their 3 x 3 block
ACTIVE = np.array([2, 3, 4])
_ROWS, _COLS = np.meshgrid(ACTIVE, ACTIVE, indexing="ij")


def derivatives(z, lam, props, kappa_ref, mu, B, f, tangent=True, *, stress=None, want_strain=False):
    """(g, H) of the planar density at every point: shapes P + (6,), P + (6, 6).

    z: P + (6,) point values (x, z, t, x', z', t'); props: stiffness arrays (P);
    mu: magnetisation per length (P) or None; B, f: 3-vectors (x, -, z) in the plane;
    kappa_ref: 3-vector (its second entry, about the plane normal, scaled by lam here).
    ``stress`` (P + (2,)): (n1, n3) for the geometric part of H (the mixed tangent);
    ``want_strain``: also return ((n1, n3) of the displacements, C J) for that update.
    """
    shape = z.shape[:-1]
    z = z.reshape(-1, 6)
    n = z.shape[0]
    th = z[:, 2]
    c, s = np.cos(th), np.sin(th)
    J = np.empty((n, 2, 3))  # d(nu1, nu3)/d(t, x', z')
    J[:, 0, 1], J[:, 0, 2], J[:, 1, 1], J[:, 1, 2] = c, -s, s, c
    nu = np.matmul(J[:, :, 1:], z[:, 3:5, None])[:, :, 0]  # (nu1, nu3)
    J[:, 0, 0], J[:, 1, 0] = -nu[:, 1], nu[:, 0]
    C = np.empty((n, 2))
    C[:, 0], C[:, 1] = props["E_s"].ravel(), props["E_e"].ravel()
    force = C * (nu - (0.0, 1.0))  # (n1, n3) in the director frame
    Eb = props["E_b"].ravel()
    g = np.empty((n, 6))
    g[:, 0], g[:, 1] = -lam * f[0], -lam * f[2]
    g[:, 2:5] = np.matmul(force[:, None, :], J)[:, 0, :]
    g[:, 5] = Eb * (z[:, 5] - lam * kappa_ref[1])
    if mu is not None:
        mu = lam * np.ravel(mu)
        g[:, 2] -= mu * (c * B[0] - s * B[2])
    if not tangent:
        return (g.reshape(shape + (6,)), None, None) if want_strain else (g.reshape(shape + (6,)), None)
    CJ = C[:, :, None] * J
    strain = None
    if want_strain:  # stress of the displacement field and C J, for the mixed update
        CJ6 = np.zeros((n, 2, 6))
        CJ6[:, :, 2:5] = CJ
        strain = (force.reshape(shape + (2,)), CJ6.reshape(shape + (2, 6)))
    if stress is not None:
        force = stress.reshape(n, 2)
    n1, n3 = force[:, 0], force[:, 1]
    A = np.matmul(J.transpose(0, 2, 1), CJ)  # J^T C J on (t, x', z')
    A[:, 0, 0] -= np.einsum("pk,pk->p", force, nu)
    gtx, gtz = n3 * c - n1 * s, -n1 * c - n3 * s
    A[:, 0, 1] += gtx
    A[:, 1, 0] += gtx
    A[:, 0, 2] += gtz
    A[:, 2, 0] += gtz
    if mu is not None:
        A[:, 0, 0] += mu * (s * B[0] + c * B[2])
    H = np.zeros((n, 6, 6))
    H[:, _ROWS, _COLS] = A
    H[:, 5, 5] = Eb
    g, H = g.reshape(shape + (6,)), H.reshape(shape + (6, 6))
    return (g, H, strain) if want_strain else (g, H)
