"""Compiled rod part of the three-point bend (numba): :meth:`matid.rod.bend_system.BendSystem.evaluate`.

The bend's planar rod lives on a mesh moved with sigma, the arc length of the support
vertex (uniform elements on each side of it, :meth:`matid.rod.bend.BendModel.vertices`).
On the moved mesh phi is unchanged and, per element, phi' and dx scale with the length
ratio h_e / h_e(base) (:meth:`matid.rod.fem.Discretisation.moved`), so the tables are
rescaled here and the planar rod is assembled as :func:`matid.rod.kernel._assemble` does
(the bend's rod has no point loads). With the pointwise derivatives g, H of the same
points, the mesh derivative is

    dR/dsigma = sum_e dh_e/dsigma dR_e/dh_e,   dR_e/dh = sum_q [W_0 (g_u/h + dg_u/dh) + W_1 dg_u'/dh],
    dg/dh = -H[:, u'] u'/h,   dh_e/dsigma = 1/k inside the support vertex k, -1/(ne - k) outside

(:meth:`matid.rod.bend_system.BendSystem._mesh_derivative`, the numpy oracle). Outputs
are in free-dof numbering; the tangent in the full LAPACK band storage of
:class:`matid.rod.fem.Banded` (``ab[u + i - j, j] = K[i, j]``, band order).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from matid.rod.bandsolve import band_lu, band_lu_solve, cholesky, cholesky_solve
from matid.rod.kernel import _add_element, _at_point, _element_matrix, _planar_point, _scatter


@njit(cache=True)
def work_arrays(ne, nq, nloc, nf, n):
    """Scratch of :func:`evaluate` for one bend system (allocated once)."""
    nv = 2 * nf
    return (
        np.empty((ne, nq, 2, nloc)),  # moved point tables
        np.empty((ne, nq)),  # moved weights
        np.empty(ne + 1),  # moved vertices
        np.empty(ne),  # moved element lengths
        np.empty(n),  # residual, band order
        np.empty(n),  # dR/dsigma, band order
        np.empty((nloc * nf, nloc * nf)),  # element tangent
        np.empty(nv),  # z = (u, u') at a point
        np.empty(nv),  # g
        np.zeros((nv, nv)),  # H
        np.empty(nv),  # dg/dh
        np.empty(2),  # point stresses (not used: consistent tangent)
        np.empty((2, nv)),
    )


@njit(cache=True)
def _move(sigma, half, k, inner, outer, v0, T0, dx0, T, dx, v, h):
    """Vertices, element lengths and rescaled tables of the mesh with its support vertex at sigma."""
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
def evaluate(
    U, lam, sigma, half, k, inner, outer, v0, T0, dx0, gdofs, bpos, order, u, props, mu, B, f, kref,
    tangent, work, R_free, ab, dR_free
):  # fmt: skip
    """Residual (free dofs) at U and, with ``tangent``, the tangent (``ab``, band order) and
    dR/dsigma (free dofs): the planar rod of :func:`matid.rod.kernel._assemble`, per point
    also the mesh derivative of the module docstring."""
    T, dx, v, h, R, dR, Kl, z, g, H, dg, su, CJ = work
    _move(sigma, half, k, inner, outer, v0, T0, dx0, T, dx, v, h)
    ne, nq = dx.shape
    nloc = T.shape[3]
    nf = gdofs.shape[1] // nloc
    R[:] = 0.0
    dR[:] = 0.0
    if tangent:
        ab[:] = 0.0
    for e in range(ne):
        Kl[:] = 0.0
        dh = 1.0 / k if e < k else -1.0 / (ne - k)
        for qp in range(nq):
            w = dx[e, qp]
            _at_point(T, e, qp, gdofs, U, nf, z)
            _planar_point(
                z, lam, props[0, e, qp], props[2, e, qp], props[3, e, qp], lam * mu[e, qp], B, f, kref,
                g, H, su, CJ, su, False
            )  # fmt: skip
            _scatter(T, e, qp, gdofs, bpos, nf, w, g, R)
            if not tangent:
                continue
            for a in range(2 * nf):  # dg/dh = -H[:, u'] u'/h (+ g_u/h)
                t = 0.0
                for d in range(nf):
                    t -= H[a, nf + d] * z[nf + d]
                dg[a] = t / h[e]
            for a in range(nf):
                dg[a] += g[a] / h[e]
            _scatter(T, e, qp, gdofs, bpos, nf, w * dh, dg, dR)
            _element_matrix(T, e, qp, nf, w, H, Kl)
        if tangent:
            _add_element(Kl, e, gdofs, bpos, u, ab, True)
    for j in range(order.size):
        R_free[order[j]] = R[j]
        dR_free[order[j]] = dR[j]


@njit(cache=True)
def bordered_factor(ab, u, order, position, B, C, L, Sinv):
    """The factors of :meth:`matid.rod.bordered.Bordered.factor`: K_rho = K + rho G^T G (``ab``
    plus the contact rows C[:2], rho = max(1, max |diag K|)) by banded Cholesky in ``L`` (rows,
    :mod:`matid.rod.bandsolve`), or LU when a pivot is not positive; Z = K_rho^-1 B and the
    inverse of the 3 x 3 Schur complement C Z into ``Sinv``.

    Returns (rho, Cholesky succeeded, LU factors, pivots, LINPACK info, Z, det(C Z)).
    """
    n = ab.shape[1]
    rho = 1.0
    for j in range(n):
        rho = max(rho, abs(ab[u, j]))
    for i in range(n):
        for t in range(u + 1):
            j = i - u + t
            L[i, t] = ab[u + i - j, j] if j >= 0 else 0.0
    nz = np.empty(C.shape[1], dtype=np.int64)
    for c in range(2):  # each contact row lives on one vertex: rho g g^T is in the band
        m = 0
        for a in range(C.shape[1]):
            if C[c, a] != 0.0:
                nz[m] = a
                m += 1
        for x in range(m):
            for y in range(m):
                pa, pb = position[nz[x]], position[nz[y]]
                if pb <= pa:
                    L[pa, pb - pa + u] += rho * C[c, nz[x]] * C[c, nz[y]]
    S = L.copy()
    ok = cholesky(L, u)
    abd, ipvt, info = np.zeros((1, 1)), np.zeros(1, dtype=np.int64), -1
    if not ok:
        abd, ipvt, info = band_lu(S, u)
        if info != 0:
            return rho, ok, abd, ipvt, info, np.zeros((n, 3)), 0.0
    Z = np.empty((n, 3))
    rhs = np.empty(n)
    for c in range(3):
        for j in range(n):
            rhs[j] = B[order[j], c]
        x = cholesky_solve(L, u, rhs) if ok else band_lu_solve(abd, ipvt, u, rhs)
        for j in range(n):
            Z[order[j], c] = x[j]
    CZ = np.zeros((3, 3))
    for p in range(3):
        for a in range(n):
            for q in range(3):
                CZ[p, q] += C[p, a] * Z[a, q]
    return rho, ok, abd, ipvt, info, Z, _inverse3(CZ, Sinv)


@njit(cache=True)
def _inverse3(S, out):
    """out = S^-1 (3 x 3) by the adjugate, as :func:`matid.rod.bordered._inverse3`; returns det S."""
    a, b, c = S[0, 0], S[0, 1], S[0, 2]
    d, e, f = S[1, 0], S[1, 1], S[1, 2]
    g, h, i = S[2, 0], S[2, 1], S[2, 2]
    c0, c1, c2 = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * c0 + b * c1 + c * c2
    if not (np.isfinite(det) and abs(det) > 1e-300):  # singular: the caller raises
        return det
    out[0, 0], out[0, 1], out[0, 2] = c0 / det, (c * h - b * i) / det, (b * f - c * e) / det
    out[1, 0], out[1, 1], out[1, 2] = c1 / det, (a * i - c * g) / det, (c * d - a * f) / det
    out[2, 0], out[2, 1], out[2, 2] = c2 / det, (b * g - a * h) / det, (a * e - b * d) / det
    return det


@njit(cache=True)
def bordered_solve(r, rho, ok, L, abd, ipvt, u, order, C, Z, Sinv, out):
    """out[:, m] = the bordered tangent's solution for r[:, m] (:meth:`matid.rod.bordered.Bordered.solve`)."""
    n = Z.shape[0]
    f, y, w = np.empty(n), np.empty(n), np.empty(3)
    for col in range(r.shape[1]):
        for j in range(n):
            a = order[j]
            f[j] = r[a, col] + rho * (C[0, a] * r[n, col] + C[1, a] * r[n + 1, col])
        x = cholesky_solve(L, u, f) if ok else band_lu_solve(abd, ipvt, u, f)
        for j in range(n):
            y[order[j]] = x[j]
        for p in range(3):
            t = -r[n + p, col]
            for a in range(n):
                t += C[p, a] * y[a]
            w[p] = t
        for p in range(3):
            t = 0.0
            for q in range(3):
                t += Sinv[p, q] * w[q]
            out[n + p, col] = t
        w0, w1, w2 = out[n, col], out[n + 1, col], out[n + 2, col]
        for a in range(n):
            out[a, col] = y[a] - (Z[a, 0] * w0 + Z[a, 1] * w1 + Z[a, 2] * w2)
