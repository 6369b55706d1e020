"""The mid-span centreline deflection of the bend model and its derivatives (contract section 7).

A centreline test gives the force at a measured centreline deflection c, while
the model is driven by the nose travel n. :func:`matid.fits.shear.fit.Problem` finds
n for each row by Newton's method on c(n) = c_measured, with dc/dn from the load
tangent dX/dd of the path, and the fit's Jacobian is the total derivative at
fixed c:

    dF/dp|_c = dF/dp|_n + dF/dn dn/dp,   dn/dp = -(dc/dp|_n) / (dc/dn).

Every dc/d(.) is dc/dX (closed form, :class:`Centreline`) times a state direction
dX/d(.) that the path already holds (one back-substitution each,
:mod:`matid.rod.bend`); :func:`rate`, a central difference along the direction, is
its test oracle.
"""

from __future__ import annotations

import numpy as np

from matid.rod.bend import BendModel, BendPath


def centreline_at(model: BendModel, X: np.ndarray) -> float:
    """Mid-span centreline deflection x(S/2) - x(0) [m] at a state of the half model (x up)."""
    s, x, _, _ = model.half_state_of(X)
    return float(np.interp(0.5 * model.geometry.span, s, x) - x[0])


def centreline_deflection(model: BendModel, path: BendPath) -> np.ndarray:
    """Mid-span centreline deflection relative to the material sections over the supports (s = S/2).

    From the solved states' public shape (``BendModel.half_state``): x(S/2) - x(0),
    x up. It differs from the nose travel by the rotation of the support sections
    (second order: +0.8 % at d/S = 1 % on a 8 mm span).
    """
    return np.array([centreline_at(model, X) for X in path.states])


class Centreline:
    """c(X) and its gradient dc/dX for one model, in closed form (the fit's hot path).

    Node positions are linear in sigma, s = a + b sigma (uniform elements on each side
    of the support vertex), and c interpolates x linearly between the two nodes around
    s = S/2, as :func:`centreline_at` does; the gradient holds the two nodal weights,
    -1 at the mid-span vertex and the derivative of the weight in sigma.
    """

    def __init__(self, model: BendModel):
        system = model.geometry_system()
        system.at(0.25)
        s1 = system.rod.disc.s_dof.copy()
        system.at(0.5)
        s2 = system.rod.disc.s_dof.copy()
        self.b = (s2 - s1) / 0.25
        self.a = s1 - 0.25 * self.b
        self.order = np.argsort(s2, kind="stable")  # the same for every sigma (fixed topology)
        self.xdof = system.rod.index[3 * np.arange(s2.size)]  # free index of x at each node
        self.x_ref = system.rod.reference()[0::3]
        self.span, self.nu = model.geometry.span, system.nu

    def _x(self, X: np.ndarray, node: int) -> float:
        i = self.xdof[node]
        return float(X[i]) if i >= 0 else float(self.x_ref[node])

    def value_and_gradient(self, X: np.ndarray) -> tuple[float, np.ndarray]:
        """c [m] and dc/dX at a state X of the half model."""
        sigma = float(X[-1])
        s = (self.a + self.b * sigma)[self.order]
        k = int(np.clip(np.searchsorted(s, 0.5, side="right") - 1, 0, s.size - 2))
        j0, j1 = self.order[k], self.order[k + 1]
        width = s[k + 1] - s[k]
        w = (0.5 - s[k]) / width
        dw = (-self.b[j0] * width - (0.5 - s[k]) * (self.b[j1] - self.b[j0])) / width**2
        x0, x1 = self._x(X, j0), self._x(X, j1)
        grad = np.zeros(X.size)
        for node, weight in ((j0, 1.0 - w), (j1, w), (0, -1.0)):
            if self.xdof[node] >= 0:
                grad[self.xdof[node]] += self.span * weight
        grad[-1] = self.span * (x1 - x0) * dw
        return self.span * (x0 + w * (x1 - x0) - self._x(X, 0)), grad


def rate(model: BendModel, X: np.ndarray, v: np.ndarray) -> float:
    """Derivative of :func:`centreline_at` along the state direction v by a central difference
    (the oracle of :meth:`Centreline.value_and_gradient`)."""
    size = float(np.max(np.abs(v)))
    if size == 0.0:
        return 0.0
    h = 1e-6 / size
    return (centreline_at(model, X + h * v) - centreline_at(model, X - h * v)) / (2.0 * h)


def centreline_path(centre: Centreline, path: BendPath) -> tuple[np.ndarray, np.ndarray, list]:
    """(c, dc/dn, gradients dc/dX) at every point of a path (dc/dn along the load tangent)."""
    c, grads = zip(*(centre.value_and_gradient(X) for X in path.states), strict=True)
    slope = [float(g @ t["d"]) for g, t in zip(grads, path.tangents, strict=True)]
    return np.array(c), np.array(slope), list(grads)


def at_fixed_centreline(
    model: BendModel, path: BendPath, E_b: float, slope: np.ndarray, grads: list
) -> tuple[dict, dict]:
    """(dF/dp at fixed centreline deflection, dn/dp) for p in E_s, E_e, E_b, SI, at each point.

    ``slope``, ``grads``: dc/dn and dc/dX of :func:`centreline_path`. The path must hold
    the sensitivities of E_s and E_e (their state directions are per unit scaled
    stiffness, E S^2/E_b; E_b moves the state only through those two, the force is
    homogeneous in the stiffnesses).
    """
    S2 = model.geometry.span**2
    e_s, e_e = path.scaled
    dn: dict[str, list] = {"E_s": [], "E_e": [], "E_b": []}
    for t, m, grad in zip(path.tangents, slope, grads, strict=True):
        r_s, r_e = float(grad @ t["E_s"]), float(grad @ t["E_e"])
        dc = {"E_s": r_s * S2 / E_b, "E_e": r_e * S2 / E_b, "E_b": -(e_s * r_s + e_e * r_e) / E_b}
        for p, value in dc.items():
            dn[p].append(-value / m)
    dn_dp = {p: np.array(v) for p, v in dn.items()}
    total = {p: path.dforce[p] + path.dforce_dd * dn_dp[p] for p in dn_dp if p in path.dforce}
    return total, dn_dp
