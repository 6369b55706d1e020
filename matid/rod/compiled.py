"""The compiled Newton path of a :class:`~matid.rod.models.RodSystem` (:mod:`matid.rod.kernel`).

Which systems it serves: band storage, closed-form derivatives, a symmetric tangent
(planar model, or full model with normalised quaternions and no dead tip moment),
and no lumped magnet in 3D. Everything else, and any Newton solve whose tangent is
stays on the numpy path of :mod:`matid.rod.newton`.
Set ``MATID_JIT=0`` to switch the compiled path off (numba is imported lazily, on
the first solve that uses it).
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import warnings

import numpy as np

from matid.physics import full
from matid.physics import kinematics as kin

_NO_LOAD = np.zeros(0)
_A, _Q = np.ascontiguousarray(full.A, dtype=float), np.ascontiguousarray(full.Q, dtype=float)
ENABLED = os.environ.get("MATID_JIT", "1") != "0" and importlib.util.find_spec("numba") is not None
#: Models of the kernel and its statuses (kernel.py reads them from here).
PLANAR, FULL = 0, 1
CONVERGED, NOT_FINITE_R, NOT_FINITE_DX, DIVERGING, STAGNATION, MAX_ITER, SINGULAR = range(7)


def kernel_cached() -> bool:
    """Whether numba's cache seems to hold the compiled kernel (in-tree ``__pycache__`` or
    ``NUMBA_CACHE_DIR``); False means the first compiled solve compiles it (~20 s, once)."""
    from pathlib import Path

    if os.environ.get("NUMBA_CACHE_DIR"):  # numba then looks there first, and only there
        return any(Path(os.environ["NUMBA_CACHE_DIR"]).rglob("kernel.newton-*.nbi"))
    return any((Path(__file__).resolve().parent / "__pycache__").glob("kernel.newton-*.nbi"))


class KernelFactor:
    """The last tangent's banded factors (Cholesky, or LU when it is not positive definite),
    solving in free-dof numbering as :class:`matid.rod.fem.BandFactor` does."""

    def __init__(self, L: np.ndarray, abd: np.ndarray, ipvt: np.ndarray, cholesky: bool, u: int, order):
        self.L, self.abd, self.ipvt, self.u, self.order = L, abd, ipvt, u, order
        self.positive_definite = cholesky  # False: symmetric but not positive definite

    def _solve(self, rhs: np.ndarray) -> np.ndarray:
        from matid.rod import kernel

        if self.positive_definite:
            return kernel.cholesky_solve(self.L, self.u, rhs)
        return kernel.band_lu_solve(self.abd, self.ipvt, self.u, rhs)

    def solve(self, b: np.ndarray) -> np.ndarray:
        rhs = np.asarray(b, dtype=float)[self.order]
        if rhs.ndim == 1:
            x = self._solve(rhs)
        else:
            x = np.column_stack([self._solve(np.ascontiguousarray(c)) for c in rhs.T])
        out = np.empty_like(x)
        out[self.order] = x
        return out


_AVAILABLE: list = [None]  # None: not tried yet; then True, or False after a warning


def available() -> bool:
    """Whether the kernels import (numba, and a place for its cache). Tried once per process:
    a broken numba, or a read-only installation with no writable cache ("cannot cache function
    ... no locator available"), gives one RuntimeWarning and the numpy path (same answers)."""
    if _AVAILABLE[0] is None:
        try:
            for name in ("matid.rod.kernel", "matid.rod.bend_kernel"):
                importlib.import_module(name)
            _AVAILABLE[0] = True
        except (ImportError, RuntimeError, OSError) as exc:
            _AVAILABLE[0] = False
            warnings.warn(
                f"matid: the compiled rod kernel is unavailable ({type(exc).__name__}: {exc}); solving on "
                "the numpy path (same answers, slower). NUMBA_CACHE_DIR=<a writable folder> gives numba "
                "a cache; MATID_JIT=0 silences this",
                RuntimeWarning,
                stacklevel=2,
            )
    return _AVAILABLE[0]


def supported(system) -> bool:
    """Whether the kernel computes exactly what ``system.evaluate`` does, and imports."""
    return serves(system) and available()


def serves(system) -> bool:
    """Whether the kernel computes exactly what ``system.evaluate`` does (numba not imported)."""
    if not (ENABLED and system.banded and system.analytic):
        return False
    if system.model == "planar":
        return True
    return (
        system.model == "full"
        and system.variant == kin.NORMALISED
        and not system.magnet_nodes
        and not any(system.rod.tip_moment)  # a dead moment in 3D: unsymmetric tangent
    )


def _mesh_arrays(disc) -> dict:
    """Tables of a discretisation for the kernel, cached on it (keyed to its free set and tables)."""
    cached = disc.__dict__.get("_kernel_mesh")
    if cached is not None and cached[0] is disc.free and cached[1] is disc.dphi:
        return cached[2]
    ne, nq = disc.dx.shape
    nloc = disc.phi.shape[0]
    T = np.ascontiguousarray(disc._point_table().reshape(ne, nq, 2, nloc))
    free_dofs = np.flatnonzero(disc.free)
    order = free_dofs[disc.band_order]  # band position -> global dof
    bpos = np.full(disc.n, -1, dtype=np.int64)
    bpos[order] = np.arange(order.size)
    arrays = {
        "T": T,
        "dx": np.ascontiguousarray(disc.dx, dtype=float),
        "gdofs": np.ascontiguousarray(disc.gdofs, dtype=np.int64),
        "bpos": bpos,
        "order": order.astype(np.int64),
        "free_dofs": free_dofs.astype(np.int64),
        "u": int(disc.band_u),
    }
    disc._kernel_mesh = (disc.free, disc.dphi, arrays)
    return arrays


def _load_arrays(system) -> dict:
    """Stiffnesses, field and loads of a system for the kernel, cached per mesh, rod and properties."""
    cache = system.disc.__dict__.setdefault("_kernel_loads", {})
    cached = cache.get(system.rod)
    if cached is not None and cached[0] is system.props:
        return cached[1]
    disc, rod, p = system.disc, system.rod, system.props
    nf = disc.nf
    props = np.ascontiguousarray(np.stack([p["E_b"], p["E_t"], p["E_s"], p["E_e"]]), dtype=float)
    mu = system.mu if "magnetic" in system.terms else np.zeros_like(system.mu)
    point = np.zeros(disc.n)
    tip = system.tip * nf
    B = np.asarray(rod.B, dtype=float)
    if system.model == "planar":
        point[tip : tip + 3] = (rod.tip_force[0], rod.tip_force[2], rod.tip_moment[1])
        magnets = np.array([[node, m] for node, m in system.magnet_nodes], dtype=float).reshape(-1, 2)
    else:
        point[tip : tip + 3] = rod.tip_force
        magnets = np.zeros((0, 2))
    arrays = {
        "props": props,
        "mu": np.ascontiguousarray(mu, dtype=float),
        "B": B,
        "f": np.asarray(rod.f, dtype=float),
        "kref": np.asarray(rod.kappa_ref, dtype=float),
        "M": np.einsum("j,jab->ab", B, full.Q[:, 2]),
        "point": point,
        "magnets": magnets,
    }
    if len(cache) > 32:
        cache.clear()
    cache[system.rod] = (system.props, arrays)
    return arrays


def _arguments(system) -> tuple:
    """The kernel's mesh and load arguments of a system, in order (built once per system)."""
    cached = system.__dict__.get("_kernel_args")
    if cached is not None and cached[0] is system.disc and cached[1] is system.props:
        return cached[2]
    mesh, loads = _mesh_arrays(system.disc), _load_arrays(system)
    args = (
        PLANAR if system.model == "planar" else FULL,
        *(mesh[k] for k in ("T", "dx", "gdofs", "bpos", "order", "u")),
        *(loads[k] for k in ("props", "mu", "B", "f", "kref")),
        _A,
        _Q,
        *(loads[k] for k in ("M", "point", "magnets")),
        float(system.c_u),
    )
    system._kernel_args = (system.disc, system.props, args)
    return args


def newton(system, x0: np.ndarray, lam: float, *, xtol, max_iter, max_step, floor, mixed_above, load=None):
    """(status, x, iterations, last correction, first correction, factor, LINPACK info) of the
    compiled Newton (``max_iter`` = 0 with ``load``: only dR/dlam at x0 into ``load``, band order)."""
    from matid.rod import kernel

    args = _arguments(system)
    disc = system.disc
    start = system.stress_start if max_iter else None
    stress = np.zeros(disc.dx.shape + (2 if args[0] == PLANAR else 6,)) if start is None else start.copy()
    su_all = np.zeros_like(stress)
    if max_iter:
        system.point_stress = su_all
    x, status, its, size, first, L, abd, ipvt, info = kernel.newton(
        np.ascontiguousarray(x0, dtype=float),
        system._reference(),
        _mesh_arrays(disc)["free_dofs"],
        float(lam),
        *args,
        float(xtol),
        float(floor),
        int(max_iter),
        float(max_step),
        bool(system.mixed),
        float(mixed_above),
        stress,
        start is not None,
        su_all,
        _NO_LOAD if load is None else load,
    )
    factor = KernelFactor(L, abd, ipvt, info == -1, args[6], disc.band_order)
    return status, x, its, size, first, factor, info


def _assemble(system, X: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """(residual, lower band of the consistent tangent) in band order, as the kernel assembles them."""
    from matid.rod import kernel

    args = _arguments(system)
    n, u = args[5].size, args[6]
    ns, nv = (2 if args[0] == PLANAR else 6), 2 * system.disc.nf
    shape = system.disc.dx.shape
    R, S = np.empty(n), np.empty((n, u + 1))
    model, T, dx, gdofs, bpos, _, _, *rest = args
    kernel._assemble(
        system.expand(X), float(lam), model, T, dx, gdofs, bpos, u, *rest,
        np.zeros(shape + (ns,)), False, np.zeros(shape + (ns,)), np.zeros(shape + (ns, nv)), R, S,
        kernel.scratch(system.disc.nf, T.shape[3]), True,
    )  # fmt: skip
    return R, S


def load_derivative(system, X: np.ndarray) -> np.ndarray:
    """dR/dlam = R(X, 1) - R(X, 0) on the free dofs (free-dof numbering), by the compiled Newton's
    evaluation (one call, no iteration)."""
    load = np.empty(X.size)
    options = {"xtol": 0.0, "max_iter": 0, "max_step": 1.0, "floor": 0.0, "mixed_above": 0.0}
    newton(system, X, 1.0, load=load, **options)
    out = np.empty(X.size)
    out[system.disc.band_order] = load
    return out


def evaluate(system, X: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
    """Residual and dense tangent on the free dofs (free-dof numbering) as the kernel assembles them,
    with the consistent tangent: the tests compare them with ``system.evaluate`` and the jets."""
    R, S = _assemble(system, X, lam)
    n, u = S.shape[0], S.shape[1] - 1
    K = np.zeros((n, n))
    for t in range(u + 1):  # S[i, t] = K[i, i - u + t]
        i = np.arange(max(0, u - t), n)
        K[i, i - u + t] = K[i - u + t, i] = S[i, t]
    order = system.disc.band_order
    R_free, K_free = np.empty(n), np.empty((n, n))
    R_free[order] = R
    K_free[np.ix_(order, order)] = K
    return R_free, K_free
