"""The bordered tangent of the three-point bend: a banded rod block with contact borders."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from matid.rod.fem import Banded


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
        self.rho = max(1.0, float(np.max(np.abs(K.ab[K.u]))))
        aug = Banded(K.ab.copy(), K.u, K.order, K.symmetric)
        aug.position = K.position
        rows, cols, vals = [], [], []
        for row in C[:2]:  # each contact row lives on its own vertex: rho g g^T is in the band
            nz = np.flatnonzero(row)
            rows.append(np.repeat(nz, nz.size)), cols.append(np.tile(nz, nz.size))
            vals.append(self.rho * np.outer(row[nz], row[nz]).ravel())
        aug.add_blocks(np.concatenate(rows), np.concatenate(cols), np.concatenate(vals))
        self.F = aug.factor()
        self.Z = self.F.solve(self.B)
        S = C @ self.Z
        if not np.all(np.isfinite(S)) or abs(np.linalg.det(S)) <= 1e-300:
            raise np.linalg.LinAlgError("singular bordered tangent")
        self.S_inv = np.linalg.inv(S)  # 3 x 3: applied to every right-hand side
        return self

    def solve(self, r: np.ndarray) -> np.ndarray:
        """The solution for a right-hand side r of shape (n + 3,) or (n + 3, m)."""
        n = self.B.shape[0]
        f = r[:n] + self.rho * (self.C[:2].T @ r[n : n + 2])
        y = self.F.solve(f)
        w = self.S_inv @ (self.C @ y - r[n:])
        return np.concatenate([y - self.Z @ w, w])
