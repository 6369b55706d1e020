"""Closed-form gradient and Hessian of the full-model density (normalised quaternions).

Variables per point z = (r, q, r', q') (14). With n2 = |q|^2 every strain is a
polynomial numerator over n2 (:mod:`matid.physics.kinematics`):

    kappa_i = a_i / n2,  a_i = q^T A_i q'          (A_i constant, bilinear)
    nu_i    = b_i / n2,  b_i = sum_j r'_j q^T Q_ji q  (R_ji(q) = q^T Q_ji q, Q constant)
    d3.B    = m / n2,    m = q^T (sum_j B_j Q_j3) q

and for e = F/n2:  grad e = (grad F - e grad n2)/n2,
Hess e = (Hess F - grad e grad n2^T - grad n2 grad e^T - 2 e I_q)/n2.
The density W = 1/2 sum_k C_k (e_k - e_k^ref)^2 - lam mu d3.B - lam f.r then has

    g = sum_k s_k grad e_k (- lam f),   H = sum_k C_k grad e_k grad e_k^T + sum_k s_k Hess e_k

with s_k = dW/de_k. The constants A_i, Q_ji are read off kinematics.directors and
kinematics.curvature_numerator once, so this is the same model as the jets
(compared to them in tests/test_rod_closed_forms.py).
"""

from __future__ import annotations

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
QS, DR, DQ = slice(3, 7), slice(7, 10), slice(10, 14)


def derivatives(vals, ders, lam, props, kappa_ref, mu, B, f, tangent=True, *, stress=None, want_strain=False):
    """(g, H) of the normalised full-model density at every point: shapes P + (14,), P + (14, 14).

    vals, ders: (7,) + P field values and s-derivatives; props: stiffness arrays (P);
    mu: magnetisation per length (P) or None; B, f: 3-vectors; kappa_ref: 3-vector (scaled by lam here).
    ``stress`` (P + (6,)): independent point stresses for the geometric part of the Hessian
    (the mixed tangent, see RodSystem.mixed_update); ``want_strain``: also return
    (C (e - e_ref), C de/dz) for that update.
    """
    q = np.moveaxis(vals[3:], 0, -1)  # P + (4,)
    p = np.moveaxis(ders[3:], 0, -1)
    dr = np.moveaxis(ders[:3], 0, -1)
    P = q.shape[:-1]
    n2 = np.sum(q * q, axis=-1)
    inv = 1.0 / n2
    Rq = np.einsum("...a,jiab,...b->...ji", q, Q, q)  # R(q), P + (3, 3)
    Qq = np.einsum("jiab,...b->...jia", Q, q)  # P + (3, 3, 4)
    nF = 6 + (mu is not None)
    F = np.empty(P + (nF,))
    gF = np.zeros(P + (nF, 14))
    F[..., :3] = np.einsum("...a,iab,...b->...i", q, A, p)
    gF[..., :3, QS] = np.einsum("iab,...b->...ia", A, p)
    gF[..., :3, DQ] = np.einsum("iab,...a->...ib", A, q)
    F[..., 3:6] = np.einsum("...j,...ji->...i", dr, Rq)
    gF[..., 3:6, QS] = 2.0 * np.einsum("...j,...jia->...ia", dr, Qq)
    gF[..., 3:6, DR] = np.swapaxes(Rq, -1, -2)
    if mu is not None:
        M = np.einsum("j,jab->ab", np.asarray(B, float), Q[:, 2])
        F[..., 6] = np.einsum("...a,ab,...b->...", q, M, q)
        gF[..., 6, QS] = 2.0 * np.einsum("ab,...b->...a", M, q)
    e = F * inv[..., None]
    gn2 = np.zeros(P + (14,))
    gn2[..., QS] = 2.0 * q
    ge = (gF - e[..., None] * gn2[..., None, :]) * inv[..., None, None]
    C = np.stack(
        [props["E_b"], props["E_b"], props["E_t"], props["E_s"], props["E_s"], props["E_e"]], axis=-1
    )
    ref = np.zeros(np.shape(kappa_ref)[:-1] + (6,))  # kappa_ref: a 3-vector, or P + (3,) per point
    ref[..., :3], ref[..., 5] = lam * np.asarray(kappa_ref, float), 1.0
    s = np.empty(P + (nF,))
    s[..., :6] = C * (e[..., :6] - ref)
    if mu is not None:
        s[..., 6] = -lam * mu
    G = np.einsum("...k,...ka->...a", s, ge)
    g = G.copy()
    g[..., :3] -= lam * np.asarray(f, float)
    if not tangent:
        return g, None
    strain = (s[..., :6].copy(), C[..., :, None] * ge[..., :6, :]) if want_strain else None
    if stress is not None:
        s[..., :6] = stress
        G = np.einsum("...k,...ka->...a", s, ge)
    H = np.einsum("...k,...ka,...kb->...ab", C, ge[..., :6, :], ge[..., :6, :])
    HS = np.zeros(P + (14, 14))
    HS[..., QS, DQ] = np.einsum("...i,iab->...ab", s[..., :3], A)
    HS[..., DQ, QS] = np.swapaxes(HS[..., QS, DQ], -1, -2)
    HS[..., QS, QS] = 2.0 * np.einsum("...i,...j,jiab->...ab", s[..., 3:6], dr, Q)
    if mu is not None:
        HS[..., QS, QS] += 2.0 * s[..., 6, None, None] * M
    HS[..., QS, DR] = 2.0 * np.einsum("...i,...jia->...aj", s[..., 3:6], Qq)
    HS[..., DR, QS] = np.swapaxes(HS[..., QS, DR], -1, -2)
    outer = G[..., :, None] * gn2[..., None, :]
    HS -= outer + np.swapaxes(outer, -1, -2)
    se = np.sum(s * e, axis=-1)
    idx = np.arange(3, 7)
    HS[..., idx, idx] -= 2.0 * se[..., None]
    H += HS * inv[..., None, None]
    return (g, H, strain) if want_strain else (g, H)


def directed_magnetic(g, H, vals, lam, mu_a, B) -> None:
    """Add the magnetisation off d3 to (g, H) of :func:`derivatives` in place (contract section 9).

    U = -lam sum_i (mu a)_i d_i.B = -lam e, e = F/n2 with F = q^T M q and
    M = sum_i (mu a)_i sum_j B_j Q_ji: grad e = (2 M q - 2 e q)/n2,
    Hess e = (2 M - 2 grad e q^T - 2 q grad e^T - 2 e I)/n2 (q-block of the 14 variables).
    ``mu_a``: P + (3,) moment per length times direction, director frame; H may be None.
    """
    q = np.moveaxis(vals[3:], 0, -1)
    inv = 1.0 / np.sum(q * q, axis=-1)
    M = np.einsum("...i,j,jiab->...ab", mu_a, np.asarray(B, float), Q)
    Mq = np.einsum("...ab,...b->...a", M, q)
    e = np.einsum("...a,...a->...", q, Mq) * inv
    ge = 2.0 * (Mq - e[..., None] * q) * inv[..., None]
    g[..., QS] -= lam * ge
    if H is None:
        return
    outer = ge[..., :, None] * q[..., None, :]
    he = 2 * (M - outer - np.swapaxes(outer, -1, -2) - e[..., None, None] * np.eye(4)) * inv[..., None, None]
    H[..., QS, QS] -= lam * he
