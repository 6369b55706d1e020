"""The bordered tangent of the three-point bend: a banded rod block with contact borders."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from matid.rod.band import Banded


class Bordered:
    """The bend tangent [[K, B], [C, 0]]: the banded rod block K bordered by three columns
    (contact normals -G^T, dR/dsigma) and three rows (-G, dh/du).

    K alone is singular (nothing but the contacts holds the tube's vertical
    translation), so the first two rows are added to the rod block with weight rho,
    K_rho = K + rho G^T G, an equivalent system whose G^T G is node-local (in the
    band). Then x = y - Z w with K_rho y = f, K_rho Z = B and the 3x3 Schur
    complement (C Z) w = C y - g: one banded factorisation and four back-solves.
    """

    def __init__(self, K, B: np.ndarray, C: np.ndarray):
        self.K, self.B, self.C = K, B, C

    @property
    def shape(self) -> tuple[int, int]:
        n = self.B.shape[0] + 3
        return (n, n)

    def tocsr(self) -> sp.csr_matrix:
        n = self.B.shape[0]
        A = np.zeros(self.shape)
        A[:n, :n] = self.K.tocsr().toarray()
        A[:n, n:], A[n:, :n] = self.B, self.C
        return sp.csr_matrix(A)

    def tocsc(self) -> sp.csc_matrix:
        return self.tocsr().tocsc()

    def factor(self) -> Bordered:
        K, C = self.K, self.C
        u = K.u
        self.rho = max(1.0, float(np.max(np.abs(K.ab[u]))))
        aug = Banded(K.ab.copy(), u, K.order, K.symmetric)
        aug.position = K.position
        for row in C[:2]:  # each contact row lives on its own vertex: rho g g^T is in the band
            nz = np.flatnonzero(row)
            pos = K.position[nz]
            aug.ab[u + pos[:, None] - pos[None, :], pos[None, :]] += self.rho * np.outer(row[nz], row[nz])
        self.F = aug.factor()
        self.Z = self.F.solve(self.B)
        self.S_inv = _inverse3(C @ self.Z)  # 3 x 3: applied to every right-hand side
        return self

    def solve(self, r: np.ndarray) -> np.ndarray:
        """The solution for a right-hand side r of shape (n + 3,) or (n + 3, m)."""
        n = self.B.shape[0]
        f = r[:n] + self.rho * (self.C[:2].T @ r[n : n + 2])
        y = self.F.solve(f)
        w = self.S_inv @ (self.C @ y - r[n:])
        return np.concatenate([y - self.Z @ w, w])


def _inverse3(S: np.ndarray) -> np.ndarray:
    """Inverse of a 3 x 3 matrix by its adjugate; LinAlgError when singular or not finite."""
    (a, b, c), (d, e, f), (g, h, i) = S.tolist()
    cof = [e * i - f * h, f * g - d * i, d * h - e * g]
    det = a * cof[0] + b * cof[1] + c * cof[2]
    if not (np.isfinite(det) and abs(det) > 1e-300):
        raise np.linalg.LinAlgError("singular bordered tangent")
    adj = [
        [cof[0], c * h - b * i, b * f - c * e],
        [cof[1], a * i - c * g, c * d - a * f],
        [cof[2], b * g - a * h, a * e - b * d],
    ]
    return np.array(adj) / det
