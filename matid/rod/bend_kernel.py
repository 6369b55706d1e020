"""Compiled rod part of the three-point bend (numba): :meth:`matid.rod.bend_system.BendSystem.evaluate`.

The bend's planar rod lives on a mesh moved with sigma, the arc length of the support
vertex (uniform elements on each side of it, :meth:`matid.rod.bend.BendModel.vertices`).
On the moved mesh phi is unchanged and, per element, phi' and dx scale with the length
ratio h_e / h_e(base) (:meth:`matid.rod.fem.Discretisation.moved`), so the tables are
rescaled here and the rod is assembled by :func:`matid.rod.kernel._assemble`. With the
pointwise derivatives g, H of the same points, the mesh derivative is

    dR/dsigma = sum_e dh_e/dsigma dR_e/dh_e,   dR_e/dh = sum_q [W_0 (g_u/h + dg_u/dh) + W_1 dg_u'/dh],
    dg/dh = -H[:, u'] u'/h,   dh_e/dsigma = 1/k inside the support vertex k, -1/(ne - k) outside

(:meth:`matid.rod.bend_system.BendSystem._mesh_derivative`, the numpy oracle). Outputs
are in free-dof numbering; the tangent in the full LAPACK band storage of
:class:`matid.rod.fem.Banded` (``ab[u + i - j, j] = K[i, j]``, band order).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from matid.rod.kernel import PLANAR, _assemble, _planar_point, scratch


@njit(cache=True)
def work_arrays(ne, nq, nloc, nf, n, u):
    """Scratch of :func:`evaluate` for one bend system (allocated once)."""
    return (
        np.empty((ne, nq, 2, nloc)),  # moved point tables
        np.empty((ne, nq)),  # moved weights
        np.empty(ne + 1),  # moved vertices
        np.empty(ne),  # moved element lengths
        np.zeros((ne, nq, 2)),  # stresses (unused: consistent tangent)
        np.zeros((ne, nq, 2, 2 * nf)),
        np.empty(n),  # residual, band order
        np.empty((n, u + 1)),  # lower band by rows
        scratch(nf, nloc),
    )


@njit(cache=True)
def _move(sigma, half, k, inner, outer, v0, T0, dx0, work):
    """Vertices, element lengths and rescaled tables of the mesh with its support vertex at sigma."""
    T, dx, v, h = work[0], work[1], work[2], work[3]
    ne, nq = dx0.shape
    for i in range(k + 1):
        v[i] = sigma * inner[i]
    for i in range(ne - k):
        v[k + 1 + i] = sigma + (half - sigma) * outer[i]
    for e in range(ne):
        h[e] = v[e + 1] - v[e]
        ratio = h[e] / (v0[e + 1] - v0[e])
        for q in range(nq):
            dx[e, q] = dx0[e, q] * ratio
            for i in range(T0.shape[3]):
                T[e, q, 0, i] = T0[e, q, 0, i]
                T[e, q, 1, i] = T0[e, q, 1, i] / ratio


@njit(cache=True)
def _to_free(x, order, out):
    for j in range(order.size):
        out[order[j]] = x[j]


@njit(cache=True)
def evaluate(
    U, lam, sigma, half, k, inner, outer, v0, T0, dx0, gdofs, bpos, order, u, props, mu, B, f, kref,
    A, Q, M, point, magnets, c_u, work, R_free, ab, dR_free
):  # fmt: skip
    """Residual (free dofs), tangent (``ab``, band order) and dR/dsigma (free dofs) at U."""
    _move(sigma, half, k, inner, outer, v0, T0, dx0, work)
    T, dx, _, h, stress, CJ, R, S, scr = work
    _assemble(U, lam, PLANAR, T, dx, gdofs, bpos, u, props, mu, B, f, kref, A, Q, M, point, magnets,
              c_u, stress, False, stress, CJ, R, S, scr)  # fmt: skip
    _to_free(R, order, R_free)
    n = S.shape[0]
    ab[:] = 0.0
    for i in range(n):
        for t in range(u + 1):
            j = i - u + t
            if j >= 0:
                ab[u + i - j, j] = S[i, t]
                ab[u + j - i, i] = S[i, t]
    _mesh_derivative(U, lam, k, h, T, dx, gdofs, bpos, props, mu, B, f, kref, scr, stress, CJ, R)
    _to_free(R, order, dR_free)


@njit(cache=True)
def _mesh_derivative(U, lam, k, h, T, dx, gdofs, bpos, props, mu, B, f, kref, scr, stress, CJ, out):
    """dR/dsigma (band order) into ``out`` on the moved mesh (see the module docstring)."""
    ne, nq = dx.shape
    nloc = T.shape[3]
    nf = gdofs.shape[1] // nloc
    z, g, H = scr[0], scr[1], scr[2]
    dg = np.empty(2 * nf)
    out[:] = 0.0
    for e in range(ne):
        dh = 1.0 / k if e < k else -1.0 / (ne - k)
        for qp in range(nq):
            for kk in range(2):
                for c in range(nf):
                    t = 0.0
                    for i in range(nloc):
                        t += T[e, qp, kk, i] * U[gdofs[e, i * nf + c]]
                    z[kk * nf + c] = t
            _planar_point(
                z, lam, props[0, e, qp], props[2, e, qp], props[3, e, qp], lam * mu[e, qp], B, f, kref,
                g, H, stress[e, qp], CJ[e, qp], stress[e, qp], False
            )  # fmt: skip
            for a in range(2 * nf):
                t = 0.0
                for d in range(nf):
                    t -= H[a, nf + d] * z[nf + d]
                dg[a] = t / h[e]
            for a in range(nf):
                dg[a] += g[a] / h[e]
            w = dx[e, qp] * dh
            for i in range(nloc):
                for c in range(nf):
                    pos = bpos[gdofs[e, i * nf + c]]
                    if pos >= 0:
                        out[pos] += w * (T[e, qp, 0, i] * dg[c] + T[e, qp, 1, i] * dg[nf + c])


@njit(cache=True)
def stiffness_residuals(
    U, sigma, half, k, inner, outer, v0, T0, dx0, gdofs, bpos, order, u, unit, mu, B, f, kref, A, Q, M,
    point, magnets, c_u, work, out
):  # fmt: skip
    """dR/dp (free dofs) at U for each unit stiffness field unit[m] (4, ne, nq): the residual of
    that one energy term at lam = 0 (the energy is linear in each stiffness), into out[:, m]."""
    _move(sigma, half, k, inner, outer, v0, T0, dx0, work)
    T, dx, _, _, stress, CJ, R, S, scr = work
    col = np.empty(out.shape[0])
    for m in range(unit.shape[0]):
        _assemble(U, 0.0, PLANAR, T, dx, gdofs, bpos, u, unit[m], mu, B, f, kref, A, Q, M, point,
                  magnets, c_u, stress, False, stress, CJ, R, S, scr)  # fmt: skip
        _to_free(R, order, col)
        out[:, m] = col
