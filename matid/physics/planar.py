"""Closed-form gradient and Hessian of the planar density (the numpy Newton path).

Variables per point z = (x, z, t, x', z', t') (6); with c, s = cos t, sin t,

    nu1 = x'c - z's,  nu3 = x's + z'c,  dnu1/dt = -nu3,  dnu3/dt = nu1,
    W = 1/2 [E_b (t' - lam k_ref)^2 + E_s nu1^2 + E_e (nu3 - 1)^2]   (the field's -lam mu (s Bx + c Bz):
    :func:`magnetic`),

so with the director-frame forces n = (n1, n3) = (E_s nu1, E_e (nu3 - 1)) and
J = d(nu1, nu3)/d(t, x', z') = [[-nu3, c, -s], [nu1, s, c]],

    g_(t, x', z') = J^T n,   H_(t, x', z') = J^T C J + G,
    G_tt = -n.nu,  G_(t, x') = -s n1 + c n3,  G_(t, z') = -c n1 - s n3

(G = n1 Hess(nu1) + n3 Hess(nu3)), g_t' = E_b (t' - lam k_ref), H_t't' = E_b, plus the
field's term in t (:func:`magnetic`). Written entry by entry: on a few dozen points numpy's cost is per
operation, and this is the fewest. In the mixed tangent (:meth:`matid.rod.system.RodSystem.mixed_update`) n in
G is the iteration's independent point stress instead of that of the displacements.
The same model as the jets of :meth:`RodSystem.density` (compared in the tests).
"""

from __future__ import annotations

import numpy as np

#: The entries of H that can be non-zero, (row, column) in z = (x, z, t, x', z', t') (one of each
#: symmetric pair): the layout of ``compact=True``.
COMPACT = ((2, 2), (2, 3), (2, 4), (3, 3), (3, 4), (4, 4), (5, 5))


def derivatives(z, lam, props, kappa_ref, tangent, *, stress, want_strain, compact=False):
    """(g, H, strain) of the planar density at every point: shapes P + (6,), P + (6, 6).

    z: P + (6,) point values (x, z, t, x', z', t'); props: stiffness arrays (P);
    kappa_ref: 3-vector or P + (3,) per point (its second entry, about the plane normal, scaled by
    lam here).
    ``stress`` (P + (2,)): (n1, n3) for the geometric part of H (the mixed tangent; NaN at a
    point: that of the displacements, as without it); strain:
    ((n1, n3) of the displacements, C J) for that update with ``want_strain`` and ``tangent``, else None.
    ``compact``: H as (7,) + P, the entries of :data:`COMPACT` (the rest are zero).
    """
    shape = z.shape[:-1]
    z = z.reshape(-1, 6)
    n = z.shape[0]
    th, dx, dz = z[:, 2], z[:, 3], z[:, 4]
    c, s = np.cos(th), np.sin(th)
    nu1, nu3 = dx * c - dz * s, dx * s + dz * c
    Es, Ee, Eb = props["E_s"].ravel(), props["E_e"].ravel(), props["E_b"].ravel()
    n1, n3 = Es * nu1, Ee * (nu3 - 1.0)
    g = np.empty((n, 6))
    g[:, :2] = 0.0  # no elastic force on r itself (dead loads: their terms)
    g[:, 2] = n3 * nu1 - n1 * nu3
    g[:, 3] = n1 * c + n3 * s
    g[:, 4] = n3 * c - n1 * s
    kappa_ref = np.asarray(kappa_ref, float)  # one rod-wide vector: no broadcast to the points
    g[:, 5] = Eb * (z[:, 5] - lam * (kappa_ref[1] if kappa_ref.ndim == 1 else kappa_ref.reshape(n, 3)[:, 1]))
    if not tangent:
        return g.reshape(shape + (6,)), None, None
    Esc, Ess, Eec, Ees = Es * c, Es * s, Ee * c, Ee * s
    a, b = -Es * nu3, Ee * nu1  # C J on t: (E_s dnu1/dt, E_e dnu3/dt)
    strain = None
    if want_strain:
        CJ = np.zeros((n, 2, 6))
        CJ[:, 0, 2], CJ[:, 0, 3], CJ[:, 0, 4] = a, Esc, -Ess
        CJ[:, 1, 2], CJ[:, 1, 3], CJ[:, 1, 4] = b, Ees, Eec
        nn = np.empty((n, 2))  # (n1, n3): np.stack costs 4 times two column writes here
        nn[:, 0], nn[:, 1] = n1, n3
        strain = (nn.reshape(shape + (2,)), CJ.reshape(shape + (2, 6)))
    if stress is not None:  # NaN rows: the displacements' stress (a stack of mixed and consistent)
        stress = stress.reshape(n, 2)
        nan = np.isnan(stress)
        if nan.any():
            n1, n3 = np.where(nan[:, 0], n1, stress[:, 0]), np.where(nan[:, 1], n3, stress[:, 1])
        else:  # one scene's mixed Newton: every point has its own
            n1, n3 = stress[:, 0], stress[:, 1]
    # tt = b nu1 - a nu3 - n.nu, tx = a c + b s - n1 s + n3 c, tz = b c - a s - n1 c - n3 s, grouped
    p, r = a + n3, b - n1
    tt, tx, tz = r * nu1 - p * nu3, p * c + r * s, r * c - p * s
    xx, xz, zz = Esc * c + Ees * s, (Ees - Ess) * c, Ess * s + Eec * c
    if compact:  # the entries that can be non-zero, in the order of COMPACT
        H = np.stack([tt, tx, tz, xx, xz, zz, Eb])
        return g.reshape(shape + (6,)), H.reshape((7,) + shape), strain
    H = np.zeros((n, 6, 6))
    H[:, 2, 2] = tt
    H[:, 2, 3] = H[:, 3, 2] = tx
    H[:, 2, 4] = H[:, 4, 2] = tz
    H[:, 3, 3] = xx
    H[:, 3, 4] = H[:, 4, 3] = xz
    H[:, 4, 4] = zz
    H[:, 5, 5] = Eb
    return g.reshape(shape + (6,)), H.reshape(shape + (6, 6)), strain


def magnetic(g: np.ndarray, H: np.ndarray | None, z: np.ndarray, mu: np.ndarray, B, *, compact=False) -> None:
    """Add the field's energy -mu (sin t Bx + cos t Bz) per length to (g, H) of :func:`derivatives`
    in place: its first and second derivative in t. mu: the moment per length times the load
    factor (P); B: (x, -, z) in the plane; ``compact``: H in the layout of :data:`COMPACT`."""
    t = z.reshape(-1, 6)[:, 2]
    c, s = np.cos(t), np.sin(t)
    mu = mu.ravel()
    g.reshape(-1, 6)[:, 2] -= mu * (c * B[0] - s * B[2])
    if H is not None:
        tt = H.reshape(7, -1)[0] if compact else H.reshape(-1, 6, 6)[:, 2, 2]
        tt += mu * (s * B[0] + c * B[2])
