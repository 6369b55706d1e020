"""The planar and full rod models on a clamped rod, in scaled units.

Scaling (physics.md, "scale the problem before solving it"): lengths by L,
forces by E_b0/L^2, moments by E_b0/L, energies by E_b0/L, with E_b0 the
bending stiffness at the clamp. Scaled stiffnesses are then E_b = 1,
E_t/E_b0, E_s L^2/E_b0, E_e L^2/E_b0; a magnetisation per length mu B becomes
mu B L^2/E_b0 and a lumped moment m B becomes m B L/E_b0.

Total energy, eq. (10), at load factor lam (loads and precurvature scale with lam):

    S = int_0^1 [W(kappa - lam kappa_ref, nu) - lam mu d3.B + c_u P - lam f.r] ds
        - lam sum_magnets m d3(s_m).B - lam F.r(1)  [- lam M theta(1), planar]

A dead tip moment in 3D has no potential; its virtual work lam M.dphi with the
spatial spin dphi = 2 vec(dq * conj(q))/|q|^2 enters the residual directly
(the tangent is then unsymmetric, which the LU solver handles).

Each load is a term of :mod:`matid.rod.terms`; :class:`matid.rod.system.RodSystem` sums the
strain energy and the terms a scene has.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.physics.kinematics import directors

PLANAR, FULL = "planar", "full"


@dataclass(frozen=True)
class Segment:
    """Scaled properties on [start, end): stiffness factors relative to the base rod."""

    start: float
    end: float
    E_b: float
    E_t: float
    E_s: float
    E_e: float
    kappa_ref: tuple[float, float, float] | None = None  # this piece's precurvature; None: the rod's


@dataclass(frozen=True)
class ScaledRod:
    """A clamped rod in scaled units (see module docstring): its stiffnesses and precurvature; its
    loads are terms (:mod:`matid.rod.terms`). In the planar model the precurvature is about the
    plane normal (its second entry)."""

    E_t: float = 1.0
    E_s: float = 1e4
    E_e: float = 1e4
    segments: tuple[Segment, ...] = ()
    kappa_ref: tuple[float, ...] = (0.0, 0.0, 0.0)

    def kappa_ref_at(self, s: np.ndarray) -> np.ndarray | None:
        """kappa_ref at points s (P + (3,)) when a segment has its own, else None (the rod's, uniform)."""
        if not any(seg.kappa_ref is not None for seg in self.segments):
            return None
        out = np.broadcast_to(np.asarray(self.kappa_ref, float), s.shape + (3,)).copy()
        for seg in self.segments:
            if seg.kappa_ref is not None:
                out[(s >= seg.start) & (s < seg.end)] = seg.kappa_ref
        return out

    def stiffness_at(self, s: np.ndarray) -> dict[str, np.ndarray]:
        base = {"E_b": 1.0, "E_t": self.E_t, "E_s": self.E_s, "E_e": self.E_e}
        out = {name: np.full_like(s, value) for name, value in base.items()}
        for seg in self.segments:
            inside = (s >= seg.start) & (s < seg.end)
            for name in out:
                out[name] = np.where(inside, getattr(seg, name), out[name])
        return out


def lab_frames(U: np.ndarray, e_a, L: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(position, d1, d3) in the lab frame (metres) of nodal rows U: planar (x, z, theta) in the plane
    of e_a (3,), or full (r, q) when e_a is None."""
    if e_a is not None:  # rotation by theta about n = e3 x e_a = (-a1, a0, 0) (Rodrigues)
        a0, a1 = float(e_a[0]), float(e_a[1])
        x, z, c, s = U[:, 0], U[:, 1], np.cos(U[:, 2]), np.sin(U[:, 2])
        one_c = 1.0 - c
        position, d1, d3 = (np.empty((U.shape[0], 3)) for _ in range(3))  # column writes: np.stack ~5 us
        position[:, 0], position[:, 1], position[:, 2] = x * a0, x * a1, z
        position *= L
        d1[:, 0], d1[:, 1], d1[:, 2] = c + a1 * a1 * one_c, -a0 * a1 * one_c, -a0 * s  # R e1
        d3[:, 0], d3[:, 1], d3[:, 2] = a0 * s, a1 * s, c  # d3 = R e3 = c e3 + s e_a
        return position, d1, d3
    position = U[:, :3] * L
    q = U[:, 3:] / np.linalg.norm(U[:, 3:], axis=1, keepdims=True)
    R = np.array(directors(q.T)).transpose(2, 0, 1)  # (n, 3, 3)
    return position, R[:, :, 0], R[:, :, 2]
