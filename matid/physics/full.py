"""Closed-form gradient and Hessian of the full-model density, both quaternion treatments.

Variables per point z = (r, q, r', q') (14); only y = (q, r', q') (11) enter the strains.
Every strain is a polynomial numerator times a power of n2 = |q|^2
(:mod:`matid.physics.kinematics`):

    kappa_i = a_i n2^p,  a_i = q^T A_i q'              (A_i constant, bilinear)
    nu_i    = b_i n2^p,  b_i = sum_j r'_j q^T Q_ji q   (R_ji(q) = q^T Q_ji q, Q constant)
    d3.B    = m n2^p,    m = q^T (sum_j B_j Q_j3) q

with p = -1 for every row when the directors come from q/|q| (normalised), and p = +1 for
kappa, 0 for nu and d3 with the raw q (the paper's). For e = F a(n2), a = n2^p:

    grad e = a grad F + a' F grad n2
    Hess e = a Hess F + a' (grad F grad n2^T + grad n2 grad F^T) + a'' F grad n2 grad n2^T + 2 a' F I_q.

The density W = 1/2 sum_k C_k (e_k - e_k^ref)^2 - lam mu d3.B (+ c_u/2 (n2 - 1)^2, raw) then
has, with s_k = dW/de_k,

    g = sum_k s_k grad e_k,   H = sum_k C_k grad e_k grad e_k^T + sum_k s_k Hess e_k,

each a few batched matrix products over all points at once with the constant tensors A, Q read
off kinematics.directors and kinematics.curvature_numerator, so this is the same model as the
jets (compared to them in tests/rod/test_derivatives.py).
"""

from __future__ import annotations

import functools

import numpy as np

from matid.physics import kinematics as kin

_E = np.eye(4)


def _bilinear() -> np.ndarray:
    """A[i, a, b] with a_i(q, p) = q^T A_i p (curvature numerator 2 G(q) p)."""
    return np.array([[kin.curvature_numerator(_E[a], _E[b]) for b in range(4)] for a in range(4)]).transpose(
        2, 0, 1
    )


def _quadratic() -> np.ndarray:
    """Q[j, i, a, b] symmetric with R_ji(q) = q^T Q_ji q (eq. 2)."""
    R = lambda q: np.array(kin.directors(q))  # noqa: E731
    Q = np.zeros((3, 3, 4, 4))
    for a in range(4):
        Q[:, :, a, a] = R(_E[a])
        for b in range(a + 1, 4):
            Q[:, :, a, b] = Q[:, :, b, a] = 0.5 * (R(_E[a] + _E[b]) - R(_E[a]) - R(_E[b]))
    return Q


A = _bilinear()
Q = _quadratic()
A_S = A.reshape(3, 16)  # s @ A_S = sum_i s_i A_i
Q_S = Q.reshape(9, 16)  # (r' (x) s) @ Q_S = sum_ji r'_j s_i Q_ji
# local variables y = (q, r', q') of z = (r, q, r', q')
YQ, YR, YP = slice(0, 4), slice(4, 7), slice(7, 11)
#: Rows per product of the point values with a constant matrix (:func:`rows_times`): OpenBLAS runs
#: (832, 14) @ (14, 64) on its threads, and on a loaded 2-core machine their start-up took 22 ms
#: against 20 us for (512, 14) (measured at load 8; a stack of 26 full-model scenes has 832 points).
PRODUCT_ROWS = 256


def rows_times(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b for a (n, k) and a small constant b, PRODUCT_ROWS rows per BLAS call (row by row the
    same products)."""
    if a.shape[0] <= PRODUCT_ROWS:
        return a @ b
    out = np.empty((a.shape[0], b.shape[1]))
    for i in range(0, a.shape[0], PRODUCT_ROWS):
        np.matmul(a[i : i + PRODUCT_ROWS], b, out=out[i : i + PRODUCT_ROWS])
    return out


Q_S2 = 2.0 * Q_S
#: (s (x) q) @ Q_T = 2 sum_i s_i Q_ji q as [a, j]: Q_T[(i, b), (a, j)] = 2 Q[j, i, a, b]
Q_T = 2.0 * Q.transpose(1, 3, 2, 0).reshape(12, 12)
_EYE16 = np.eye(4).reshape(1, 16)
#: exponents p of n2 per strain row (kappa 1-3, nu 1-3, d3.B)
POWERS = {kin.NORMALISED: np.full(7, -1.0), kin.RAW: np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0])}


@functools.lru_cache(maxsize=16)
def linear_maps(B: tuple[float, float, float]) -> np.ndarray:
    """W (14, 64) with z @ W = [A_i^T q (12), A_i q' (12), Q_ji q (36), M q (4)] at every point:
    every linear map of the point values in one matrix product (M = sum_j B_j Q_j3)."""
    W = np.zeros((14, 64))
    W[3:7, 0:12] = A.transpose(1, 0, 2).reshape(4, 12)  # [i, b] = sum_a q_a A_iab
    W[10:14, 12:24] = A.transpose(2, 0, 1).reshape(4, 12)  # [i, a] = sum_b A_iab q'_b
    W[3:7, 24:60] = Q.transpose(3, 0, 1, 2).reshape(4, 36)  # [j, i, a] = sum_b Q_jiab q_b
    W[3:7, 60:64] = np.einsum("j,jab->ab", np.asarray(B, float), Q[:, 2])
    return W


def derivatives(
    z, lam, props, kappa_ref, mu, B, tangent, *, stress, want_strain, variant=kin.NORMALISED, c_u=0.0
):
    """(g, H, strain) of the full-model density at every point: shapes P + (14,), P + (14, 14).

    z: P + (14,) the point values (r, q, r', q'); props: stiffness arrays (P); mu:
    magnetisation per length (P) or None; B: 3-vector; kappa_ref: 3-vector (scaled by lam
    here); ``variant``: directors from q/|q| or the raw q (then with the integrated penalty
    c_u/2 (|q|^2 - 1)^2). ``stress`` (P + (6,)): independent point stresses for the geometric
    part of the Hessian (the mixed tangent, see RodSystem.mixed_update; NaN at a point: its own
    consistent stress); strain: (C (e - e_ref),
    C de/dz) for that update with ``want_strain`` and ``tangent``, else None.
    """
    shape = z.shape[:-1]
    z = z.reshape(-1, 14)
    n = z.shape[0]
    q, dr = z[:, 3:7], z[:, 7:10]
    n2 = np.einsum("pa,pa->p", q, q)
    nF = 6 + (mu is not None)
    power = POWERS[variant][:nF]
    a = n2[:, None] ** power  # (n, nF)
    a1 = power * a / n2[:, None]
    W = linear_maps(tuple(float(b) for b in B))
    F, gF = _numerators(z, rows_times(z, W), mu is not None)
    M = W[3:7, 60:64] if mu is not None else None
    gn2 = np.zeros((n, 11))
    gn2[:, YQ] = 2.0 * q
    C = np.empty((n, 6))
    C[:, 0] = C[:, 1] = props["E_b"].ravel()
    C[:, 2], C[:, 3], C[:, 5] = props["E_t"].ravel(), props["E_s"].ravel(), props["E_e"].ravel()
    C[:, 4] = C[:, 3]
    ref = np.zeros((n, 6))  # kappa_ref: a 3-vector, or P + (3,) per point (per-segment precurvature)
    kappa_ref = np.asarray(kappa_ref, float)  # one rod-wide vector broadcasts in the assignment
    ref[:, :3], ref[:, 5] = lam * (kappa_ref if kappa_ref.ndim == 1 else kappa_ref.reshape(n, 3)), 1.0
    s = np.empty((n, nF))
    s[:, :6] = C * (a[:, :6] * F[:, :6] - ref)
    if mu is not None:
        s[:, 6] = -lam * np.ravel(mu)
    penalty = c_u * (n2 - 1.0) if variant == kin.RAW else None
    g = np.empty((n, 14))
    g[:, :3] = 0.0  # no elastic force on r itself (a distributed force: its term)
    g[:, 3:] = _gradient(s, a, a1, F, gF, gn2, penalty)
    if not tangent:
        return g.reshape(shape + (14,)), None, None
    ge6 = a[:, :6, None] * gF[:, :6] + (a1[:, :6] * F[:, :6])[:, :, None] * gn2[:, None, :]
    Cge = C[:, :, None] * ge6
    strain = None
    if want_strain:
        CJ = np.zeros((n, 6, 14))
        CJ[:, :, 3:] = Cge
        strain = (s[:, :6].reshape(shape + (6,)), CJ.reshape(shape + (6, 14)))
    if stress is not None:  # the geometric part from the independent point stresses; NaN rows: the
        s = s.copy()  # displacements' (a stack of mixed and consistent scenes)
        stress = stress.reshape(n, 6)
        s[:, :6] = np.where(np.isnan(stress), s[:, :6], stress)
    H = np.zeros((n, 14, 14))
    H[:, 3:, 3:] = _hessian(ge6, Cge, s, a, a1, power, n2, F, gF, gn2, dr, q, M, penalty, c_u)
    return g.reshape(shape + (14,)), H.reshape(shape + (14, 14)), strain


def _numerators(z, Wz, magnetic):
    """(F, dF/dy) at every point: the strain numerators and their gradients."""
    n = z.shape[0]
    q, dr, p = z[:, 3:7], z[:, 7:10], z[:, 10:14]
    Aq, Ap = Wz[:, 0:12].reshape(n, 3, 4), Wz[:, 12:24].reshape(n, 3, 4)
    Qq = Wz[:, 24:60].reshape(n, 3, 3, 4)  # [j, i, a] = (Q_ji q)_a
    nF = 6 + magnetic
    F = np.empty((n, nF))
    gF = np.zeros((n, nF, 11))
    F[:, :3] = np.einsum("pib,pb->pi", Aq, p)
    gF[:, :3, YQ] = Ap
    gF[:, :3, YP] = Aq
    R = np.einsum("pjia,pa->pji", Qq, q)  # R_ji(q)
    F[:, 3:6] = np.einsum("pj,pji->pi", dr, R)
    gF[:, 3:6, YQ] = 2.0 * np.einsum("pj,pjia->pia", dr, Qq)
    gF[:, 3:6, YR] = R.transpose(0, 2, 1)
    if magnetic:
        Mq = Wz[:, 60:64]
        F[:, 6] = np.einsum("pa,pa->p", Mq, q)
        gF[:, 6, YQ] = 2.0 * Mq
    return F, gF


def _gradient(s, a, a1, F, gF, gn2, penalty):
    """sum_k s_k grad e_k (+ the raw penalty's c_u (n2 - 1) grad n2) over y."""
    c1 = np.einsum("pk,pk->p", s * a1, F)
    if penalty is not None:
        c1 = c1 + penalty
    return np.einsum("pk,pka->pa", s * a, gF) + c1[:, None] * gn2


def _hessian(ge6, Cge, s, a, a1, power, n2, F, gF, gn2, dr, q, M, penalty, c_u):
    """sum_k C_k grad e_k grad e_k^T + sum_k s_k Hess e_k (+ the raw penalty's Hessian) over y.

    The rank-one terms of the chain rule, V grad n2^T + grad n2 V^T + c2 grad n2 grad n2^T with
    V = sum_k s_k a'_k grad F_k, ride in the same batched product as J^T C J: rows
    [grad e (6), grad n2, V] against [C grad e, c2 grad n2 + V, grad n2]. The second derivatives
    of the numerators (the q-q', q-q and q-r' blocks, each a constant map of the point values)
    are matrix products with constant tensors, written into one block array added at once
    (measured: 35.6 -> 26.6 us at 8 points, same values to round-off; four strided in-place adds,
    a fancy-indexed diagonal and an einsum cost the difference)."""
    n = s.shape[0]
    sa, sa1 = s * a, s * a1
    a2 = power * (power - 1.0) * a / (n2 * n2)[:, None]
    c2 = np.einsum("pk,pk->p", s * a2, F)
    c1 = 2.0 * np.einsum("pk,pk->p", sa1, F)
    if penalty is not None:
        c2 = c2 + c_u
        c1 = c1 + 2.0 * penalty
    V = np.einsum("pk,pka->pa", sa1, gF)
    rows, cols = np.empty((n, 8, 11)), np.empty((n, 8, 11))
    rows[:, :6], rows[:, 6], rows[:, 7] = ge6, gn2, V
    cols[:, :6], cols[:, 6], cols[:, 7] = Cge, c2[:, None] * gn2 + V, gn2
    H = np.matmul(rows.transpose(0, 2, 1), cols)
    blocks = np.zeros((n, 11, 11))
    S = rows_times(sa[:, :3], A_S).reshape(n, 4, 4)  # sum_i s_i A_i: the kappa rows' q-q' block
    blocks[:, YQ, YP] = S
    blocks[:, YP, YQ] = S.transpose(0, 2, 1)
    rs = (dr[:, :, None] * sa[:, None, 3:6]).reshape(n, 9)
    Hqq = rows_times(rs, Q_S2) + c1[:, None] * _EYE16  # 2 sum_ji r'_j s_i Q_ji + c1 I
    if M is not None:  # Hess (q^T M q) = 2 M
        Hqq += 2.0 * sa[:, 6, None] * M.reshape(1, 16)
    blocks[:, YQ, YQ] = Hqq.reshape(n, 4, 4)
    sq = (sa[:, 3:6, None] * q[:, None, :]).reshape(n, 12)
    T = rows_times(sq, Q_T).reshape(n, 4, 3)  # the nu rows' q-r' block
    blocks[:, YQ, YR] = T
    blocks[:, YR, YQ] = T.transpose(0, 2, 1)
    H += blocks
    return H


def directed_maps(B, directions: np.ndarray) -> np.ndarray:
    """M_k (k, 4, 4) with q^T M_k q n2^p = (R(q) a_k).B for directions a_k (k, 3) in the director
    frame (contract section 9): M_k = sum_ji B_j a_ki Q_ji; a = e3 gives the d3 map of eq. (9).
    ``B``: one field (3,), or one per direction (k, 3) (the scenes of a stack)."""
    B = np.asarray(B, float)
    if B.ndim == 2:
        return np.einsum("kj,ki,jiab->kab", B, np.asarray(directions, float), Q)
    return np.einsum("j,ki,jiab->kab", B, np.asarray(directions, float), Q)


def magnet(q: np.ndarray, B, variant: str = kin.NORMALISED, M: np.ndarray | None = None):
    """Gradient and Hessian in q (k, 4) of a unit lumped magnet's potential -d3(q).B, eq. (9):
    -q^T M q n2^p with the chain rule of the module docstring (p = -1 normalised, 0 raw).
    ``M`` (k, 4, 4): per point, a magnet along another direction with its moment folded in
    (:func:`directed_maps`); default the d3 map of B."""
    M = linear_maps(tuple(float(b) for b in B))[3:7, 60:64] if M is None else M
    p = POWERS[variant][6]
    n2 = np.einsum("ka,ka->k", q, q)
    a, a1 = n2**p, p * n2 ** (p - 1.0)
    a2 = p * (p - 1.0) * n2 ** (p - 2.0)
    Mq = np.einsum("kab,kb->ka", np.broadcast_to(M, (q.shape[0], 4, 4)), q)
    F = np.einsum("ka,ka->k", Mq, q)
    gF, gn2 = 2.0 * Mq, 2.0 * q
    g = -(a[:, None] * gF + (a1 * F)[:, None] * gn2)
    cross = gF[:, :, None] * gn2[:, None, :]
    H = -(
        2.0 * a[:, None, None] * M
        + a1[:, None, None] * (cross + cross.transpose(0, 2, 1))
        + (a2 * F)[:, None, None] * (gn2[:, :, None] * gn2[:, None, :])
        + 2.0 * (a1 * F)[:, None, None] * np.eye(4)
    )
    return g, H


def dead_moment(q: np.ndarray, M) -> tuple[np.ndarray, np.ndarray]:
    """Generalised force of a dead moment M on q (4,) and its Jacobian.

    The spatial spin dphi = 2 (q0 dv - dq0 v + v x dv)/|q|^2 gives the virtual work M.dphi = Q.dq
    with Q = L q / |q|^2, L = [[0, -2 M^T], [2 M, 2 [M]x]], so dQ/dq = (L - 2 Q q^T)/|q|^2.
    """
    M = np.asarray(M, float)
    L = np.zeros((4, 4))
    L[0, 1:], L[1:, 0] = -2.0 * M, 2.0 * M
    L[1:, 1:] = 2.0 * np.array([[0.0, -M[2], M[1]], [M[2], 0.0, -M[0]], [-M[1], M[0], 0.0]])
    n2 = float(q @ q)
    Q = L @ q / n2
    return Q, (L - 2.0 * np.outer(Q, q)) / n2


def directed_magnetic(g: np.ndarray, H: np.ndarray | None, z: np.ndarray, lam: float, M: np.ndarray, variant):
    """Add magnetisation off d3 to (g, H) of :func:`derivatives` in place (contract section 9):
    U = -lam (R(q) mu a).B per point, with ``M`` = :func:`directed_maps` (B, mu a) of the points
    (mu a: the moment per length times its direction in the director frame; built once per
    system); the gradient and Hessian are :func:`magnet`'s with that map."""
    q = z.reshape(-1, 14)[:, 3:7]
    gq, Hq = magnet(q, None, variant, M=M)
    g[..., 3:7] += lam * gq.reshape(g.shape[:-1] + (4,))
    if H is not None:
        H[..., 3:7, 3:7] += lam * Hq.reshape(H.shape[:-2] + (4, 4))
