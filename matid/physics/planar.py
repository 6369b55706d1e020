"""Closed-form gradient and Hessian of the planar density (the numpy Newton path).

Variables per point z = (x, z, t, x', z', t') (6); with c, s = cos t, sin t,

    nu1 = x'c - z's,  nu3 = x's + z'c,  dnu1/dt = -nu3,  dnu3/dt = nu1,
    W = 1/2 [E_b (t' - lam k_ref)^2 + E_s nu1^2 + E_e (nu3 - 1)^2] - lam mu (s Bx + c Bz) - lam f.r,

so with the director-frame forces n1 = E_s nu1, n3 = E_e (nu3 - 1) and J = d(nu1, nu3)/dz,
H = J^T C J + n1 Hess(nu1) + n3 Hess(nu3) (+ the field term). In the mixed tangent
(:meth:`matid.rod.models.RodSystem.mixed_update`) (n1, n3) in the geometric part are the
independent point stresses of the iteration instead of those of the displacements.
The same model as the jets of :meth:`RodSystem.density` (compared in the tests) and as the
compiled kernel (:mod:`matid.rod.kernel`).
"""

from __future__ import annotations

import numpy as np


def derivatives(vals, ders, lam, props, kappa_ref, mu, B, f, tangent=True, *, stress=None, want_strain=False):
    """(g, H) of the planar density at every point: shapes P + (6,), P + (6, 6).

    vals, ders: (3,) + P field values and s-derivatives; props: stiffness arrays (P);
    mu: magnetisation per length (P) or None; B, f: 3-vectors (x, -, z) in the plane;
    kappa_ref: 3-vector (its second entry, about the plane normal, scaled by lam here).
    ``stress`` (P + (2,)): (n1, n3) for the geometric part of H (the mixed tangent);
    ``want_strain``: also return ((n1, n3) of the displacements, C J) for that update.
    """
    Eb, Es, Ee = props["E_b"], props["E_s"], props["E_e"]
    th, dx, dz, dth = vals[2], ders[0], ders[1], ders[2]
    c, s = np.cos(th), np.sin(th)
    nu1, nu3 = dx * c - dz * s, dx * s + dz * c
    n1, n3 = Es * nu1, Ee * (nu3 - 1.0)  # internal forces in the director frame
    g = np.zeros(th.shape + (6,))
    g[..., 0], g[..., 1] = -lam * f[0], -lam * f[2]
    g[..., 2] = -n1 * nu3 + n3 * nu1
    g[..., 3], g[..., 4] = n1 * c + n3 * s, -n1 * s + n3 * c
    g[..., 5] = Eb * (dth - lam * np.asarray(kappa_ref)[..., 1])  # a 3-vector, or P + (3,)
    if mu is not None:
        mu = lam * mu
        g[..., 2] -= mu * (c * B[0] - s * B[2])
    if not tangent:
        return (g, None, None) if want_strain else (g, None)
    strain = None
    if want_strain:  # stress of the displacement field and C J, for the mixed update
        J = np.zeros(th.shape + (2, 6))
        J[..., 0, 2], J[..., 0, 3], J[..., 0, 4] = -nu3, c, -s
        J[..., 1, 2], J[..., 1, 3], J[..., 1, 4] = nu1, s, c
        strain = (np.stack([n1, n3], axis=-1), J * np.stack([Es, Ee], axis=-1)[..., None])
    if stress is not None:
        n1, n3 = stress[..., 0], stress[..., 1]
    H = np.zeros(th.shape + (6, 6))
    H[..., 2, 2] = Es * nu3 * nu3 + Ee * nu1 * nu1 - n1 * nu1 - n3 * nu3
    H[..., 2, 3] = H[..., 3, 2] = -Es * nu3 * c + Ee * nu1 * s - n1 * s + n3 * c
    H[..., 2, 4] = H[..., 4, 2] = Es * nu3 * s + Ee * nu1 * c - n1 * c - n3 * s
    H[..., 3, 3] = Es * c * c + Ee * s * s
    H[..., 3, 4] = H[..., 4, 3] = (Ee - Es) * s * c
    H[..., 4, 4] = Es * s * s + Ee * c * c
    H[..., 5, 5] = Eb
    if mu is not None:
        H[..., 2, 2] += mu * (s * B[0] + c * B[2])
    return (g, H, strain) if want_strain else (g, H)
