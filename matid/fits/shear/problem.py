"""The E_s fit's least-squares problem: residuals and Jacobian from the bend model, and the solver.

The bend is solved on knots, a subset of each test's rows, and interpolated to every
row in the measured coordinate q (nose travel, or the centreline deflection):

    F(q)      cubic Hermite through F_j and the path tangent dF/dq_j at the knots,
    dF/dp(q)  cubic spline (not-a-knot) through dF/dp_j,  p in E_s, E_b, E_e.

Both are O(h^4). The interpolation error at the rows is estimated by |Hermite - spline|
of F (the spline's own error, about ten times the Hermite's: an upper bound, measured),
and knots are added (the row nearest each failing interval's middle) until it is below

    tol = INTERPOLATION_FRACTION sigma / sqrt(n)   (floor INTERPOLATION_FLOOR max |F|)

with sigma the rows' noise (:func:`matid.fits.stats.difference_noise`) and n the rows:
a bias that small moves E_s by about a tenth of its standard error at most. The knots
are chosen at the first evaluation and held through Levenberg-Marquardt (the residual
stays one smooth function of x); :meth:`Problem.refine` checks them at the solution.
A fit costs knots, not rows: up to 2 START_KNOTS - 1 rows, every distinct row is a knot
(the per-row solve, exact). The model and the statistics: :mod:`matid.fits.shear.fit`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from matid.errors import FitError
from matid.fits.shear import centreline as bend_centreline
from matid.fits.shear.lsq import least_squares, statistics
from matid.fits.stats import difference_noise
from matid.rod.bend import BendModel, BendPath

if TYPE_CHECKING:
    from matid.fits.shear.data import BendData

#: Knots of the first solve of a test; up to 2 START_KNOTS - 1 rows (one refinement of every
#: interval) every distinct row is a knot.
START_KNOTS = 17
#: The interpolation error stays below this fraction of sigma / sqrt(n) (see the module docstring),
INTERPOLATION_FRACTION = 0.1
#: or below this fraction of the largest force (noise-free data).
INTERPOLATION_FLOOR = 1e-8
#: Centreline tests: the nose travel n of each knot is found when its centreline deflection c(n)
#: misses the measured one by at most this fraction of the largest, or when the next Newton step
#: on n would (its miss is rate * miss^2, the rate measured on the steps before): then that step
#: is taken to first order, F + dF/dn (c - c(n)) / (dc/dn), instead of solving again (on the
#: demo's T1 the misses run 2.4e-2, 1.0e-5, 1.8e-12 of the largest: one solve saved).
CENTRELINE_MATCH = 1e-9
ORDER = 4.0  # measured P2 order of the bend force (bench): the FE error's Richardson estimate


def start_knots(q: np.ndarray) -> np.ndarray:
    """Row indices of the first knots: every distinct row, or for more than 2 START_KNOTS - 1
    of them the distinct rows nearest START_KNOTS values evenly spread over [q_0, q_end]."""
    first = np.unique(q, return_index=True)[1]  # first row of each distinct value, increasing q
    if first.size <= 2 * START_KNOTS - 1:
        return first
    qu = q[first]
    targets = np.linspace(qu[0], qu[-1], START_KNOTS)
    pos = np.clip(np.searchsorted(qu, targets), 1, qu.size - 1)
    nearest = np.where(targets - qu[pos - 1] <= qu[pos] - targets, pos - 1, pos)
    return first[np.unique(nearest)]


def refine(q: np.ndarray, knots: np.ndarray, error: np.ndarray, tol: float) -> np.ndarray | None:
    """The knots with the distinct row nearest the middle of every interval whose error at a
    row exceeds tol added; None when no interval needs (or can take) another knot."""
    qk = q[knots]
    if qk.size < 2:  # one distinct row: nothing between knots
        return None
    interval = np.clip(np.searchsorted(qk, q, side="right") - 1, 0, qk.size - 2)
    first = np.unique(q, return_index=True)[1]
    added = []
    for j in np.unique(interval[error > tol]):
        inside = first[(q[first] > qk[j]) & (q[first] < qk[j + 1])]
        if inside.size:
            added.append(inside[np.argmin(np.abs(q[inside] - 0.5 * (qk[j] + qk[j + 1])))])
    return np.sort(np.r_[knots, added]).astype(int) if added else None


def interpolate(qk: np.ndarray, F, slope, dF: dict, q: np.ndarray) -> tuple[np.ndarray, dict, np.ndarray]:
    """(F, dF/dp, estimated error of F) at the rows q from the knots qk (module docstring).

    Rows on a knot take its values exactly.
    """
    if qk.size == 1:
        ones = np.ones(q.size)
        return F[0] * ones, {p: v[0] * ones for p, v in dF.items()}, np.zeros(q.size)
    force = CubicHermiteSpline(qk, F, slope)(q)
    error = np.abs(force - CubicSpline(qk, F)(q))
    pos = np.minimum(np.searchsorted(qk, q), qk.size - 1)
    on = qk[pos] == q
    force[on], error[on] = F[pos[on]], 0.0
    if not dF:
        return force, {}, error
    at_knots = np.column_stack(list(dF.values()))
    table = CubicSpline(qk, at_knots)(q)
    table[on] = at_knots[pos[on]]
    return force, dict(zip(dF, table.T, strict=True)), error


def tolerance(F: np.ndarray) -> float:
    """Allowed interpolation error [N] of one test's rows (module docstring)."""
    noise = difference_noise(F)
    return max(
        INTERPOLATION_FRACTION * noise / np.sqrt(F.size), INTERPOLATION_FLOOR * float(np.max(np.abs(F)))
    )


class Problem:
    """Residuals and Jacobian of the bend fit, with the paths of every evaluation kept.

    Each evaluation is kept with its paths (a fit makes a handful): returning to an
    earlier x costs nothing, and the paths of the last x asked for are ``paths``,
    the warm starts of the next solve. ``paths[k]`` is solved at the knots of test k
    (``knots[k]``, row indices); ``force[k]`` and ``dforce[k]`` (dF/dp) are at its rows,
    interpolated (module docstring; for centreline tests at fixed centreline deflection,
    :mod:`matid.fits.shear.centreline`), ``error[k]`` the estimated interpolation error
    at the rows and ``tolerance[k]`` its bound.
    """

    def __init__(
        self,
        data: Sequence[BendData],
        E_b: float,
        E_e: float,
        *,
        fit_E_b: bool,
        elements: int,
        jacobian: bool = True,
        knots: Sequence[np.ndarray | None] | None = None,
    ):
        self.data, self.E_b, self.E_e, self.fit_E_b = data, E_b, E_e, fit_E_b
        self.jacobian = jacobian or any(b.centreline for b in data)  # False: residuals only (J is None)
        self.models = [BendModel(b.geometry, elements=elements) for b in data]
        self.knots: list[np.ndarray | None] = list(knots) if knots is not None else [None] * len(data)
        self.tolerance = [tolerance(b.F) for b in data]
        self.paths: list[BendPath | None] = [None] * len(data)
        self.force: list[np.ndarray | None] = [None] * len(data)
        self.dforce: list[dict | None] = [None] * len(data)
        self.error: list[np.ndarray | None] = [None] * len(data)
        self.nose = [b.d.copy() for b in data]  # nose travel of the model at each row
        self.nose_rate: list[tuple | None] = [None] * len(data)  # (E_s, E_b, dn/dE_s, dn/dE_b) at the knots
        self.match_rate: list[float | None] = [None] * len(data)  # of the Newton steps on n [1/m]
        self.centre: list[bend_centreline.Centreline | None] = [None] * len(data)
        self.evaluations: dict[bytes, tuple] = {}
        self.solves = 0
        self.newton_iterations = 0
        self.cold_runtime_s: float | None = None  # one solve of every curve from scratch

    _KEPT = ("paths", "force", "dforce", "error", "nose", "nose_rate")

    def params(self, x: np.ndarray) -> tuple[float, float]:
        E_s = float(np.exp(x[0]))
        return E_s, float(np.exp(x[1])) if self.fit_E_b else self.E_b

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = np.asarray(x, float).tobytes()
        kept = self.evaluations.get(key)
        if kept is not None:
            r, J, state = kept
            for name, value in zip(self._KEPT, state, strict=True):
                setattr(self, name, list(value))
            return r, J
        t0 = time.perf_counter()
        E_s, E_b = self.params(x)
        names = ("E_s", "E_b", "E_e") if self.jacobian else ()  # back-substitutions on the factorisation
        res, jac = [], []
        for k, b in enumerate(self.data):
            self._rows(k, E_b, E_s, names)
            res.append(self.force[k] - b.F)
            if self.jacobian:
                dF = self.dforce[k]
                cols = [dF["E_s"] * E_s] + ([dF["E_b"] * E_b] if self.fit_E_b else [])
                jac.append(np.column_stack(cols))  # d r / d log p
        r, J = np.concatenate(res), (np.vstack(jac) if self.jacobian else None)
        if self.cold_runtime_s is None:
            self.cold_runtime_s = time.perf_counter() - t0
        self.evaluations[key] = (r, J, tuple(list(getattr(self, name)) for name in self._KEPT))
        return r, J

    def refine(self, x: np.ndarray) -> bool:
        """Knots added where the interpolation error at x exceeds its tolerance (the knots
        were chosen at the first evaluation); True when any were, and x must be fitted again."""
        self.evaluate(x)
        changed = False
        for k, b in enumerate(self.data):
            finer = refine(b.d, self.knots[k], self.error[k], self.tolerance[k])
            if finer is not None:
                self._move_knots(k, finer)
                changed = True
        if changed:
            self.evaluations.clear()
        return changed

    def _move_knots(self, k: int, knots: np.ndarray) -> None:
        self.knots[k] = knots
        self.paths[k] = self.nose_rate[k] = None  # states at other deflections: no warm start

    def _rows(self, k: int, E_b: float, E_s: float, names) -> None:
        """Force and dF/dp at the rows of test k; at its first evaluation the knots are chosen
        (refined until the interpolation error is below the tolerance)."""
        b, fresh = self.data[k], self.knots[k] is None
        if fresh:
            self.knots[k] = start_knots(b.d)
        while True:
            qk = b.d[self.knots[k]]
            path, F, slope, dF = self._path(k, b, self.models[k], E_b, E_s, names)
            force, rows, error = interpolate(qk, F, slope, dF, b.d)
            finer = refine(b.d, self.knots[k], error, self.tolerance[k]) if fresh else None
            if finer is None:
                break
            self._move_knots(k, finer)
        self.force[k], self.dforce[k], self.error[k] = force, rows, error

    def _path(self, k: int, b: BendData, model: BendModel, E_b: float, E_s: float, names):
        """(path, F, dF/dq, dF/dp) at the knots of test k: at the measured nose travel, or for
        centreline data at the nose travel whose centreline deflection is the measured one.

        Centreline: Newton's method on the nose travel of each knot, n <- n + (c - c(n)) / (dc/dn),
        started from the last evaluation's nose travel moved by dn/dp (first order); its last step
        may be taken to first order in F (:data:`CENTRELINE_MATCH`).
        """
        knots = self.knots[k]
        if not b.centreline:
            path = self._solve_path(k, model, E_b, E_s, names, b.d[knots])
            return path, path.force, path.dforce_dd, path.dforce
        target, nose = b.d[knots], self.nose[k][knots]
        if self.nose_rate[k] is not None:
            E_s0, E_b0, dn_s, dn_b = self.nose_rate[k]
            nose = np.maximum.accumulate(np.maximum(nose + dn_s * (E_s - E_s0) + dn_b * (E_b - E_b0), 0.0))
        if self.centre[k] is None:
            self.centre[k] = bend_centreline.Centreline(model)
        tol, last = CENTRELINE_MATCH * target[-1], None
        for _ in range(8):
            path = self._solve_path(k, model, E_b, E_s, names, nose)
            c, slope, grads = bend_centreline.centreline_path(self.centre[k], path)
            miss, rising = target - c, bool(np.all(slope > 0))
            size = float(np.max(np.abs(miss)))
            if last:  # this miss came from a Newton step on the last one: miss' = rate miss^2
                self.match_rate[k] = size / last**2
            rate = self.match_rate[k]
            distinct = nose.size > 1 and bool(np.all(np.diff(nose) > 0))
            if size <= tol or (rising and distinct and rate is not None and rate * size**2 <= tol):
                dF, dn = bend_centreline.at_fixed_centreline(model, path, E_b, slope, grads)
                self.nose_rate[k] = (E_s, E_b, dn["E_s"], dn["E_b"])
                if size <= tol:
                    self.nose[k] = np.interp(b.d, target, nose)
                    return path, path.force, path.dforce_dd / slope, dF
                return self._step_on(k, b, path, nose, miss / slope, slope, dF)
            if not rising:
                break
            nose, last = np.maximum.accumulate(np.maximum(nose + miss / slope, 0.0)), size
        raise FitError(
            f"{b.measurement.test.file.name}: the centreline deflection of the model did not match"
        )

    def _step_on(self, k: int, b: BendData, path: BendPath, nose, shift, slope, dF: dict):
        """The result of :meth:`_path` one Newton step ``shift`` on the nose travel further, to first
        order: F + dF/dn shift, and dF/dp moved along the path by the derivative in n of its
        cubic spline through the knots (the path is at these stiffnesses)."""
        self.nose[k] = np.interp(b.d, b.d[self.knots[k]], nose + shift)
        moved = {}
        if dF:
            rates = CubicSpline(nose, np.column_stack(list(dF.values())))(nose, 1)
            moved = {p: v + rates[:, j] * shift for j, (p, v) in enumerate(dF.items())}
        return path, path.force + path.dforce_dd * shift, path.dforce_dd / slope, moved

    def _solve_path(self, k: int, model: BendModel, E_b: float, E_s: float, names, nose) -> BendPath:
        path = model.solve(E_b, E_s, self.E_e, nose, sensitivities=names, start=self.paths[k])
        self.paths[k] = path
        self.solves += 1
        self.newton_iterations += path.newton_iterations
        return path

    def interpolation(self) -> list[dict]:
        """Per test: rows, knots (solved points), and the interpolation error's estimate and bound [N]."""
        return [
            {
                "rows": int(b.d.size),
                "knots": int(k.size),
                "error_N": float(np.max(e)),
                "tolerance_N": float(t),
            }
            for b, k, e, t in zip(self.data, self.knots, self.error, self.tolerance, strict=True)
        ]

    def sensitivity(self, name: str) -> np.ndarray:
        """dF/dp at the rows at the last evaluation for any stiffness, stacked over tests."""
        return np.concatenate([dF[name] for dF in self.dforce])


def fe_error(problem: Problem, x: np.ndarray, data, E_e: float, fit_E_b: bool) -> tuple[float, list]:
    """Richardson estimate of the relative error of E_s from a solve at half the elements.

    The coarse solve runs on every third knot of each curve (and its last), where the fine
    forces are solved too: enough to map the force error into E_s, a third of the cost. Returns the
    error and the two mesh levels as (elements, estimated error of E_s, run time
    of one cold solve of all curves) - the coarse time scaled to all points.
    """
    r, J = problem.evaluate(x)
    picks = [k[np.unique(np.r_[np.arange(0, k.size, 3), k.size - 1])] for k in problem.knots]
    sub = [replace(b, d=b.d[k], F=b.F[k]) for b, k in zip(data, picks, strict=True)]
    elements = max(problem.models[0].elements // 2, 2)
    every_row = [np.arange(k.size) for k in picks]  # the coarse forces at the picked knots, solved
    coarse = Problem(
        sub, problem.E_b, E_e, fit_E_b=fit_E_b, elements=elements, jacobian=False, knots=every_row
    )
    coarse.nose = [n[k] for n, k in zip(problem.nose, picks, strict=True)]  # centreline: the fine mesh's
    coarse.match_rate = list(problem.match_rate)  # and its rate of the Newton steps on the nose travel
    r_coarse, _ = coarse.evaluate(x)
    scale = sum(k.size for k in problem.knots) / sum(b.d.size for b in sub)
    offsets = np.cumsum([0] + [b.d.size for b in data[:-1]])
    rows = np.concatenate([o + k for o, k in zip(offsets, picks, strict=True)])
    dF = (r[rows] - r_coarse) / (2.0**ORDER - 1.0)  # error of the fine forces at those points
    dx, *_ = np.linalg.lstsq(J[rows], dF, rcond=None)
    error = float(abs(dx[0]))
    levels = [
        {"elements": p.models[0].elements, "discretization_error": e, "runtime_s": t}
        for p, e, t in (
            (coarse, error * 2.0**ORDER, coarse.cold_runtime_s * scale),
            (problem, error, problem.cold_runtime_s),
        )
    ]
    return error, levels


def span_fits(joint: Problem, x: np.ndarray, E_b: float, spans) -> list[dict]:
    """E_s of each span alone (E_b held at the joint value, the joint mesh and knots), for the
    consistency test; started at the joint x from the joint fit's paths of these tests (warm)."""
    if len(spans) < 2:
        return []
    rows, data, elements = [], joint.data, joint.models[0].elements
    for S in spans:
        idx = [k for k, b in enumerate(data) if b.geometry.span == S]
        group = [data[k] for k in idx]
        knots = [joint.knots[k] for k in idx]
        problem = Problem(group, E_b, joint.E_e, fit_E_b=False, elements=elements, knots=knots)
        problem.paths = [joint.paths[k] for k in idx]
        problem.nose = [joint.nose[k].copy() for k in idx]
        problem.nose_rate = [joint.nose_rate[k] for k in idx]
        x_span = least_squares(problem, x[:1])
        r, J = problem.evaluate(x_span)
        sd = float(np.sqrt(statistics(r, J, [b.d.size for b in group]).cov[0, 0]))
        rows.append({"span": S, "span_mm": 1e3 * S, "E_s": float(np.exp(x_span[0])), "sd_log": sd})
    return rows
