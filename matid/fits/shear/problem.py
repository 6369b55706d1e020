"""The E_s fit's least-squares problem: residuals and Jacobian from the bend model, and the solver.

:class:`Problem` solves every bend test's path at given (log E_s[, log E_b]) and
keeps each evaluation with its paths, the warm starts of the next.
:func:`least_squares` is Levenberg-Marquardt on those log stiffnesses, stopping on
the Gauss-Newton step it would take next. See :mod:`matid.fits.shear.fit` for the model.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from matid.errors import ConvergenceError, FitError
from matid.fits.shear import centreline as bend_centreline
from matid.rod.bend import BendModel, BendPath

if TYPE_CHECKING:
    from matid.fits.shear.fit import BendData


class Problem:
    """Residuals and Jacobian of the bend fit, with the paths of every evaluation kept.

    Each evaluation is kept with its paths (a fit makes a handful): returning to an
    earlier x costs nothing, and the paths of the last x asked for are ``paths``,
    the warm starts of the next solve. ``dforce[k]``: dF/dp of test k at its rows
    (for centreline tests at fixed centreline deflection, :mod:`matid.fits.shear.centreline`).
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
    ):
        self.data, self.E_b, self.E_e, self.fit_E_b = data, E_b, E_e, fit_E_b
        self.jacobian = jacobian or any(b.centreline for b in data)  # False: residuals only (J is None)
        self.models = [BendModel(b.geometry, elements=elements) for b in data]
        self.paths: list[BendPath | None] = [None] * len(data)
        self.dforce: list[dict | None] = [None] * len(data)
        self.nose = [b.d.copy() for b in data]  # nose travel of the model at each row
        self.nose_rate: list[tuple | None] = [None] * len(data)  # (E_s, E_b, dn/dE_s, dn/dE_b)
        self.centre: list[bend_centreline.Centreline | None] = [None] * len(data)
        self.evaluations: dict[bytes, tuple] = {}
        self.solves = 0
        self.newton_iterations = 0
        self.cold_runtime_s: float | None = None  # one solve of every curve from scratch

    def params(self, x: np.ndarray) -> tuple[float, float]:
        E_s = float(np.exp(x[0]))
        return E_s, float(np.exp(x[1])) if self.fit_E_b else self.E_b

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = np.asarray(x, float).tobytes()
        kept = self.evaluations.get(key)
        if kept is not None:
            r, J, paths, dforce, nose, rates = kept
            self.paths, self.dforce, self.nose, self.nose_rate = (
                list(paths),
                list(dforce),
                list(nose),
                list(rates),
            )
            return r, J
        t0 = time.perf_counter()
        E_s, E_b = self.params(x)
        names = ("E_s", "E_b", "E_e") if self.jacobian else ()  # back-substitutions on the factorisation
        res, jac = [], []
        for k, (b, model) in enumerate(zip(self.data, self.models, strict=True)):
            path = self._path(k, b, model, E_b, E_s, names)
            res.append(path.force - b.F)
            if self.jacobian:
                dF = self.dforce[k]
                cols = [dF["E_s"] * E_s] + ([dF["E_b"] * E_b] if self.fit_E_b else [])
                jac.append(np.column_stack(cols))  # d r / d log p
        r, J = np.concatenate(res), (np.vstack(jac) if self.jacobian else None)
        if self.cold_runtime_s is None:
            self.cold_runtime_s = time.perf_counter() - t0
        self.evaluations[key] = (
            r,
            J,
            list(self.paths),
            list(self.dforce),
            list(self.nose),
            list(self.nose_rate),
        )
        return r, J

    def _path(self, k: int, b: BendData, model: BendModel, E_b: float, E_s: float, names) -> BendPath:
        """The solved path at the rows of test k: at the measured nose travel, or for centreline
        data at the nose travel whose centreline deflection is the measured one.

        Centreline: Newton's method on the nose travel of each row, n <- n + (d - c(n)) / (dc/dn),
        started from the last evaluation's nose travel moved by dn/dp (first order).
        """
        if not b.centreline:
            path = self._solve_path(k, model, E_b, E_s, names, self.nose[k])
            self.dforce[k] = path.dforce
            return path
        nose = self.nose[k]
        if self.nose_rate[k] is not None:
            E_s0, E_b0, dn_s, dn_b = self.nose_rate[k]
            nose = np.maximum.accumulate(np.maximum(nose + dn_s * (E_s - E_s0) + dn_b * (E_b - E_b0), 0.0))
        if self.centre[k] is None:
            self.centre[k] = bend_centreline.Centreline(model)
        for _ in range(8):
            path = self._solve_path(k, model, E_b, E_s, names, nose)
            self.nose[k] = nose
            c, slope, grads = bend_centreline.centreline_path(self.centre[k], path)
            if np.all(np.abs(c - b.d) <= 1e-9 * b.d[-1]):
                self.dforce[k], dn = bend_centreline.at_fixed_centreline(model, path, E_b, slope, grads)
                self.nose_rate[k] = (E_s, E_b, dn["E_s"], dn["E_b"])
                return path
            if not np.all(slope > 0):
                break
            nose = np.maximum.accumulate(np.maximum(nose + (b.d - c) / slope, 0.0))
        raise FitError(
            f"{b.measurement.test.file.name}: the centreline deflection of the model did not match"
        )

    def _solve_path(self, k: int, model: BendModel, E_b: float, E_s: float, names, nose) -> BendPath:
        path = model.solve(E_b, E_s, self.E_e, nose, sensitivities=names, start=self.paths[k])
        self.paths[k] = path
        self.solves += 1
        self.newton_iterations += path.newton_iterations
        return path

    def sensitivity(self, name: str) -> np.ndarray:
        """dF/dp at the last evaluation for any stiffness, stacked over tests."""
        return np.concatenate([dF[name] for dF in self.dforce])


#: Levenberg-Marquardt stops when its Gauss-Newton step in (log E_s[, log E_b]) is below
#: XTOL (1 + |x|) (MINPACK's xtol = 1e-9, used before with scipy's least_squares) or below
#: STAT_FRACTION of each parameter's standard error s sqrt((J^T J)^-1_ii): Gauss-Newton
#: converges quadratically here, so the estimate then moves by less than 1e-4 of its standard
#: error (0.0025 % of a 95 % interval's width) and no solve is spent to refine it further.
XTOL = 1e-9
STAT_FRACTION = 1e-4
MAX_EVALUATIONS = 60


def least_squares(problem: Problem, x0: np.ndarray) -> np.ndarray:
    """Levenberg-Marquardt on the log stiffnesses; returns x with the problem's paths at x.

    The residual is nearly linear in log E_s: Gauss-Newton (no damping) converges in
    3-5 evaluations. Marquardt damping (diag(J^T J)) only after a step that raised the
    cost. Convergence is read off the Gauss-Newton step predicted at the last
    evaluation, so no model solve is spent to confirm it (scipy's least_squares spent
    two per fit: a trial step of 1e-11 and the solve at its best point again).
    """
    x = np.asarray(x0, float).copy()
    try:
        r, J = problem.evaluate(x)
        cost, mu = float(r @ r), 0.0
        for _ in range(MAX_EVALUATIONS):
            A, g = J.T @ J, J.T @ r
            scale = np.diag(A).copy()
            if not (np.all(np.isfinite(A)) and np.all(scale > 0)):
                raise FitError("E_s least squares: the model force does not depend on the fitted stiffness")
            newton_step = np.linalg.solve(A, -g)
            tol = XTOL * (XTOL + float(np.linalg.norm(x)))
            dof = max(r.size - x.size, 1)
            sd = np.sqrt(cost / dof * np.diag(np.linalg.inv(A)))
            if float(np.linalg.norm(newton_step)) <= tol or np.all(np.abs(newton_step) <= STAT_FRACTION * sd):
                return _at(problem, x)
            step = newton_step if mu == 0.0 else np.linalg.solve(A + mu * np.diag(scale), -g)
            r_new, J_new = problem.evaluate(x + step)
            cost_new = float(r_new @ r_new)
            if np.isfinite(cost_new) and cost_new <= cost:
                x, r, J, cost = x + step, r_new, J_new, cost_new
                mu = 0.0 if mu <= 1e-3 else 0.1 * mu
            elif float(np.linalg.norm(step)) <= 10 * tol:  # at the cost's round-off: x is the minimum
                return _at(problem, x)
            else:
                mu = max(1e-3, 10.0 * mu)
    except ConvergenceError as exc:
        raise FitError(f"the bend model did not converge during the fit: {exc}") from exc
    except np.linalg.LinAlgError as exc:  # J^T J singular: the fitted stiffnesses cannot be told apart
        raise FitError(
            f"E_s least squares: the bend data do not determine the fitted stiffnesses ({exc})"
        ) from exc
    raise FitError(f"E_s least squares did not converge in {MAX_EVALUATIONS} evaluations")


def _at(problem: Problem, x: np.ndarray) -> np.ndarray:
    if not np.all(np.isfinite(x)):
        raise FitError("E_s least squares did not converge: the estimate is not finite")
    problem.evaluate(x)  # the paths at the solution (kept: no solve)
    return x
