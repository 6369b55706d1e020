"""An independent reference for cantilever scenes: the strong form of the special Cosserat rod
integrated by shooting (test-only; it shares no code with matid's solver).

Unknowns along s, lab frame: r, R = [d1 d2 d3], internal force n and moment m.

    r' = R nu,   R' = R [kappa]x,   n' = -f,   m' = -r' x n - mu (R a) x B,
    nu = (n1/E_s, n2/E_s, 1 + n3/E_e),   kappa = kappa_ref + (m1/E_b, m2/E_b, m3/E_t)

with (n_i, m_i) = R^T (n, m) in the director frame. The clamp gives r(0) = 0, R(0) = I; the
free end n(L) = F_tip, m(L) = M_tip + m_tip (R a) x B. At an interior point s_p, a point
load jumps n(s_p-) = n(s_p+) + F and m(s_p-) = m(s_p+) + M, a lumped magnet m(s_p-) =
m(s_p+) + m (R a) x B. Shooting: (n(0), m(0)) solve the six end conditions, each segment
between breaks integrated by solve_ivp (DOP853, rtol 1e-12), the load raised in steps.
E_s = E_e = inf is the inextensible, unshearable rod of the closed forms.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import root

RTOL, ATOL = 1e-12, 1e-14


def _hat(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


class Rod:
    """A scene in SI, read from a matid Scene only for its numbers (scene.rod, scene.loads)."""

    def __init__(self, scene, B=None, base=None):
        rod, loads = scene.rod, scene.loads
        self.L = rod.length
        self.base = dict(E_b=rod.E_b, E_t=rod.E_t, E_s=rod.E_s, E_e=rod.E_e, kref=np.array(rod.precurvature))
        self.base.update(base or {})
        self.segments = rod.segments
        self.B = np.array(loads.B if B is None else B, float)
        self.f = np.array(loads.distributed_force, float)
        self.F_tip, self.M_tip = np.array(loads.tip_force, float), np.array(loads.tip_moment, float)
        self.magnets = [
            (at, m, np.array(a)) for (at, m), a in zip(loads.magnets, loads.directions("magnet"), strict=True)
        ]
        self.mu = [
            (s0, s1, m, np.array(a))
            for (s0, s1, m), a in zip(loads.magnetization, loads.directions("magnetization"), strict=True)
        ]
        self.points = [(at, np.array(F), np.array(M)) for at, F, M in loads.point_loads]
        cuts = {0.0, self.L}
        cuts |= {p for seg in self.segments for p in (seg.start, seg.end)}
        cuts |= {at for at, _, _ in self.magnets} | {at for at, _, _ in self.points}
        cuts |= {p for s0, s1, _, _ in self.mu for p in (s0, s1)}
        self.cuts = sorted(c for c in cuts if 0.0 <= c <= self.L)

    def props(self, s: float) -> dict:
        out = dict(self.base)
        for seg in self.segments:
            if seg.start <= s < seg.end:
                out.update(seg.overrides)
                if seg.precurvature is not None:
                    out["kref"] = np.array(seg.precurvature)
        return out

    def mu_a(self, s: float) -> np.ndarray:
        return sum((m * a for s0, s1, m, a in self.mu if s0 <= s <= s1), np.zeros(3))

    def rhs(self, s: float, y: np.ndarray, lam: float, p: dict, mua: np.ndarray) -> np.ndarray:
        R, n, m = y[3:12].reshape(3, 3), y[12:15], y[15:18]
        nd, md = R.T @ n, R.T @ m
        nu = np.array([nd[0] / p["E_s"], nd[1] / p["E_s"], 1.0 + nd[2] / p["E_e"]])
        kappa = lam * p["kref"] + np.array([md[0] / p["E_b"], md[1] / p["E_b"], md[2] / p["E_t"]])
        dr = R @ nu
        dm = -np.cross(dr, n) - lam * np.cross(R @ mua, self.B)
        return np.concatenate([dr, (R @ _hat(kappa)).ravel(), -lam * self.f, dm])

    def shoot(self, nm0: np.ndarray, lam: float, dense: bool = False):
        """The state at s = L from (n(0), m(0)), applying the point jumps on the way."""
        y = np.concatenate([np.zeros(3), np.eye(3).ravel(), nm0])
        for a, b in zip(self.cuts[:-1], self.cuts[1:], strict=True):
            mid = 0.5 * (a + b)
            args = (lam, self.props(mid), self.mu_a(mid))
            sol = solve_ivp(self.rhs, (a, b), y, method="DOP853", rtol=RTOL, atol=ATOL, args=args)
            y = sol.y[:, -1].copy()
            if b < self.L:
                y = self.jump(y, b, lam)
        return y

    def jump(self, y: np.ndarray, s: float, lam: float) -> np.ndarray:
        """Crossing s forwards: n(s+) = n(s-) - F, m(s+) = m(s-) - M - m (R a) x B."""
        R = y[3:12].reshape(3, 3)
        for at, F, M in self.points:
            if at == s:
                y[12:15] -= lam * F
                y[15:18] -= lam * M
        for at, m, a in self.magnets:
            if at == s:
                y[15:18] -= lam * m * np.cross(R @ a, self.B)
        return y

    def end_conditions(self, x: np.ndarray, lam: float) -> np.ndarray:
        y = self.shoot(x * self.scale, lam)
        R = y[3:12].reshape(3, 3)
        n_end, m_end = lam * self.F_tip.copy(), lam * self.M_tip.copy()
        for at, F, M in self.points:
            if at >= self.L:
                n_end, m_end = n_end + lam * F, m_end + lam * M
        for at, m, a in self.magnets:
            if at >= self.L:
                m_end = m_end + lam * m * np.cross(R @ a, self.B)
        return (np.concatenate([y[12:15] - n_end, y[15:18] - m_end])) / self.scale

    @property
    def scale(self) -> np.ndarray:
        """Force and moment units E_b/L^2, E_b/L: the shooting unknowns are O(1) in them."""
        return np.concatenate(
            [np.full(3, self.base["E_b"] / self.L**2), np.full(3, self.base["E_b"] / self.L)]
        )


def solve(scene, *, steps: int = 8, B=None, start=None, base=None) -> dict:
    """Tip position, d1, d3 (lab frame, SI) of a cantilever scene; the load raised in ``steps``.

    ``B`` replaces the scene's field; ``base`` its rod's stiffnesses (e.g. E_s = E_e = inf)."""
    rod = Rod(scene, B, base)
    x = np.zeros(6) if start is None else np.asarray(start, float) / rod.scale
    lams = [1.0] if start is not None else np.linspace(0, 1, steps + 1)[1:]
    for lam in lams:
        out = root(rod.end_conditions, x, args=(lam,), method="hybr", options={"xtol": 1e-12})
        if np.max(np.abs(out.fun)) > 1e-10:  # hybr may stall at the integrator's noise: judged by |R|
            raise RuntimeError(f"reference: no convergence at load {lam}: {out.message}")
        x = out.x
    y = rod.shoot(x * rod.scale, 1.0)
    R = y[3:12].reshape(3, 3)
    return {"position": y[:3], "d1": R[:, 0], "d3": R[:, 2], "start": x * rod.scale}
