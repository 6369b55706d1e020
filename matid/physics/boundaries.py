"""Rigid boundaries a tube touches (physics.md section 9): gaps of points to planar walls and to a
lumen around a polyline centreline with rounded corners, with their gradients and Hessians.

Points are (n, 3) arrays; every function is vectorised over them (numpy only). The gap of a point
r of the centreline at outer radius R_o:

- wall through p with unit normal n: g = n.(r - p) - R_o, gradient n, Hessian 0;
- lumen of radius rho: g = rho - R_o - d, d = |r - c*(r)| with c* the closest point of the
  centreline; gradient -e (e = (r - c*)/d), Hessian -H_d with
  H_d = (I - e e^T - kappa_c t t^T) / d (t the centreline's tangent at c*, kappa_c = 1 on a straight
  piece, R_c / rho_in on an arc of radius R_c at in-plane distance rho_in from its centre, 0 at an
  end point of the centreline).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def wall_gap(r: np.ndarray, point, normal, R_o: np.ndarray):
    """(g (n,), gradient (n, 3)) of a wall at points r (n, 3)."""
    n = np.asarray(normal, float)
    g = (r - np.asarray(point, float)) @ n - R_o
    return g, np.broadcast_to(n, r.shape)


@dataclass(frozen=True)
class Centreline:
    """A polyline with rounded corners: straight pieces (a, b) and arcs (centre, radius, A, B, axis).

    The first and last straight pieces are continued beyond the polyline's ends (an open vessel).
    """

    lines: tuple[tuple[np.ndarray, np.ndarray], ...]
    arcs: tuple[tuple[np.ndarray, float, np.ndarray, np.ndarray, np.ndarray], ...]

    @classmethod
    def rounded(cls, points, corner_radius: float) -> Centreline:
        """The polyline through ``points`` (m, 3), each inner corner replaced by an arc of
        ``corner_radius`` tangent to both sides; ValueError when an arc does not fit."""
        P = np.asarray(points, float)
        if P.shape[0] < 2 or P.shape[1] != 3:
            raise ValueError("a centreline needs at least two points (x, y, z)")
        legs = np.diff(P, axis=0)
        lengths = np.linalg.norm(legs, axis=1)
        if np.any(lengths <= 0):
            raise ValueError("two consecutive centreline points coincide")
        t = legs / lengths[:, None]
        starts, ends, arcs = [P[0]], [], []
        used = np.zeros(lengths.size)  # length taken by the arcs at each leg's two ends
        for i in range(1, P.shape[0] - 1):
            t_in, t_out = t[i - 1], t[i]
            cos = float(np.clip(t_in @ t_out, -1.0, 1.0))
            if cos > 1.0 - 1e-14:  # straight through: no arc
                ends.append(P[i])
                starts.append(P[i])
                continue
            if cos < -1.0 + 1e-9:
                raise ValueError("the centreline turns back on itself")
            half = 0.5 * np.arccos(cos)
            T = corner_radius * np.tan(half)
            used[i - 1] += T
            used[i] += T
            A, B = P[i] - T * t_in, P[i] + T * t_out
            inward = t_out - cos * t_in
            centre = A + corner_radius * inward / np.linalg.norm(inward)
            axis = np.cross(t_in, t_out)
            arcs.append((centre, float(corner_radius), A, B, axis / np.linalg.norm(axis)))
            ends.append(A)
            starts.append(B)
        ends.append(P[-1])
        if np.any(used > lengths * (1 + 1e-12)):
            raise ValueError("corner_radius too large: the rounded corners of the centreline overlap")
        return cls(_pieces(starts, ends, lengths - used <= MEET * lengths, legs), tuple(arcs))

    def closest(self, r: np.ndarray):
        """(c*, kappa_c t t^T) at points r (n, 3): the closest centreline point and its Jacobian."""
        n = r.shape[0]
        best = np.full(n, np.inf)
        c_best = np.zeros((n, 3))
        J_best = np.zeros((n, 3, 3))
        last = len(self.lines) - 1
        for k, (a, b) in enumerate(self.lines):
            ab = b - a
            length = float(np.linalg.norm(ab))
            t = ab / length
            u = (r - a) @ t
            lo = -np.inf if k == 0 else 0.0
            hi = np.inf if k == last else length
            inside = (u >= lo) & (u <= hi)
            c = a + np.clip(u, lo, hi)[:, None] * t
            J = np.where(inside[:, None, None], np.outer(t, t), 0.0)
            best, c_best, J_best = _keep(r, c, J, best, c_best, J_best)
        for centre, Rc, A, B, axis in self.arcs:
            w = r - centre
            inplane = w - np.outer(w @ axis, axis)
            rho = np.maximum(np.linalg.norm(inplane, axis=1), 1e-300)
            u = inplane / rho[:, None]
            a0 = (A - centre) / Rc
            b0 = (B - centre) / Rc
            span = np.arctan2(np.cross(a0, b0) @ axis, a0 @ b0)
            ang = np.arctan2(np.cross(a0, u) @ axis, u @ a0)
            inside = (ang >= 0) & (ang <= span)
            c = np.where(inside[:, None], centre + Rc * u, np.where((ang < 0)[:, None], A, B))
            tang = np.cross(axis, u)
            bend = (Rc / rho)[:, None, None] * tang[:, :, None] * tang[:, None, :]
            J = np.where(inside[:, None, None], bend, 0.0)
            best, c_best, J_best = _keep(r, c, J, best, c_best, J_best)
        return c_best, J_best


#: Where the arcs at a leg's two ends leave less than this fraction of it straight, they meet: the
#: piece between is round-off long (or 0), so b - a has no direction. It is dropped, or at an open
#: end, whose continuation beyond the polyline it carries, rebuilt along its leg.
MEET = 1e-9


def _pieces(starts: list, ends: list, meet: np.ndarray, legs: np.ndarray) -> tuple:
    """The straight pieces (a, b), one per leg (``legs``: its vectors), but where the arcs meet
    (:data:`MEET`); the first and last are always kept, as the leg's line up to or from its arc."""
    last = len(starts) - 1
    pieces = []
    for i, (a, b) in enumerate(zip(starts, ends, strict=True)):
        if not meet[i]:
            pieces.append((a, b))
        elif i == 0:
            pieces.append((b - legs[0], b))
        elif i == last:
            pieces.append((a, a + legs[-1]))
    return tuple(pieces)


def _keep(r, c, J, best, c_best, J_best):
    d = np.linalg.norm(r - c, axis=1)
    closer = d < best
    return (
        np.where(closer, d, best),
        np.where(closer[:, None], c, c_best),
        np.where(closer[:, None, None], J, J_best),
    )


def lumen_gap(r: np.ndarray, line: Centreline, radius: float, R_o: np.ndarray):
    """(g (n,), gradient (n, 3), Hessian (n, 3, 3)) of a lumen at points r (n, 3)."""
    c, J = line.closest(r)
    w = r - c
    d = np.maximum(np.linalg.norm(w, axis=1), 1e-300)
    e = w / d[:, None]
    eye = np.eye(3)
    H_d = (eye - e[:, :, None] * e[:, None, :] - J) / d[:, None, None]
    return radius - R_o - d, -e, -H_d
