"""The E_s fit's least squares: scipy's trust-region reflective on the log stiffnesses, the paths
of :class:`matid.fits.shear.problem.Problem` serving residuals and Jacobian, and the covariance
of the fitted values."""

from __future__ import annotations

import numpy as np
from scipy import optimize

from matid.errors import ConvergenceError, FitError
from matid.fits.stats import Covariance, ar1_covariance


def statistics(r: np.ndarray, J: np.ndarray, segments) -> Covariance:
    """Covariance of the log parameters under AR(1)-correlated residuals within each file
    (:func:`matid.fits.stats.ar1_covariance`; the textbook one when rho is not significant)."""
    try:
        return ar1_covariance(J, r, segments)
    except np.linalg.LinAlgError as exc:  # J^T J singular: the fitted stiffnesses cannot be told apart
        raise FitError(
            f"E_s least squares: the bend data do not determine the fitted stiffnesses ({exc})"
        ) from exc


#: The log stiffnesses stay within LOG_BOUND of their start (a factor of ~1e8 either way, as the
#: extension fit's log-parameters): bounds on E_s > 0 and E_b > 0 as the other fits set them.
LOG_BOUND = 18.0
MAX_EVALUATIONS = 60
#: The fit ends at an evaluated x whose Gauss-Newton step is below this fraction of each
#: parameter's standard error (of the fit, :func:`statistics`): x is then the minimum to that
#: fraction (the step is the distance to it, to first order), and the path solve that scipy would
#: make at x + step only to see the cost stop falling is saved.
CONVERGED_STEP = 1e-4


class _Converged(Exception):
    """Raised from the Jacobian at an x that is the minimum to :data:`CONVERGED_STEP`."""

    def __init__(self, x: np.ndarray):
        super().__init__()
        self.x = x


def converged(r: np.ndarray, J: np.ndarray, segments) -> bool:
    """Whether the Gauss-Newton step -(J^T J)^-1 J^T r is below CONVERGED_STEP standard errors of
    every parameter (False when they cannot be had: scipy decides)."""
    try:
        se = np.sqrt(np.diag(statistics(r, J, segments).cov))
        step = np.linalg.solve(J.T @ J, -(J.T @ r))
    except (FitError, ValueError, np.linalg.LinAlgError):
        return False
    return bool(np.all(np.isfinite(step)) and np.all(np.abs(step) <= CONVERGED_STEP * se))


def least_squares(problem, x0: np.ndarray) -> np.ndarray:
    """The log stiffnesses minimising the residuals of ``problem`` (a
    :class:`matid.fits.shear.problem.Problem`), by ``scipy.optimize.least_squares``
    (trust-region reflective, bounds LOG_BOUND about x0); returns x with the problem's paths at x.

    Why not lmfit, as the other fits: each residual evaluation here is a finite-element path
    solve, and the Jacobian comes with it from the solver's own sensitivities (one
    back-substitution per knot, :mod:`matid.rod.bend`); lmfit's least-squares wrapper would
    difference the residuals instead (a path solve per parameter per step) and holds no solver
    state between evaluations, while the paths kept by the problem warm-start the next
    solve and serve the Jacobian at the same x for free. The residuals are scaled by the
    largest force (scipy's gtol is absolute); the minimum does not move. Gauss-Newton converges
    in 3-5 evaluations: the residual is nearly linear in log E_s. It stops at the first x whose
    step is below CONVERGED_STEP standard errors (:func:`converged`), or where scipy stops.
    """
    x0 = np.asarray(x0, float)
    lower, upper = x0 - LOG_BOUND, x0 + LOG_BOUND
    scale = max(float(np.max(np.abs(b.F))) for b in problem.data) or 1.0
    segments = [b.d.size for b in problem.data]

    def jacobian(x: np.ndarray) -> np.ndarray:
        r, J = problem.evaluate(x)
        if converged(r, J, segments):
            raise _Converged(np.array(x, float))
        return J / scale

    try:
        out = optimize.least_squares(
            lambda x: problem.evaluate(x)[0] / scale,
            x0,
            jac=jacobian,
            bounds=(lower, upper),
            method="trf",
            max_nfev=MAX_EVALUATIONS,
        )
        x, status, at_bound = out.x, out.status, np.any(out.active_mask != 0)
    except ConvergenceError as exc:
        raise FitError(f"the bend model did not converge during the fit: {exc}") from exc
    except _Converged as stop:  # scipy keeps its iterates strictly inside the bounds
        x, status = stop.x, 1
        at_bound = np.any(np.minimum(x - lower, upper - x) <= 1e-10 * np.maximum(1.0, np.abs(x)))
    if status == 0:
        raise FitError(f"E_s least squares did not converge in {MAX_EVALUATIONS} evaluations")
    if not np.all(np.isfinite(x)):
        raise FitError("E_s least squares did not converge: the estimate is not finite")
    if at_bound:
        raise FitError("E_s least squares ended at a bound: the bend data do not determine the stiffness")
    problem.evaluate(x)  # the paths at the solution (kept: no solve)
    return x
