"""Band storage of the rod's free-dof tangent, and its factorisation by LAPACK.

Ordered along s, the dofs of a 1D mesh couple only within an element, so the tangent
K has half-bandwidth u (P2: 3 nf - 1 whatever the mesh size) and lives in LAPACK band
storage ab[u + i - j, j] = K[i, j]. A symmetric positive definite K is factorised by
banded Cholesky (pbtrf), anything else by banded LU (gbtrf): O(n u^2) per Newton step,
and a successful Cholesky is the stability test of the state (every pivot > 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.linalg import lapack


@dataclass(frozen=True)
class BlockPattern:
    """Where dense node-local blocks on global dofs (k, m) land in the free-dof tangent: the
    kept entries (both dofs free) of the (k, m, m) blocks, their free-dof rows and columns (CSR)
    and their positions in the band storage (built once per system)."""

    keep: np.ndarray
    rows: np.ndarray
    cols: np.ndarray
    flat: np.ndarray


class Banded:
    """A free-dof tangent in the band storage of the module docstring; ``order[k]`` is the free
    dof at band position k, ``position`` its inverse."""

    def __init__(self, ab: np.ndarray, u: int, order: np.ndarray, position: np.ndarray, symmetric: bool):
        self.ab, self.u, self.order, self.position, self.symmetric = ab, u, order, position, symmetric

    @property
    def shape(self) -> tuple[int, int]:
        return (self.ab.shape[1], self.ab.shape[1])

    def add_blocks(self, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray) -> None:
        """Add entries given in free-dof numbering (must lie in the band)."""
        pos = self.position[rows]
        col = self.position[cols]
        np.add.at(self.ab, (self.u + pos - col, col), vals)

    def add(self, pattern: BlockPattern, blocks: np.ndarray) -> None:
        """Add dense blocks (k, m, m) laid out by ``pattern`` (no two entries of one pattern share
        a position: node-local blocks on distinct dofs)."""
        flat = self.ab.reshape(-1)  # a view: ab is C-contiguous
        flat[pattern.flat] += blocks.reshape(-1)[pattern.keep]

    def tocsr(self) -> sp.csr_matrix:
        """The matrix in free-dof numbering, in O(n u) (the stability test of dead moments, tests)."""
        n, u = self.shape[0], self.u
        w = min(u, n - 1)  # a mesh of few elements is narrower than the band: no diagonal past n
        offsets = list(range(-w, w + 1))
        diagonals = [self.ab[u + k, max(0, -k) : min(n, n - k)] for k in offsets]
        band = sp.diags(diagonals, [-k for k in offsets], shape=(n, n), format="coo")
        out = sp.csr_matrix((band.data, (self.order[band.row], self.order[band.col])), shape=(n, n))
        out.eliminate_zeros()  # as a dense matrix's: the structure SuperLU orders by
        return out

    def factor(self) -> BandFactor:
        """Cholesky (LAPACK pbtrf) when symmetric and positive definite, else banded LU (gbtrf)."""
        u, n = self.u, self.shape[0]
        if self.symmetric:
            c, info = lapack.dpbtrf(self.ab[u:], lower=1)
            if info == 0:
                return BandFactor(self, c, None, True)
        lu_ab = np.zeros((3 * u + 1, n))
        lu_ab[u:] = self.ab
        lu, piv, info = lapack.dgbtrf(lu_ab, u, u)
        if info != 0:
            raise np.linalg.LinAlgError(f"singular tangent (zero pivot {info})")
        return BandFactor(self, lu, piv, False if self.symmetric else None)


class BandFactor:
    """A factorised :class:`Banded`; ``positive_definite`` is True (Cholesky succeeded), False
    (symmetric, Cholesky failed: not a stable state) or None (unsymmetric: no test)."""

    def __init__(self, matrix: Banded, factor: np.ndarray, piv: np.ndarray | None, positive_definite):
        self.matrix, self.factor_, self.piv, self.positive_definite = matrix, factor, piv, positive_definite

    def solve(self, b: np.ndarray) -> np.ndarray:
        m = self.matrix
        rhs = b[m.order]
        if self.piv is None:
            x, info = lapack.dpbtrs(self.factor_, rhs, lower=1)
        else:
            x, info = lapack.dgbtrs(self.factor_, m.u, m.u, rhs, self.piv)
        out = np.empty_like(x)
        out[m.order] = x
        return out
