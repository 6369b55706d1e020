"""Banded symmetric systems in numba (the compiled Newton's linear algebra, :mod:`matid.rod.kernel`).

Storage by rows: ``S[i, t] = K[i, i - u + t]`` for t = 0..u, the lower triangle of a
symmetric band matrix of half-bandwidth u. :func:`cholesky` (L L^T, in place) refuses a
pivot that is not positive - the stability test of a tangent, as LAPACK's dpbtrf in
:meth:`matid.rod.fem.Banded.factor`; :func:`band_lu` is LU with partial pivoting
(LINPACK dgbfa/dgbsl) for the symmetric indefinite case. Costs O(n u^2).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def cholesky(S, u):
    """In-place banded Cholesky of the lower band S (rows); False when a pivot is not positive."""
    n = S.shape[0]
    inv = np.empty(n)  # 1 / L[j, j]
    for i in range(n):
        j0, oi = max(0, i - u), u - i
        for j in range(j0, i + 1):
            oj = u - j
            s = S[i, j + oi]
            for k in range(j0, j):
                s -= S[i, k + oi] * S[j, k + oj]
            if j < i:
                S[i, j + oi] = s * inv[j]
            elif not s > 0.0:
                return False
            else:
                S[i, u] = np.sqrt(s)
                inv[i] = 1.0 / S[i, u]
    return True


@njit(cache=True)
def cholesky_solve(L, u, b):
    """x with L L^T x = b, L from :func:`cholesky`."""
    n = L.shape[0]
    x = b.copy()
    for i in range(n):
        s = x[i]
        for k in range(max(0, i - u), i):
            s -= L[i, k - i + u] * x[k]
        x[i] = s / L[i, u]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, min(n, i + u + 1)):
            s -= L[k, i - k + u] * x[k]
        x[i] = s / L[i, u]
    return x


@njit(cache=True)
def band_lu(S, u):
    """LU with partial pivoting (LINPACK dgbfa) of the symmetric band matrix whose lower band is S.

    Returns (abd, ipvt, info): abd[2u + i - j, j] holds the factors (0-based), info > 0
    names a zero pivot (1-based, as LAPACK).
    """
    n = S.shape[0]
    ml = mu = u
    m = ml + mu  # 0-based row of the diagonal
    abd = np.zeros((2 * ml + mu + 1, n))
    for i in range(n):
        for t in range(u + 1):
            j = i - u + t
            if j >= 0:
                abd[m + i - j, j] = S[i, t]
                abd[m + j - i, i] = S[i, t]
    ipvt = np.zeros(n, dtype=np.int64)
    info = 0
    ju = 0
    for k in range(n - 1):
        lm = min(ml, n - 1 - k)
        best, r = -1.0, m
        for i in range(m, m + lm + 1):
            if abs(abd[i, k]) > best:
                best, r = abs(abd[i, k]), i
        ipvt[k] = r + k - m
        if abd[r, k] == 0.0:
            info = k + 1
            continue
        if r != m:
            abd[r, k], abd[m, k] = abd[m, k], abd[r, k]
        t = -1.0 / abd[m, k]
        for i in range(m + 1, m + lm + 1):
            abd[i, k] *= t
        ju = min(max(ju, mu + ipvt[k] + 1), n)
        mm = m
        for j in range(k + 1, ju):
            r -= 1
            mm -= 1
            t = abd[r, j]
            if r != mm:
                abd[r, j], abd[mm, j] = abd[mm, j], t
            for i in range(lm):
                abd[mm + 1 + i, j] += t * abd[m + 1 + i, k]
    ipvt[n - 1] = n - 1
    if n and abd[m, n - 1] == 0.0:
        info = n
    return abd, ipvt, info


@njit(cache=True)
def band_lu_solve(abd, ipvt, u, b):
    """x with A x = b from :func:`band_lu` (LINPACK dgbsl)."""
    n = abd.shape[1]
    m = 2 * u
    x = b.copy()
    for k in range(n - 1):
        lm = min(u, n - 1 - k)
        r = ipvt[k]
        t = x[r]
        if r != k:
            x[r], x[k] = x[k], t
        for i in range(lm):
            x[k + 1 + i] += t * abd[m + 1 + i, k]
    for k in range(n - 1, -1, -1):
        x[k] /= abd[m, k]
        lm = min(k, m)
        t = -x[k]
        for i in range(lm):
            x[k - lm + i] += t * abd[m - lm + i, k]
    return x
