"""Fields carried from one mesh of the rod to another (the meshes of an error estimate, a warm start).

P2 nodal values are interpolated by the P2 shape functions of the element holding each point
(given the breaks where they may kink, a warm start's by the quartic through that element's nodes
and its nearer neighbour's in the same piece);
point stresses (two Gauss points per element) are recovered through the two points of the coarse
element holding each point (linear) and, given the breaks where they may jump, the nearest point of
each neighbour in the same piece. Both are matrices cached per pair of meshes.
"""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp


def interpolate_p2(vertices: np.ndarray, values: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The P2 field with nodal ``values`` (vertex, mid-point, vertex, ... sorted by s) at points s."""
    return _p2_operator(np.asarray(vertices, float).tobytes(), np.asarray(s, float).tobytes()) @ values


def interpolate_warm(
    vertices: np.ndarray, values: np.ndarray, s: np.ndarray, breaks: bytes | None
) -> np.ndarray:
    """:func:`interpolate_p2`, or with ``breaks`` (the vertices where the field may kink, as bytes)
    the Lagrange quartic through the 3 nodes of the element holding each point and the 2 of its
    nearer neighbour not across a break (P2 where neither neighbour is in the piece).

    A warm start's interpolation error at the new mid-points is the start's largest: measured on the
    16-element mesh of P1 (matid/bench/peers.py) from the 8-element state, 2.2e-4 with P2 against
    1.5e-5 at the old vertices; 6.7e-5 with the quartic, where the old mid-points' own error (6.9e-5
    in theta) then dominates. Newton's first correction then stays below MIXED_ABOVE, so its last
    factor is a consistent tangent (:meth:`matid.rod.cantilever.Equilibrium.confirmed`)."""
    if breaks is None:
        return interpolate_p2(vertices, values, s)
    meshes = (np.asarray(vertices, float).tobytes(), np.asarray(s, float).tobytes())
    return _p4_operator(*meshes, breaks) @ values


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
def _p4_operator(vertices: bytes, points: bytes, breaks: bytes):
    """The matrix of :func:`interpolate_warm` with breaks (cached per mesh pair and breaks)."""
    v, s = np.frombuffer(vertices), np.frombuffer(points)
    nodes = np.empty(2 * v.size - 1)
    nodes[::2], nodes[1::2] = v, 0.5 * (v[1:] + v[:-1])
    e = np.clip(np.searchsorted(v, s, side="right") - 1, 0, v.size - 2)
    left, right = _neighbours(v, e, breaks)
    near_left = s - v[e] < v[e + 1] - s
    left, right = left & (near_left | ~right), right & ~(left & near_left)
    first = np.where(left, 2 * e - 2, 2 * e)  # the stencil: 5 nodes from here, or the element's 3
    cols = np.minimum(first[:, None] + np.arange(5), nodes.size - 1)
    use = np.ones(cols.shape, bool)
    use[:, 3:] = (left | right)[:, None]
    return _operator(cols, _lagrange(nodes[cols], use, s), nodes.size)


@functools.lru_cache(maxsize=64)
def stress_recovery(vertices: bytes, coarse: bytes, points: bytes, breaks: bytes | None = None):
    """The matrix of :meth:`matid.rod.cantilever.Equilibrium.stress_at`: linear through the two
    Gauss points of the coarse element holding each point (cached per mesh pair). With ``breaks``
    (the vertices where the stresses may jump, as bytes): Lagrange through those two and the
    nearest Gauss point of each neighbouring element not across a break (cubic inside a piece).
    Measured (issue 32.3): the next Newton's second correction 2.6e-5 -> 2.6e-6 on the 8-element
    mesh of the alpha = 5 tip force, 3.4e-6 -> 1.4e-7 on the 45-degree 3D bend."""
    v, s = np.frombuffer(vertices), np.frombuffer(points)
    q = np.frombuffer(coarse).reshape(v.size - 1, 2)
    e = np.clip(np.searchsorted(v, s, side="right") - 1, 0, v.size - 2)
    if breaks is None:
        t = (s - q[e, 0]) / (q[e, 1] - q[e, 0])
        return _operator(np.stack([2 * e, 2 * e + 1], axis=1), np.stack([1.0 - t, t], axis=1), q.size)
    left, right = _neighbours(v, e, breaks)
    cols = np.stack([2 * e - 1, 2 * e, 2 * e + 1, 2 * e + 2], axis=1)
    use = np.stack([left, np.ones_like(left), np.ones_like(left), right], axis=1)
    cols = np.clip(cols, 0, q.size - 1)
    return _operator(cols, _lagrange(q.ravel()[cols], use, s), q.size)


def _neighbours(v: np.ndarray, e: np.ndarray, breaks: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Whether element e's left and right neighbours (of the mesh with vertices v) are in its piece:
    there is one, and the vertex between is none of ``breaks`` (bytes)."""
    inner = ~np.isclose(v[:, None], np.frombuffer(breaks)[None, :], rtol=0.0, atol=1e-12).any(axis=1)
    return (e > 0) & inner[e], (e < v.size - 2) & inner[np.minimum(e + 1, v.size - 1)]


def _lagrange(x: np.ndarray, use: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Lagrange weights (n, k) at the points s (n,) of their stencils' nodes x (n, k), over the
    nodes in ``use`` (n, k) (zero at the others): every factor (s - x_m) / (x_k - x_m) at once."""
    k = x.shape[1]
    both = use[:, :, None] & use[:, None, :] & ~np.eye(k, dtype=bool)  # [point, node k, node m]
    gap = np.where(both, x[:, :, None] - x[:, None, :], 1.0)
    factors = np.where(both, (s[:, None, None] - x[:, None, :]) / gap, 1.0)
    return np.where(use, factors.prod(axis=2), 0.0)
