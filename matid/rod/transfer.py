"""Fields carried from one mesh of the rod to another (the meshes of an error estimate, a warm start).

P2 nodal values are interpolated by the P2 shape functions of the element holding each point;
point stresses (two Gauss points per element) are recovered linearly through the two points of the
coarse element holding each point. Both are matrices cached per pair of meshes.
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp


def interpolate_p2(vertices: np.ndarray, values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The P2 field with nodal ``values`` (vertex, mid-point, vertex, ... sorted by s) at points s."""
    return _p2_operator(np.asarray(vertices, float).tobytes(), np.asarray(s, float).tobytes()) @ values


#: Interpolation operators up to this many entries are dense (one small matmul), larger ones sparse.
DENSE_ENTRIES = 1 << 16


def _operator(cols: np.ndarray, weights: np.ndarray, ncols: int):
    """The matrix with row k holding ``weights[k]`` in columns ``cols[k]``: dense when small (the
    error estimate's meshes), else CSR."""
    n, k = cols.shape
    matrix = sp.csr_matrix((weights.ravel(), (np.repeat(np.arange(n), k), cols.ravel())), shape=(n, ncols))
    return matrix if n * ncols > DENSE_ENTRIES else matrix.toarray()


@functools.lru_cache(maxsize=64)
def _p2_operator(vertices: bytes, points: bytes):
    """The matrix of :func:`interpolate_p2` from one mesh to the points (cached: the meshes of a
    solve repeat)."""
    v, s = np.frombuffer(vertices), np.frombuffer(points)
    e = np.clip(np.searchsorted(v, s, side="right") - 1, 0, v.size - 2)
    t = (s - v[e]) / (v[e + 1] - v[e])
    weights = np.stack([2 * (t - 0.5) * (t - 1), 4 * t * (1 - t), 2 * t * (t - 0.5)], axis=1)
    return _operator(np.stack([2 * e, 2 * e + 1, 2 * e + 2], axis=1), weights, 2 * v.size - 1)


@functools.lru_cache(maxsize=64)
def stress_recovery(vertices: bytes, coarse: bytes, points: bytes):
    """The matrix of :meth:`matid.rod.cantilever.Equilibrium.stress_at`: linear through the two
    Gauss points of the coarse element holding each point (cached per mesh pair)."""
    v, s = np.frombuffer(vertices), np.frombuffer(points)
    q = np.frombuffer(coarse).reshape(v.size - 1, 2)
    e = np.clip(np.searchsorted(v, s, side="right") - 1, 0, v.size - 2)
    t = (s - q[e, 0]) / (q[e, 1] - q[e, 0])
    return _operator(np.stack([2 * e, 2 * e + 1], axis=1), np.stack([1.0 - t, t], axis=1), q.size)
