"""The tangents of N P2 cantilevers on one mesh, factorised together (physics.md section 10).

Ordered along s, a P2 tangent couples b x b node blocks (b fields: planar x, z, theta; full model
r, q: b = 7) only within an element, and
a mid-node only with its own element's two vertices. So the mid-nodes are condensed element by
element (all elements of all scenes at once), which leaves a block-tridiagonal chain of the free
vertices; the chain is factorised by cyclic reduction (every other vertex eliminated at once:
log2(ne) levels instead of ne sequential steps). Blocks are held as (b, b, N, ...) arrays, so a
product or an inverse of all the blocks of a level is a few numpy calls on contiguous arrays; the
3 x 3 inverses are closed-form (cofactors), since np.linalg.inv costs ~0.4 us per 3 x 3 matrix
(measured: 43 us for 100, 820 us for 1600; the cofactors 13 us and 65 us); larger blocks go to
np.linalg.inv (LAPACK, pivoted within the block), one call per level.

The tangents are symmetric (every stacked term's is), so only the blocks on and above the
diagonal are formed. Block Gaussian elimination without pivoting across blocks: a symmetric
tangent is positive definite iff every pivot block (the b x b blocks inverted on the way) is,
which Sylvester's criterion reads from the cofactors (:attr:`Chain.definite`, the stability test
of :mod:`matid.rod.batch`); for larger blocks from the pivot blocks' eigenvalues, only for the scenes
asked (:meth:`Chain.positive_definite`: a converged Newton solve asks once).
"""

from __future__ import annotations

import numpy as np

_NEXT, _AFTER = np.array([1, 2, 0]), np.array([2, 0, 1])
_A11, _A22 = np.ix_(_NEXT, _NEXT), np.ix_(_AFTER, _AFTER)
_A12, _A21 = np.ix_(_NEXT, _AFTER), np.ix_(_AFTER, _NEXT)


def mm(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Block products A B of (b, b, ...) stacks."""
    return np.einsum("ij...,jk...->ik...", A, B)


def mv(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Block-vector products A x of a (b, b, ...) and a (b, ...) stack."""
    return np.einsum("ij...,j...->i...", A, x)


def inverse3(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(inverses, positive definite) of the 3 x 3 blocks A (3, 3, ...): the adjugate
    adj_ij = A_(j+1)(i+1) A_(j+2)(i+2) - A_(j+1)(i+2) A_(j+2)(i+1) (indices mod 3, read from the
    transposed view) over det; a singular block gives inf or NaN (call under np.errstate).
    Definite: the leading minors A_00, adj_22, det all > 0."""
    At = A.swapaxes(0, 1)
    adj = At[_A11] * At[_A22] - At[_A21] * At[_A12]
    det = np.einsum("i...,i...->...", A[0], adj[:, 0])
    return adj / det, (A[0, 0] > 0) & (adj[2, 2] > 0) & (det > 0)


def inverse(A: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """(inverses, positive definite or None) of the b x b blocks A (b, b, ...): :func:`inverse3`
    for b = 3, else np.linalg.inv (definiteness then from :func:`blocks_definite`); a singular block's
    inverse is NaN."""
    if A.shape[0] == 3:
        return inverse3(A)
    M = A.transpose(*range(2, A.ndim), 0, 1)  # (..., b, b) (np.moveaxis: 40 us of axis checks)
    try:
        inv = np.linalg.inv(M)
    except np.linalg.LinAlgError:  # some block exactly singular: NaN there, the rest inverted
        flat, inv = M.reshape(-1, *M.shape[-2:]), np.full(M.shape, np.nan)
        out = inv.reshape(flat.shape)
        for k in range(flat.shape[0]):
            try:
                out[k] = np.linalg.inv(flat[k])
            except np.linalg.LinAlgError:
                continue
    return inv.transpose(A.ndim - 2, A.ndim - 1, *range(A.ndim - 2)), None


def blocks_definite(A: np.ndarray) -> np.ndarray:
    """Per scene (last axis): every symmetric b x b block of A (b, b, ..., N) positive definite
    (its eigenvalues; a non-finite block is not)."""
    M = A.transpose(*range(2, A.ndim), 0, 1)
    finite = np.isfinite(M).all((-2, -1))
    lowest = np.linalg.eigvalsh(np.where(finite[..., None, None], M, 0.0))[..., 0]
    ok = finite & (lowest > 0)
    return ok.reshape(-1, ok.shape[-1]).all(0)


class ChainLayout:
    """Where a mesh's nodes sit in the chain (built once per mesh): each element's local nodes
    (left vertex, right vertex, mid-node) and the scalar dofs of the vertices and mid-nodes."""

    def __init__(self, disc):
        if disc.element != "P2":
            raise ValueError(f"the stacked factorisation needs P2 elements, not {disc.element}")
        s = disc.s_dof[disc.edofs]  # (3, ne)
        order = np.argsort(s, axis=0, kind="stable")
        left, mid, right = (int(i) for i in order[:, 0])
        if not (order == np.array([[left], [mid], [right]])).all():
            raise ValueError("the elements' local node order differs between elements")
        #: the local nodes (left, right, mid): the order of the element blocks of Chain
        self.local = np.array([left, right, mid])
        self.vertices = np.append(disc.edofs[left], disc.edofs[right, -1])  # scalar dofs, along s
        self.mids = disc.edofs[mid]
        self.ne, self.nscalar = disc.ne, disc.nscalar
        self.m = 1 << max(self.ne - 1, 0).bit_length()  # the chain padded to a power of two


class Chain:
    """The factorised tangents of N clamped chains.

    ``K`` (3, 3, b, b, ne, N): the element matrices as node blocks [k, l, i, j] (k, l local nodes
    in the layout's (left, right, mid) order, i, j fields); ``vertex_diagonal`` (b, ne + 1, N) or
    ``vertex_blocks`` (b, b, ne + 1, N) or None: additions to the vertices' diagonal or blocks
    (lumped terms). Vertex 0 is clamped. Every block array is (b, b, position along the chain, scene).
    """

    def __init__(self, K: np.ndarray, layout: ChainLayout, vertex_diagonal=None, vertex_blocks=None):
        with np.errstate(divide="ignore", invalid="ignore"):  # a singular pivot: its scene's NaN
            self._factor(K, layout, vertex_diagonal, vertex_blocks)

    def _factor(self, K, layout, vertex_diagonal, vertex_blocks) -> None:
        self.layout = lay = layout
        ne, N, m, b = lay.ne, K.shape[5], lay.m, K.shape[2]
        self.N, self.b = N, b
        self.Gm, definite = inverse(K[2, 2])
        pivots = [K[2, 2]] if definite is None else None  # the pivot blocks, for blocks_definite()
        self.Kl, self.Kr = K[0, 2].copy(), K[1, 2].copy()  # K itself may be a work array
        # x_m = Gm r_m - Pl x_l - Pr x_r (K symmetric: K_ml = K_lm^T)
        self.Pl, self.Pr = mm(self.Gm, self.Kl.swapaxes(0, 1)), mm(self.Gm, self.Kr.swapaxes(0, 1))
        D = np.zeros((b, b, m, N))
        D[np.arange(b), np.arange(b), ne:] = 1.0  # padding: decoupled identities
        D[:, :, :ne] = K[1, 1] - mm(self.Kr, self.Pr)
        D[:, :, : ne - 1] += K[0, 0, :, :, 1:] - mm(self.Kl[:, :, 1:], self.Pl[:, :, 1:])
        if vertex_diagonal is not None:
            for f in range(b):
                D[f, f, :ne] += vertex_diagonal[f, 1:]
        if vertex_blocks is not None:
            D[:, :, :ne] += vertex_blocks[:, :, 1:]
        U = np.zeros((b, b, m - 1, N))  # vertex j -> j + 1 (chain numbering: vertex j + 1 of the mesh)
        U[:, :, : ne - 1] = K[0, 1, :, :, 1:] - mm(self.Kl[:, :, 1:], self.Pr[:, :, 1:])
        definite = None if definite is None else definite.all(0)
        self.levels = []
        while m > 1:  # eliminate the odd vertices j: they couple to j - 1 and j + 1 only
            if pivots is not None:
                pivots.append(D[:, :, 1::2])
            G, ok = inverse(D[:, :, 1::2])
            Ue, Lodd = U[:, :, 0::2], U[:, :, 1::2].swapaxes(0, 1)  # j - 1 -> j; j + 1 -> j: U^T
            GL, GU = mm(G, Ue.swapaxes(0, 1)), mm(G[:, :, :-1], U[:, :, 1::2])
            Dk = D[:, :, 0::2] - mm(Ue, GL)
            Dk[:, :, 1:] -= mm(Lodd, GU)
            U, D = -mm(Ue[:, :, :-1], GU), Dk
            self.levels.append((G, GL, GU, Ue, Lodd))
            if definite is not None:
                definite &= ok.all(0)
            m //= 2
        self.G, ok = inverse(D)
        #: per scene: every pivot positive definite (a symmetric tangent: positive definite); for
        #: blocks larger than 3 x 3 found on demand from the pivot blocks kept here
        self.definite = None if definite is None else definite & ok.all(0)
        self.pivots = None if pivots is None else pivots + [D]

    def positive_definite(self, rows: np.ndarray) -> np.ndarray:
        if self.definite is not None:
            return self.definite[rows]
        rows = np.asarray(rows, int)
        out = np.ones(rows.size, bool)
        for P in self.pivots:
            out &= blocks_definite(P[..., rows])
        return out

    def solve(self, r: np.ndarray) -> np.ndarray:
        """x with K x = r on all dofs (N, nscalar b), the clamp's entries zero."""
        lay, b = self.layout, self.b
        N, ne = r.shape[0], lay.ne
        r = r.reshape(N, lay.nscalar, b).T  # (b, nscalar, N)
        rv = r[:, lay.vertices]  # (b, ne + 1, N)
        ym = mv(self.Gm, r[:, lay.mids])
        rv[:, :-1] -= mv(self.Kl, ym)
        rv[:, 1:] -= mv(self.Kr, ym)
        c = np.zeros((b, lay.m, N))
        c[:, :ne] = rv[:, 1:]
        ys = []
        for G, _, _, Ue, Lodd in self.levels:
            y = mv(G, c[:, 1::2])
            ck = c[:, 0::2] - mv(Ue, y)
            ck[:, 1:] -= mv(Lodd, y[:, :-1])
            ys.append(y)
            c = ck
        x = mv(self.G, c)
        for (_, GL, GU, _, _), y in zip(self.levels[::-1], ys[::-1], strict=True):
            odd = y - mv(GL, x)
            odd[:, :-1] -= mv(GU, x[:, 1:])
            both = np.empty((b, 2 * x.shape[1], N))
            both[:, 0::2], both[:, 1::2] = x, odd
            x = both
        xv = np.zeros((b, ne + 1, N))
        xv[:, 1:] = x[:, :ne]
        out = np.zeros((b, lay.nscalar, N))
        out[:, lay.vertices] = xv
        out[:, lay.mids] = ym - mv(self.Pl, xv[:, :-1]) - mv(self.Pr, xv[:, 1:])
        return out.T.reshape(N, -1)
