"""The mid-span centreline deflection of the bend model and its derivatives (contract section 7).

A centreline test gives the force at a measured centreline deflection c, while
the model is driven by the nose travel n. :func:`matid.fits.shear.Problem` finds
n for each row by Newton's method on c(n) = c_measured, with dc/dn from the load
tangent dX/dd of the path, and the fit's Jacobian is the total derivative at
fixed c:

    dF/dp|_c = dF/dp|_n + dF/dn dn/dp,   dn/dp = -(dc/dp|_n) / (dc/dn).

Every dc/d(.) is the derivative of c(X) along a state direction dX/d(.) that the
path already holds (one back-substitution each, :mod:`matid.rod.bend`). c(X)
interpolates nodal values linearly at s = S/2, on nodes whose positions move
smoothly with sigma, so a central difference along the direction is exact to
O(h^2) (h = 1e-6 of the state).
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


def rate(model: BendModel, X: np.ndarray, v: np.ndarray) -> float:
    """Derivative of :func:`centreline_at` along the state direction v (central difference)."""
    size = float(np.max(np.abs(v)))
    if size == 0.0:
        return 0.0
    h = 1e-6 / size
    return (centreline_at(model, X + h * v) - centreline_at(model, X - h * v)) / (2.0 * h)


def nose_slope(model: BendModel, path: BendPath) -> np.ndarray:
    """dc/dn at each point of the path (the centreline moves with the nose at ~1)."""
    return np.array([rate(model, X, t["d"]) for X, t in zip(path.states, path.tangents, strict=True)])


def at_fixed_centreline(model: BendModel, path: BendPath, E_b: float, slope: np.ndarray) -> tuple[dict, dict]:
    """(dF/dp at fixed centreline deflection, dn/dp) for p in E_s, E_e, E_b, SI, at each point.

    ``slope``: dc/dn of :func:`nose_slope`. The path must hold the sensitivities of E_s
    and E_e (their state directions are per unit scaled stiffness, E S^2/E_b; E_b moves
    the state only through those two, the force is homogeneous in the stiffnesses).
    """
    S2 = model.geometry.span**2
    e_s, e_e = path.scaled
    dn: dict[str, list] = {"E_s": [], "E_e": [], "E_b": []}
    for X, t, m in zip(path.states, path.tangents, slope, strict=True):
        r_s, r_e = rate(model, X, t["E_s"]), rate(model, X, t["E_e"])
        dc = {"E_s": r_s * S2 / E_b, "E_e": r_e * S2 / E_b, "E_b": -(e_s * r_s + e_e * r_e) / E_b}
        for p, value in dc.items():
            dn[p].append(-value / m)
    dn_dp = {p: np.array(v) for p, v in dn.items()}
    total = {p: path.dforce[p] + path.dforce_dd * dn_dp[p] for p in dn_dp if p in path.dforce}
    return total, dn_dp
