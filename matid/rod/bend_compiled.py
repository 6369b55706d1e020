"""The compiled rod part of :class:`matid.rod.bend_system.BendSystem` (:mod:`matid.rod.bend_kernel`).

Serves the bend's planar rod where :func:`matid.rod.compiled.supported` serves it
(``MATID_JIT=0`` switches it off) and once it pays in this process (:data:`WARMUP`).
The arguments are built once per bend system, on its base mesh; each evaluation moves
the mesh to sigma inside the kernel, so no moved :class:`~matid.rod.fem.Discretisation`
is built per Newton iteration.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from matid.rod import compiled
from matid.rod.bordered import Bordered
from matid.rod.fem import Banded


class CompiledBend:
    """Residual, banded tangent and dR/dsigma of a bend's rod, and its dR/dE_s, dR/dE_e."""

    def __init__(self, rod, model, unit: dict):
        disc = rod.disc
        mesh, loads = compiled._mesh_arrays(disc), compiled._load_arrays(rod)
        T, dx, gdofs, bpos, u = (mesh[k] for k in ("T", "dx", "gdofs", "bpos", "u"))
        props, mu, B, f, kref = (loads[k] for k in ("props", "mu", "B", "f", "kref"))
        model.vertices(0.5)  # the fractions of uniform elements on each side of the support
        inner, outer = model._fractions
        self.order, self.position, self.u = disc.band_order, disc.band_position, u
        self.mesh = (
            float(model.half),
            int(model.support_vertex),
            np.ascontiguousarray(inner, dtype=float),
            np.ascontiguousarray(outer, dtype=float),
            np.ascontiguousarray(disc.vertices, dtype=float),
            T,
            dx,
            gdofs,
            bpos,
            np.ascontiguousarray(disc.band_order, dtype=np.int64),
            int(u),
        )
        self.props, self.loads = props, (mu, B, f, kref)
        stack = [np.stack([unit[name][p] for p in ("E_b", "E_t", "E_s", "E_e")]) for name in ("E_s", "E_e")]
        self.unit = np.ascontiguousarray(np.stack(stack), dtype=float)
        self.reference, self.free = rod._reference().copy(), np.flatnonzero(disc.free)
        self.shape = (dx.shape[0], dx.shape[1], T.shape[3], disc.nf, disc.band_order.size)
        self._work = None

    def expand(self, x: np.ndarray) -> np.ndarray:
        """All dofs from the free ones (the fixed ones do not move with the mesh)."""
        U = self.reference.copy()
        U[self.free] = x
        return U

    def _kernel(self):
        from matid.rod import bend_kernel

        if self._work is None:
            self._work = bend_kernel.work_arrays(*self.shape)
        return bend_kernel

    def _call(self, U, sigma, props, tangent: bool, ab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        kernel = self._kernel()
        n = self.order.size
        R, dR = np.empty(n), np.empty(n)
        kernel.evaluate(U, 0.0, float(sigma), *self.mesh, props, *self.loads, tangent, self._work, R, ab, dR)
        return R, dR

    def evaluate(self, U: np.ndarray, sigma: float) -> tuple[np.ndarray, Banded, np.ndarray]:
        """(residual, banded tangent, dR/dsigma) of the rod at U on the mesh at sigma (free dofs)."""
        ab = np.empty((2 * self.u + 1, self.order.size))
        R, dR = self._call(U, sigma, self.props, True, ab)
        K = Banded(ab, self.u, self.order, True)
        K.position = self.position
        return R, K, dR

    def bordered(self, K: Banded, B: np.ndarray, C: np.ndarray) -> CompiledBordered:
        """The bend's bordered tangent with compiled factorisation and solves."""
        return CompiledBordered(K, B, C, self._kernel())

    def stiffness_residuals(self, U: np.ndarray, sigma: float) -> np.ndarray:
        """(n, 2): dR/dE_s and dR/dE_e (scaled) at U on the mesh at sigma (free dofs): the residual of
        that one energy term (the energy is linear in each stiffness)."""
        ab = np.empty((1, 1))  # not written without the tangent
        return np.column_stack([self._call(U, sigma, unit, False, ab)[0] for unit in self.unit])


class CompiledBordered(Bordered):
    """:class:`~matid.rod.bordered.Bordered` with its factorisation and solves compiled
    (:func:`matid.rod.bend_kernel.bordered_factor`): the same elimination, one call each."""

    def __init__(self, K: Banded, B: np.ndarray, C: np.ndarray, kernel):
        super().__init__(K, B, C)
        self._kernel = kernel

    def factor(self) -> CompiledBordered:
        K, n = self.K, self.B.shape[0]
        self.L, self.S_inv = np.empty((n, K.u + 1)), np.empty((3, 3))
        self.rho, ok, self.abd, self.ipvt, info, self.Z, det = self._kernel.bordered_factor(
            K.ab, K.u, K.order, K.position, self.B, self.C, self.L, self.S_inv
        )
        if info > 0:
            raise np.linalg.LinAlgError(f"singular tangent (zero pivot {info})")
        if not (np.isfinite(det) and abs(det) > 1e-300):
            raise np.linalg.LinAlgError("singular bordered tangent")
        #: as fem.BandFactor: whether the banded Cholesky of K_rho succeeded
        self.positive_definite = bool(ok)
        return self

    def solve(self, r: np.ndarray) -> np.ndarray:
        rhs = np.asarray(r, dtype=float)
        rhs2 = np.ascontiguousarray(rhs.reshape(rhs.shape[0], -1))
        out = np.empty_like(rhs2)
        self._kernel.bordered_solve(
            rhs2, self.rho, self.positive_definite, self.L, self.abd, self.ipvt, self.K.u, self.K.order,
            self.C, self.Z, self.S_inv, out,
        )  # fmt: skip
        return out.reshape(rhs.shape)


#: Bend evaluations on the numpy path after which new bend systems of this process use the kernel.
#: Loading numba and the kernel from its cache costs a process about 0.4 s, what about 2000
#: numpy evaluations cost more (measured: 0.35 against 0.13 ms per Newton iteration of the
#: demo bend; ``matid demo``'s E_s fits, ~540 iterations, took 0.2-0.3 s numpy and 0.7 s with
#: the kernel). Where numba is loaded already, or with ``MATID_JIT=1``, the kernel serves from
#: the first system. The answers are the same either way (tests/test_bend_kernel.py).
WARMUP = 2000
_numpy_evaluations = 0


def count_numpy_evaluation() -> None:
    """One more bend evaluation on the numpy path (:data:`WARMUP`)."""
    global _numpy_evaluations
    _numpy_evaluations += 1


def _numba_loaded() -> bool:
    return "numba" in sys.modules


def for_bend(rod, model, unit: dict) -> CompiledBend | None:
    """The compiled rod of a bend system, or None: the kernel does not serve its rod, or does not
    pay yet in this process (:data:`WARMUP`)."""
    loads = (rod.rod.tip_force, rod.rod.tip_moment)
    if rod.model != "planar" or not compiled.serves(rod) or rod.magnet_nodes or any(map(any, loads)):
        return None  # the kernel assembles the planar rod without point loads
    eager = os.environ.get("MATID_JIT") == "1" or _numba_loaded()
    if not eager and _numpy_evaluations < WARMUP:
        return None
    return CompiledBend(rod, model, unit) if compiled.available() else None
