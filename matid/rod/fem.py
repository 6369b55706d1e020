"""1D finite elements for the rod: scikit-fem basis tables, one vectorised assembly.

The total energy is  E(U) = sum_e sum_q dx_eq  w(u_eq, u'_eq)  plus point terms.
With the pointwise gradient g = dw/d(u, u') and Hessian H (from
:mod:`matid.rod.jet`) and the basis tables phi, phi' of scikit-fem,

    R_(i,c) = sum_q dx [g_c phi_i + g_c' phi_i']
    K_(i,c)(j,d) = sum_q dx [phi_i, phi_i'] H_(c,d) [phi_j, phi_j']^T

are a pair of einsums over all elements at once; the sparse pattern is built
once and each assembly is a single ``bincount``. No Python loop over elements.
Unknowns are interleaved per scalar P2 dof: global dof = k * nf + c.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import Basis, ElementLineP1, ElementLineP2, MeshLine

ELEMENTS = {"P2": ElementLineP2, "P1": ElementLineP1}


@dataclass(frozen=True)
class Pattern:
    """CSR pattern of the element matrices restricted to the free dofs."""

    keep: np.ndarray  # mask over the flattened element-matrix entries
    inverse: np.ndarray  # position of each kept entry in the CSR data
    indices: np.ndarray
    indptr: np.ndarray
    n: int

    def matrix(self, values: np.ndarray) -> sp.csr_matrix:
        data = np.bincount(self.inverse, weights=values.ravel()[self.keep], minlength=self.indices.size)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


class Discretisation:
    """Mesh, basis tables and assembly for ``nf`` scalar fields on [0, L]."""

    def __init__(self, vertices: np.ndarray, nf: int, *, element: str = "P2", intorder: int | None = None):
        self.mesh = MeshLine(np.asarray(vertices, dtype=float))
        self.element = element
        elem = ELEMENTS[element]()
        self.basis = Basis(self.mesh, elem, intorder=intorder) if intorder else Basis(self.mesh, elem)
        self.nf = nf
        b = self.basis
        nloc = len(b.basis)
        self.phi = np.array([np.asarray(b.basis[i][0]) for i in range(nloc)])  # (nloc, ne, nq)
        self.dphi = np.array([b.basis[i][0].grad[0] for i in range(nloc)])
        self.dx = b.dx  # (ne, nq)
        self.edofs = b.element_dofs  # (nloc, ne) scalar dofs
        self.nscalar = b.N
        self.s_dof = b.doflocs[0]  # reference arc length of each scalar dof
        self.s_quad = b.mapping.F(b.X)[0]  # (ne, nq)
        self.n = self.nscalar * nf
        self.weighted = np.stack([self.phi, self.dphi]) * self.dx[None, None]  # (2, nloc, ne, nq)
        self.both = np.stack([self.phi, self.dphi])
        gd = (self.edofs.T[:, :, None] * nf + np.arange(nf)[None, None, :]).reshape(self.ne, -1)
        self.gdofs = gd  # (ne, nloc*nf), local order (i, c)
        self.set_free(np.ones(self.n, dtype=bool))

        self._vertices = self.mesh.p[0].copy()

    @property
    def ne(self) -> int:
        return self.mesh.t.shape[1]

    @property
    def vertices(self) -> np.ndarray:
        return self._vertices

    def moved(self, vertices: np.ndarray) -> Discretisation:
        """A copy on moved vertices (same topology), by rescaling the affine 1D basis tables.

        phi is unchanged, phi' and dx scale with each element's length: cheap
        enough to differentiate the residual with respect to vertex positions.
        """
        new = object.__new__(Discretisation)
        new.__dict__.update(self.__dict__)
        vertices = np.asarray(vertices, float)
        ratio = (np.diff(vertices) / np.diff(self._vertices))[:, None]
        new._vertices = vertices
        new.dphi = self.dphi / ratio[None]
        new.dx = self.dx * ratio
        new.s_quad = vertices[:-1, None] + (self.s_quad - self._vertices[:-1, None]) * ratio
        nv = vertices.size
        new.s_dof = (
            np.concatenate([vertices, 0.5 * (vertices[:-1] + vertices[1:])])
            if self.element == "P2"
            else vertices.copy()
        )
        assert new.s_dof.size == self.nscalar and nv == self._vertices.size
        new.weighted = np.stack([new.phi, new.dphi]) * new.dx[None, None]
        new.both = np.stack([new.phi, new.dphi])
        return new

    def vertex_dof(self, index: int) -> int:
        """Scalar dof of mesh vertex ``index`` (P1/P2 vertices come first in scikit-fem)."""
        return int(index)

    def set_free(self, free: np.ndarray) -> None:
        """Build the CSR pattern of the free-free block once."""
        self.free = np.asarray(free, dtype=bool)
        index = np.full(self.n, -1)
        index[self.free] = np.arange(int(self.free.sum()))
        m = self.gdofs.shape[1]
        rows = np.broadcast_to(index[self.gdofs][:, :, None], (self.ne, m, m)).ravel()
        cols = np.broadcast_to(index[self.gdofs][:, None, :], (self.ne, m, m)).ravel()
        keep = (rows >= 0) & (cols >= 0)
        nfree = int(self.free.sum())
        keys = rows[keep] * nfree + cols[keep]
        unique, inverse = np.unique(keys, return_inverse=True)
        indptr = np.searchsorted(unique // nfree, np.arange(nfree + 1)) if nfree else np.zeros(1, int)
        self.pattern = Pattern(keep, inverse, unique % nfree if nfree else unique, indptr, nfree)

    def interpolate(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Field values and s-derivatives at the quadrature points, each (nf, ne, nq)."""
        Ue = U.reshape(self.nscalar, self.nf)[self.edofs]  # (nloc, ne, nf)
        vals = np.einsum("iec,ieq->ceq", Ue, self.phi)
        ders = np.einsum("iec,ieq->ceq", Ue, self.dphi)
        return vals, ders

    def assemble(self, g: np.ndarray, H: np.ndarray | None) -> tuple[np.ndarray, sp.csr_matrix | None]:
        """Residual (all dofs) and tangent (free block) from the pointwise gradient and Hessian.

        g has shape (ne, nq, 2*nf), H (ne, nq, 2*nf, 2*nf): variables ordered
        (u_0..u_{nf-1}, u'_0..u'_{nf-1}).
        """
        nf, ne = self.nf, self.ne
        nq = g.shape[1]
        g4 = g.reshape(ne, nq, 2, nf)
        Re = np.einsum("eqkc,kieq->eic", g4, self.weighted, optimize=True).reshape(ne, -1)
        R = np.bincount(self.gdofs.ravel(), weights=Re.ravel(), minlength=self.n)
        if H is None:
            return R, None
        H6 = H.reshape(ne, nq, 2, nf, 2, nf)
        Ke = np.einsum("eqkcld,kieq,ljeq->eicjd", H6, self.weighted, self.both, optimize=True)
        return R, self.pattern.matrix(Ke)


def graded_vertices(length: float, elements: int, *, breaks: tuple[float, ...] = ()) -> np.ndarray:
    """Uniform vertices on [0, length] with nodes forced at the ``breaks`` (segment ends, magnets)."""
    base = np.linspace(0.0, length, elements + 1)
    points = [b for b in breaks if 0.0 < b < length]
    if not points:
        return base
    # snap the nearest vertex to each break so the element count stays fixed
    snapped = base.copy()
    for b in points:
        snapped[np.argmin(np.abs(snapped - b))] = b
    snapped = np.unique(snapped)
    if snapped.size != base.size or np.any(np.diff(snapped) <= 0):
        snapped = np.unique(np.concatenate([base, points]))
    return snapped
