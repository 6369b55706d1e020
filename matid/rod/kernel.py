"""Compiled Newton solve of a clamped rod (numba): the same equations as :mod:`matid.rod.models`.

One call runs :func:`matid.rod.newton.newton` on a :class:`~matid.rod.models.RodSystem`
(planar model, or full model with normalised quaternions) without a Python step per
iteration: the pointwise derivatives, the assembly into band storage, a banded
Cholesky factorisation and the mixed-integration-point update are loops over the
quadrature points. Per point, with z = (u, u') and the element tables [phi, phi'],

    R_(i,c)      += dx [g_c phi_i + g_(nf+c) phi_i']
    K_(i,c)(j,d) += dx sum_(k,l) B_k,i H_(k nf + c)(l nf + d) B_l,j,   B = [phi, phi']

with g, H the closed forms of :func:`matid.physics.planar.derivatives` and
:func:`matid.physics.full.derivatives` (tests compare them with the jets). Band storage
is by rows, ``S[i, t] = K[i, i - u + t]`` for t = 0..u (the lower triangle: the
tangent is symmetric). As in :meth:`matid.rod.fem.Banded.factor`, each tangent is
factorised by Cholesky, whose success is the stability test, and by banded LU with
partial pivoting (LINPACK dgbfa/dgbsl) when a pivot is not positive.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from matid.rod.bandsolve import band_lu, band_lu_solve, cholesky, cholesky_solve  # noqa: F401
from matid.rod.compiled import (  # noqa: F401 - the statuses are read off this module too
    CONVERGED,
    DIVERGING,
    FULL,
    MAX_ITER,
    NOT_FINITE_DX,
    NOT_FINITE_R,
    PLANAR,
    SINGULAR,
    STAGNATION,
)


@njit(cache=True)
def _planar_point(z, lam, Eb, Es, Ee, mu, B, f, kref, g, H, su, CJ, stress, use_stress):
    th, dx, dz, dth = z[2], z[3], z[4], z[5]
    c, s = np.cos(th), np.sin(th)
    nu1, nu3 = dx * c - dz * s, dx * s + dz * c
    n1, n3 = Es * nu1, Ee * (nu3 - 1.0)
    g[0], g[1] = -lam * f[0], -lam * f[2]
    g[2] = -n1 * nu3 + n3 * nu1 - mu * (c * B[0] - s * B[2])
    g[3], g[4] = n1 * c + n3 * s, -n1 * s + n3 * c
    g[5] = Eb * (dth - lam * kref[1])
    su[0], su[1] = n1, n3
    CJ[:] = 0.0
    CJ[0, 2], CJ[0, 3], CJ[0, 4] = -Es * nu3, Es * c, -Es * s
    CJ[1, 2], CJ[1, 3], CJ[1, 4] = Ee * nu1, Ee * s, Ee * c
    if use_stress:
        n1, n3 = stress[0], stress[1]
    H[:] = 0.0
    H[2, 2] = Es * nu3 * nu3 + Ee * nu1 * nu1 - n1 * nu1 - n3 * nu3 + mu * (s * B[0] + c * B[2])
    H[2, 3] = H[3, 2] = -Es * nu3 * c + Ee * nu1 * s - n1 * s + n3 * c
    H[2, 4] = H[4, 2] = Es * nu3 * s + Ee * nu1 * c - n1 * c - n3 * s
    H[3, 3] = Es * c * c + Ee * s * s
    H[3, 4] = H[4, 3] = (Ee - Es) * s * c
    H[4, 4] = Es * s * s + Ee * c * c
    H[5, 5] = Eb


@njit(cache=True)
def _full_point(z, lam, C, mu, M, f, kref, A, Q, g, H, su, CJ, stress, use_stress, Qq, gF, F, s, G):
    """Normalised full model at one point: z = (r, q, r', q'); see :mod:`matid.physics.full`.

    Qq (3, 3, 4), gF (7, 14), F (7), s (7) and G (14) are scratch. Loop bounds are read off
    the arrays, not literals, so that LLVM does not unroll them: that keeps the first
    compile short (7 s -> 1-3 s for this function).
    """
    n3, n4, nv, nF, ns = Q.shape[0], Q.shape[2], z.size, F.size, su.size
    QS, DR, DQ = n3, n3 + n4, 2 * n3 + n4
    n2 = 0.0
    for a in range(n4):
        n2 += z[QS + a] * z[QS + a]
    inv = 1.0 / n2
    gF[:] = 0.0
    F[:] = 0.0
    for j in range(n3):
        for i in range(n3):
            for a in range(n4):
                t = 0.0
                for b in range(n4):
                    t += Q[j, i, a, b] * z[QS + b]
                Qq[j, i, a] = t
    for i in range(n3):
        for a in range(n4):
            for b in range(n4):
                F[i] += z[QS + a] * A[i, a, b] * z[DQ + b]
                gF[i, QS + a] += A[i, a, b] * z[DQ + b]
                gF[i, DQ + b] += A[i, a, b] * z[QS + a]
        for j in range(n3):
            r_ji = 0.0
            for a in range(n4):
                r_ji += z[QS + a] * Qq[j, i, a]
                gF[n3 + i, QS + a] += 2.0 * z[DR + j] * Qq[j, i, a]
            F[n3 + i] += z[DR + j] * r_ji
            gF[n3 + i, DR + j] = r_ji
    for a in range(n4):
        for b in range(n4):
            F[nF - 1] += z[QS + a] * M[a, b] * z[QS + b]
            gF[nF - 1, QS + a] += 2.0 * M[a, b] * z[QS + b]
    for k in range(nF):  # F -> e = F/n2 and gF -> grad e in place
        F[k] *= inv
        for a in range(n4):
            gF[k, QS + a] -= F[k] * 2.0 * z[QS + a]
        for b in range(nv):
            gF[k, b] *= inv
    e, ge = F, gF
    for k in range(ns):
        ref = lam * kref[k] if k < n3 else (1.0 if k == ns - 1 else 0.0)
        s[k] = C[k] * (e[k] - ref)
    s[nF - 1] = -lam * mu
    for b in range(nv):
        t = 0.0
        for k in range(nF):
            t += s[k] * ge[k, b]
        g[b] = t
    for j in range(n3):
        g[j] -= lam * f[j]
    for k in range(ns):
        su[k] = s[k]
        for b in range(nv):
            CJ[k, b] = C[k] * ge[k, b]
    G[:] = g
    for j in range(n3):
        G[j] += lam * f[j]
    if use_stress:
        for k in range(ns):
            s[k] = stress[k]
        for b in range(nv):
            t = 0.0
            for k in range(nF):
                t += s[k] * ge[k, b]
            G[b] = t
    se = 0.0
    for k in range(nF):
        se += s[k] * e[k]
    for a in range(nv):
        for b in range(nv):
            t = 0.0
            for k in range(ns):
                t += C[k] * ge[k, a] * ge[k, b]
            H[a, b] = t
    for a in range(n4):  # the geometric part HS / n2
        for b in range(n4):
            t = 0.0
            for i in range(n3):
                t += s[i] * A[i, a, b]
            H[QS + a, DQ + b] += t * inv
            H[DQ + b, QS + a] += t * inv
            t = 2.0 * s[nF - 1] * M[a, b]
            for i in range(n3):
                for j in range(n3):
                    t += 2.0 * s[n3 + i] * z[DR + j] * Q[j, i, a, b]
            H[QS + a, QS + b] += t * inv
        for j in range(n3):
            t = 0.0
            for i in range(n3):
                t += 2.0 * s[n3 + i] * Qq[j, i, a]
            H[QS + a, DR + j] += t * inv
            H[DR + j, QS + a] += t * inv
        for b in range(nv):
            H[QS + a, b] -= G[b] * 2.0 * z[QS + a] * inv
            H[b, QS + a] -= G[b] * 2.0 * z[QS + a] * inv
        H[QS + a, QS + a] -= 2.0 * se * inv


@njit(cache=True)
def scratch(nf, nloc):
    """Work arrays of :func:`_assemble` (allocated once per Newton solve, not per evaluation)."""
    nv = 2 * nf
    return (
        np.empty(nv),
        np.empty(nv),
        np.zeros((nv, nv)),
        np.empty(6),
        np.empty((nloc * nf, nloc * nf)),
        np.empty((3, 3, 4)),
        np.empty((7, 14)),
        np.empty(7),
        np.empty(7),
        np.empty(14),
    )


@njit(cache=True)
def _max_abs(x):
    """max |x|, or -1 when an entry is not finite."""
    m = 0.0
    for v in x:
        if not np.isfinite(v):
            return -1.0
        m = max(m, abs(v))
    return m


@njit(cache=True)
def _at_point(T, e, qp, gdofs, U, nf, out):
    """out = (u, u') at quadrature point qp of element e: the basis tables T applied to U."""
    nloc = T.shape[3]
    for k in range(2):
        for c in range(nf):
            t = 0.0
            for i in range(nloc):
                t += T[e, qp, k, i] * U[gdofs[e, i * nf + c]]
            out[k * nf + c] = t


@njit(cache=True)
def _scatter(T, e, qp, gdofs, bpos, nf, w, g, R):
    """R += w [phi_i, phi_i'] . g at the dofs in band order (fixed dofs skipped)."""
    nloc = T.shape[3]
    for i in range(nloc):
        b0, b1 = w * T[e, qp, 0, i], w * T[e, qp, 1, i]
        for c in range(nf):
            pos = bpos[gdofs[e, i * nf + c]]
            if pos >= 0:
                R[pos] += b0 * g[c] + b1 * g[nf + c]


@njit(cache=True)
def _element_matrix(T, e, qp, nf, w, H, Kl):
    """Kl_(i,c)(j,d) += w B_(k,i) H_ab B_(l,j), a = k nf + c, b = l nf + d (zero entries of H skipped)."""
    nloc = T.shape[3]
    for k in range(2):
        for c in range(nf):
            for l in range(2):  # noqa: E741 - the index of the formula
                for d in range(nf):
                    h = H[k * nf + c, l * nf + d]
                    if h == 0.0:  # most of the planar H (10 of 36 entries are not zero)
                        continue
                    for i in range(nloc):
                        wh = w * T[e, qp, k, i] * h
                        for j in range(nloc):
                            Kl[i * nf + c, j * nf + d] += wh * T[e, qp, l, j]


@njit(cache=True)
def _add_element(Kl, e, gdofs, bpos, u, S, full):
    """S += the element tangent Kl of element e at its dofs' band positions (fixed dofs skipped):
    the lower band by rows, ``S[i, j - i + u] = K[i, j]`` (j <= i), or with ``full`` LAPACK's
    full band, ``S[u + i - j, j] = K[i, j]`` (:class:`matid.rod.fem.Banded`)."""
    m = Kl.shape[0]
    for a in range(m):
        pa = bpos[gdofs[e, a]]
        if pa < 0:
            continue
        for b in range(m):
            pb = bpos[gdofs[e, b]]
            if full:
                if pb >= 0 and abs(pa - pb) <= u:
                    S[u + pa - pb, pb] += Kl[a, b]
            elif 0 <= pb <= pa:
                S[pa, pb - pa + u] += Kl[a, b]


@njit(cache=True)
def _assemble(
    U, lam, model, T, dx, gdofs, bpos, u, props, mu, B, f, kref, A, Q, M, point, magnets, c_u, stress,
    use_stress, su_all, CJ_all, R, S, work, tangent
):  # fmt: skip
    """Residual R (band order) and, when ``tangent``, the lower band S of the tangent at U
    (else S is left unassembled: the load derivative needs residuals only); ``work`` from
    :func:`scratch`."""
    ne, nq = dx.shape
    nloc = T.shape[3]
    nf = gdofs.shape[1] // nloc
    R[:] = 0.0
    S[:] = 0.0
    z, g, H, C, Kl, Qq, gF, F, sk, G = work
    H[:] = 0.0
    for e in range(ne):
        Kl[:] = 0.0
        for qp in range(nq):
            w = dx[e, qp]
            _at_point(T, e, qp, gdofs, U, nf, z)
            if model == PLANAR:
                _planar_point(
                    z, lam, props[0, e, qp], props[2, e, qp], props[3, e, qp], lam * mu[e, qp], B, f,
                    kref, g, H, su_all[e, qp], CJ_all[e, qp], stress[e, qp], use_stress
                )  # fmt: skip
            else:
                C[0] = C[1] = props[0, e, qp]
                C[2], C[3], C[4], C[5] = props[1, e, qp], props[2, e, qp], props[2, e, qp], props[3, e, qp]
                _full_point(
                    z, lam, C, mu[e, qp], M, f, kref, A, Q, g, H, su_all[e, qp], CJ_all[e, qp],
                    stress[e, qp], use_stress, Qq, gF, F, sk, G
                )  # fmt: skip
            _scatter(T, e, qp, gdofs, bpos, nf, w, g, R)
            if tangent:
                _element_matrix(T, e, qp, nf, w, H, Kl)
        if tangent:
            _add_element(Kl, e, gdofs, bpos, u, S, False)
    _point_terms(U, lam, model, bpos, u, B, point, magnets, c_u, R, S)


@njit(cache=True)
def _point_terms(U, lam, model, bpos, u, B, point, magnets, c_u, R, S):
    """Tip loads, lumped magnets (planar) and the nodal unity penalty (full, normalised)."""
    for k in range(U.size):
        if bpos[k] >= 0:
            R[bpos[k]] -= lam * point[k]
    if model == PLANAR:
        for k in range(magnets.shape[0]):
            dof, m = int(magnets[k, 0]) * 3 + 2, magnets[k, 1]
            th, pos = U[dof], bpos[int(magnets[k, 0]) * 3 + 2]
            if pos >= 0:
                R[pos] -= lam * m * (np.cos(th) * B[0] - np.sin(th) * B[2])
                S[pos, u] += lam * m * (np.sin(th) * B[0] + np.cos(th) * B[2])
        return
    for node in range(U.size // 7):
        base = node * 7 + 3
        e = U[base] ** 2 + U[base + 1] ** 2 + U[base + 2] ** 2 + U[base + 3] ** 2 - 1.0
        for a in range(4):
            pa = bpos[base + a]
            if pa < 0:
                continue
            R[pa] += 2.0 * c_u * e * U[base + a]
            for b in range(4):
                pb = bpos[base + b]
                if 0 <= pb <= pa:
                    S[pa, pb - pa + u] += c_u * (
                        4.0 * U[base + a] * U[base + b] + (2.0 * e if a == b else 0.0)
                    )


@njit(cache=True)
def _mixed_update(dU, alpha, T, gdofs, su_all, CJ_all, stress, use_stress):
    """sigma += alpha (C (e(u) + J du) - sigma) at every point (RodSystem.mixed_update)."""
    ne, nq, _, nloc = T.shape
    nf = gdofs.shape[1] // nloc
    ns = su_all.shape[2]
    dz = np.empty(2 * nf)
    for e in range(ne):
        for qp in range(nq):
            _at_point(T, e, qp, gdofs, dU, nf, dz)
            for m in range(ns):
                target = su_all[e, qp, m]
                for v in range(2 * nf):
                    target += CJ_all[e, qp, m, v] * dz[v]
                old = stress[e, qp, m] if use_stress else su_all[e, qp, m]
                stress[e, qp, m] = old + alpha * (target - old)


@njit(cache=True)
def newton(
    x0, U_ref, free_dofs, lam, model, T, dx, gdofs, bpos, order, u, props, mu, B, f, kref, A, Q, M, point,
    magnets, c_u,
    xtol, floor, max_iter, max_step, mixed, mixed_above, stress, use0, su_all, load
):  # fmt: skip
    """Newton at load factor lam from the free dofs x0 (``free_dofs``: their global numbers; the
    fixed ones from ``U_ref``), as :func:`matid.rod.newton.newton`.

    With ``max_iter`` = 0 there is no iteration: ``load`` (band order) receives dR/dlam =
    R(x0, 1) - R(x0, 0) for the continuation's tangent predictor (every load is linear in lam).

    ``stress`` (ne, nq, ns): the mixed tangent's point stresses of the first iteration when
    ``use0`` (a warm start), overwritten by the iteration; ``su_all`` receives C e(u) at the
    points of the last evaluation (the converged state's stresses, for the next warm start).
    Returns (x, status, iterations, last correction, first correction, L, abd, ipvt, info):
    status is one of CONVERGED ... SINGULAR; the last tangent's factors are the Cholesky
    L when ``info`` is -1, else the LU factors (abd, ipvt) and ``info`` LINPACK's.
    """
    n = order.size
    ne, nq = dx.shape
    ns = 2 if model == PLANAR else 6
    nv = gdofs.shape[1] // T.shape[3] * 2
    U = U_ref.copy()
    for i in range(free_dofs.size):
        U[free_dofs[i]] = x0[i]
    R = np.empty(n)
    S = np.empty((n, u + 1))
    L = np.empty((n, u + 1))
    abd, ipvt = np.zeros((1, 1)), np.zeros(1, dtype=np.int64)
    CJ_all = np.zeros((ne, nq, ns, nv))
    use_stress = np.zeros(1, dtype=np.int64)  # an array, not a literal: one compiled _assemble
    use_stress[0] = 1 if (mixed and use0) else 0
    dU = np.zeros(U.size)
    sizes = np.zeros(max_iter)
    size = 0.0
    work = scratch(gdofs.shape[1] // T.shape[3], T.shape[3])
    if max_iter == 0:
        for level in (1.0, 0.0):
            _assemble(U, level, model, T, dx, gdofs, bpos, u, props, mu, B, f, kref, A, Q, M, point,
                      magnets, c_u, stress, use_stress[0] != 0, su_all, CJ_all, R, S, work,
                      False)  # fmt: skip
            if level == 1.0:
                load[:] = R
        load -= R
        return x0, CONVERGED, 0, size, size, L, abd, ipvt, -1
    for it in range(1, max_iter + 1):
        _assemble(
            U, lam, model, T, dx, gdofs, bpos, u, props, mu, B, f, kref, A, Q, M, point, magnets, c_u,
            stress, use_stress[0] != 0, su_all, CJ_all, R, S, work, True
        )  # fmt: skip
        if _max_abs(R) < 0.0:
            return x0, NOT_FINITE_R, it, size, sizes[0], L, abd, ipvt, -1
        L[:] = S
        if cholesky(L, u):
            info = -1
            d = cholesky_solve(L, u, -R)
        else:  # not positive definite: LU, as fem.Banded.factor
            abd, ipvt, info = band_lu(S, u)
            if info != 0:
                return x0, SINGULAR, it, size, sizes[0], L, abd, ipvt, info
            d = band_lu_solve(abd, ipvt, u, -R)
        size = _max_abs(d)
        if size < 0.0:
            return x0, NOT_FINITE_DX, it, size, sizes[0], L, abd, ipvt, info
        k = it - 1
        if size <= xtol or (size <= floor and k > 0 and size > 0.1 * sizes[k - 1]):
            for j in range(n):
                U[order[j]] += d[j]
            return U[free_dofs], CONVERGED, it, size, sizes[0], L, abd, ipvt, info
        if k >= 3 and size > sizes[k - 1] and size > sizes[k - 3]:
            lo = min(sizes[k - 3], sizes[k - 2], sizes[k - 1])
            hi = max(sizes[k - 3], sizes[k - 2], sizes[k - 1])
            if size < 1e-3 and hi < 10 * lo and size < 1e-2 * sizes[0]:
                return x0, STAGNATION, it, size, sizes[0], L, abd, ipvt, info
            return x0, DIVERGING, it, size, sizes[0], L, abd, ipvt, info
        sizes[k] = size
        alpha = min(1.0, max_step / size)
        if mixed:
            if size > mixed_above:
                for j in range(n):
                    dU[order[j]] = d[j]
                _mixed_update(dU, alpha, T, gdofs, su_all, CJ_all, stress, use_stress[0] != 0)
                use_stress[0] = 1
            else:
                use_stress[0] = 0
        for j in range(n):
            U[order[j]] += alpha * d[j]
    return x0, MAX_ITER, max_iter, size, sizes[0], L, abd, ipvt, info
