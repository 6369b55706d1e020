"""Model runs and their convergence: Richardson limits and the cost at a target error.

Each model's discretisation error is measured against its own converged limit: Richardson
extrapolation from the three finest meshes with the observed order (h = 1 / level). The DOF and
time at error 1e-4 come from log-log interpolation; outside the measured range they are
extrapolated and flagged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

TARGET = 1e-4


@dataclass
class Run:
    """One model evaluation: the output value, its unknowns and wall time."""

    model: str
    case: str
    mesh: str
    dofs: int
    runtime_s: float
    value: float
    extra: dict = field(default_factory=dict)


def richardson(h: np.ndarray, values: np.ndarray, *, roundoff: float = 1e-10) -> dict:
    """Limit and observed order from the three finest meshes, v = v_inf + C h^p.

    p solves (h1^p - h2^p) / (h2^p - h3^p) = (v1 - v2) / (v2 - v3). When the two
    differences are at round-off the finest value is the limit (order None); when
    they change sign the sequence is not monotone and the finest value is kept.
    """
    h1, h2, h3 = (float(x) for x in h[-3:])
    v1, v2, v3 = (float(x) for x in values[-3:])
    d12, d23 = v1 - v2, v2 - v3
    scale = abs(v3)
    if max(abs(d12), abs(d23)) <= roundoff * scale:
        return {"limit": v3, "order": None, "status": "exact to round-off on every mesh"}
    if d12 * d23 <= 0:
        return {"limit": v3, "order": None, "status": "not monotone: finest value taken as the limit"}
    ratio = d12 / d23

    def gap(p):
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio

    lo, hi = 0.05, 16.0
    if gap(lo) * gap(hi) > 0:
        return {"limit": v3, "order": None, "status": "order outside [0.05, 16]: finest value taken"}
    p = brentq(gap, lo, hi)
    limit = v3 - d23 * h3**p / (h2**p - h3**p)
    return {"limit": limit, "order": p, "status": "Richardson, observed order"}


def cost_at(
    runs: list[Run], errors: np.ndarray, target: float = TARGET, *, order: float | None = None, dim: int = 3
) -> dict:
    """DOF and run time at discretisation error ``target``: log-log interpolation between the
    meshes around it; beyond the finest mesh extrapolated with err ~ DOF^(-order/dim) and a
    power-law fit of time against DOF; if the coarsest mesh is already below, its cost."""
    dofs = np.array([r.dofs for r in runs], float)
    times = np.array([r.runtime_s for r in runs], float)
    for i in range(len(runs) - 1):
        e0, e1 = errors[i], errors[i + 1]
        if e0 >= target > e1 and e1 > 0:
            w = math.log(e0 / target) / math.log(e0 / e1)
            return _cost(
                dofs[i] * (dofs[i + 1] / dofs[i]) ** w,
                times[i] * (times[i + 1] / times[i]) ** w,
                "interpolated",
            )
    if errors[0] <= target:
        return _cost(dofs[0], times[0], "coarsest mesh already below the target (an upper bound of the cost)")
    if order is None:
        return _cost(math.nan, math.nan, "not reached and no order to extrapolate")
    slope = np.polyfit(np.log(dofs[-3:]), np.log(times[-3:]), 1)[0]
    n = dofs[-1] * (errors[-1] / target) ** (dim / order)
    status = f"extrapolated beyond the finest mesh (err ~ DOF^-{order / dim:.2f}, time ~ DOF^{slope:.2f})"
    return _cost(n, times[-1] * (n / dofs[-1]) ** slope, status)


def _cost(dofs: float, time_s: float, status: str) -> dict:
    return {"dofs": float(dofs), "time_s": float(time_s), "status": status}
