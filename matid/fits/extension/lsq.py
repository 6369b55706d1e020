"""The joint SLS least squares of :mod:`matid.fits.extension.fit`: starts, minimisation, slack rows.

Parameters are ``x = log(k / k_ref)`` for k in (k1, k2, eta). Starts come from variable
projection: for fixed tau = eta / k2 the model ``F = k1 eps + eta g(t; tau)`` is linear in
(k1, eta), so a grid of tau over the observed window is solved by non-negative least
squares and the best local minima seed the least squares. The fit is then refitted with
slack rows left out and with each run weighted by its own residual noise.

The least squares is Levenberg-Marquardt (MINPACK lmdif, ``scipy.optimize.leastsq``)
run as lmfit's ``leastsq`` ran it, so the answers are lmfit's: column scaling from the
Jacobian, ftol = xtol = 1.5e-8, gtol = 0, forward differences of relative step 1e-5,
on the free log-parameters (the fixed ones held) through MINUIT's transform
x = -B + (sin u + 1) B with B = 18. The transform matters even though x never nears
+-18 in the tests or the demo (|x| < 0.2): it sets lmdif's path, and where the
chi-square is flat (tau outside the window) the path is the answer; unbounded LM
(``least_squares(method="lm")``) moved k2 by 0.3 % and its standard error by 0.2 % in
the fast-relaxation test. From several starts the lowest chi-square wins.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import optimize

from matid.errors import FitError
from matid.fits.extension.runs import SLACK, _near_zero, _Run

_PARAM_NAMES = {"k1": "sls_k1", "k2": "sls_k2", "eta": "sls_eta"}

# --------------------------------------------------------------------------- starts


def _tau_grid(runs: Sequence[_Run], fixed: Mapping[str, float], n: int = 33) -> np.ndarray:
    """Relaxation times to try: log-spaced over the observed window, wider by 10x each side."""
    if "k2" in fixed and "eta" in fixed:
        return np.array([fixed["eta"] / fixed["k2"]])
    low = min(run.dt for run in runs) / 10.0
    high = max(run.duration for run in runs) * 10.0
    return np.geomspace(low, high, n)


def _profile_point(
    runs: Sequence[_Run], sigma: np.ndarray, tau: float, fixed: Mapping[str, float]
) -> tuple[float, float, float]:
    """For fixed tau, F = k1 eps + eta g(t; tau) is linear: solve (k1, eta) >= 0 by NNLS.

    Returns (cost, k1, eta); fixed k1, eta (or eta = k2 tau for fixed k2) are held.
    """
    eps = np.concatenate([run.eps[run.used] / s for run, s in zip(runs, sigma, strict=True)])
    g = np.concatenate(
        [run.history.force(0.0, 1.0 / tau, 1.0)[run.used] / s for run, s in zip(runs, sigma, strict=True)]
    )
    y = np.concatenate([run.force[run.used] / s for run, s in zip(runs, sigma, strict=True)])
    known = {"k1": fixed.get("k1"), "eta": fixed.get("eta")}
    if "k2" in fixed:
        known["eta"] = fixed["k2"] * tau
    columns = {"k1": eps, "eta": g}
    free = [name for name in columns if known[name] is None]
    rhs = y - sum(known[name] * columns[name] for name in columns if known[name] is not None)
    if free:
        coef, cost = optimize.nnls(np.column_stack([columns[name] for name in free]), rhs)
        known.update(zip(free, coef, strict=True))
    else:
        cost = float(np.linalg.norm(rhs))
    return float(cost) ** 2, float(known["k1"]), float(known["eta"])


def _starts(
    runs: Sequence[_Run], sigma: np.ndarray, fixed: Mapping[str, float], n_starts: int = 3
) -> list[dict[str, float]]:
    """Starting points (k1, k2, eta) at the best local minima of the tau profile, best first."""
    taus = _tau_grid(runs, fixed)
    points = [_profile_point(runs, sigma, tau, fixed) for tau in taus]
    cost = np.array([p[0] for p in points])
    padded = np.r_[np.inf, cost, np.inf]
    minima = np.flatnonzero((cost <= padded[:-2]) & (cost <= padded[2:]))
    minima = minima[np.argsort(cost[minima])][:n_starts]
    scale = max(np.ptp(run.force) / np.ptp(run.eps) for run in runs)  # a stiffness [N]
    starts = []
    for i in minima:
        _, k1, eta = points[i]
        k1 = k1 if k1 > 0 else 1e-3 * scale
        eta = eta if eta > 0 else 1e-3 * scale * taus[i]
        starts.append({"k1": float(k1), "k2": float(eta / taus[i]), "eta": float(eta)})
    return starts


# --------------------------------------------------------------------------- least squares

#: Log-parameters live in [-_LOG_BOUND, _LOG_BOUND] (natural log from k_ref: a factor of ~1e8).
_LOG_BOUND = 18.0
_ORDER = ("k1", "k2", "eta")
#: MINPACK lmdif settings (lmfit's leastsq): tolerances on the cost and on x, the squared
#: relative forward-difference step, and the initial step bound.
_LMDIF = {"ftol": 1.5e-8, "xtol": 1.5e-8, "gtol": 0.0, "epsfcn": 1e-10, "factor": 100}
#: lmfit's leastsq evaluates the residuals at most 2000 (n_free + 1) times (its max_nfev).
_NFEV_PER_PARAMETER = 2000


@dataclass(frozen=True)
class LsqFit:
    """One least-squares fit: x = log(k / k_ref) of (k1, k2, eta), the names varied, the
    weighted residuals at x, the covariance of the free x (None if singular) and the
    optimiser's verdict."""

    x: np.ndarray
    free: tuple[str, ...]
    residual: np.ndarray
    covar: np.ndarray | None
    success: bool
    message: str

    @property
    def ndata(self) -> int:
        return int(self.residual.size)

    @property
    def nvarys(self) -> int:
        return len(self.free)

    @property
    def nfree(self) -> int:
        return self.ndata - self.nvarys

    @property
    def chisqr(self) -> float:
        """Weighted residual sum of squares (floored at 1e-250 per point, as lmfit)."""
        return max(float(np.dot(self.residual, self.residual)), 1e-250 * self.ndata)

    def at(self, name: str) -> float:
        return float(self.x[_ORDER.index(name)])


def _log_x(start: Mapping[str, float], ref: Mapping[str, float], fixed: Mapping[str, float]) -> np.ndarray:
    """x = log(k / k_ref): of order one whatever the SI scale; fixed values held."""
    return np.array([math.log(fixed.get(name, start[name]) / ref[name]) for name in _ORDER])


def _values(fit: LsqFit | np.ndarray, ref: Mapping[str, float]) -> dict[str, float]:
    x = fit.x if isinstance(fit, LsqFit) else fit
    return {name: ref[name] * math.exp(float(v)) for name, v in zip(_ORDER, x, strict=True)}


def _models(runs: Sequence[_Run], k: Mapping[str, float]) -> list[np.ndarray]:
    return [run.history.force(k["k1"], k["k2"], k["eta"]) for run in runs]  # = sls_force(run.t, run.eps, ...)


def _residual(x: np.ndarray, runs, sigma, ref) -> np.ndarray:
    """Weighted residuals (F_model - F) / sigma_run over all runs; FitError on NaN."""
    models = _models(runs, _values(np.asarray(x), ref))
    out = np.concatenate(
        [(f - run.force)[run.used] / s for f, run, s in zip(models, runs, sigma, strict=True)]
    )
    if np.isnan(np.sum(out)):
        raise FitError("the SLS model could not be evaluated: NaN in the residuals")
    return out


def _external(u: np.ndarray) -> np.ndarray:
    """x of the bounded internal variable u: x = -B + (sin u + 1) B (MINUIT's transform)."""
    return -_LOG_BOUND + (np.sin(u) + 1.0) * (2.0 * _LOG_BOUND) / 2.0


def _internal(x: np.ndarray) -> np.ndarray:
    u = np.arcsin(2.0 * (x + _LOG_BOUND) / (2.0 * _LOG_BOUND) - 1.0)
    return np.where(np.abs(u) < 1e-15, 0.0, u)


class _Abort(Exception):
    """lmfit's AbortFitException: the evaluation budget is spent; ``u`` is the point asked for."""

    def __init__(self, u: np.ndarray) -> None:
        super().__init__("too many function evaluations")
        self.u = u


def max_nfev(nvarys: int) -> int:
    """lmfit's budget of residual evaluations for a leastsq fit of ``nvarys`` parameters."""
    return _NFEV_PER_PARAMETER * (nvarys + 1)


def _least_squares(
    x0: np.ndarray, free: Sequence[str], runs, sigma, ref, budget: int | None = None
) -> LsqFit:
    """Levenberg-Marquardt (MINPACK lmdif) on the free log-parameters, the others held at x0.

    lmdif runs on u with x = _external(u), which keeps x within +-_LOG_BOUND; the
    covariance of x is lmdif's (R^T R)^-1 in u times (dx/du)^2, scaled by chi2 / nfree.
    As lmfit, the fit stops after ``budget`` evaluations (default :func:`max_nfev`; lmdif's
    own maxfev is twice that) at the point it was about to evaluate, without covariance.
    """
    index = [_ORDER.index(name) for name in free]
    budget = max_nfev(len(index)) if budget is None else budget
    calls = 0  # lmfit's nfev + 2: scipy's shape check and lmdif's first call are not counted

    def evaluate(u: np.ndarray) -> np.ndarray:
        x = x0.copy()
        x[index] = _external(u)
        return _residual(x, runs, sigma, ref)

    def fun(u: np.ndarray) -> np.ndarray:
        nonlocal calls
        calls += 1
        if calls - 2 > budget:
            raise _Abort(np.array(u, dtype=float))
        return evaluate(u)

    if not index:
        return LsqFit(x0, (), evaluate(np.zeros(0)), None, True, "nothing to vary")
    try:
        with np.errstate(all="ignore"):
            u, cov, _, _, ier = optimize.leastsq(
                fun, _internal(x0[index]), full_output=True, maxfev=2 * budget, **_LMDIF
            )
    except _Abort as abort:
        u, cov, ier = abort.u, None, -1
    x = x0.copy()
    x[index] = _external(u)
    residual = evaluate(u)
    if cov is not None:
        grad = np.cos(u) * (2.0 * _LOG_BOUND) / 2.0
        redchi = float(np.dot(residual, residual)) / max(1, residual.size - len(index))
        cov = cov * np.outer(grad, grad) * redchi
    return LsqFit(x, tuple(free), residual, cov, ier in (1, 2, 3, 4), _message(ier, cov is not None))


def _message(ier: int, errorbars: bool) -> str:
    """lmfit's MinimizerResult.message for lmdif's ``ier`` (-1: the budget was spent)."""
    if ier in (1, 2, 3):
        message = "Fit succeeded."
    elif ier == 0:
        message = (
            "Invalid Input Parameters. I.e. more variables than data points given, "
            "tolerance < 0.0, or no data provided."
        )
    elif ier == 4:
        message = "One or more variable did not affect the fit."
    else:  # 5 (lmdif's maxfev, past the budget: never reached), 6-8 and the budget's -1
        message = "Tolerance seems to be too small."
    return message if errorbars else f"{message} Could not estimate error-bars."


def _minimise(runs, sigma, starts, ref, fixed) -> LsqFit:
    """Least squares from each start; the lowest chi-square wins."""
    free = [name for name in _ORDER if name not in fixed]
    best = None
    for start in starts:
        fit = _least_squares(_log_x(start, ref, fixed), free, runs, sigma, ref)
        if best is None or fit.chisqr < best.chisqr:
            best = fit
    return best


def _run_noise(result, runs: Sequence[_Run], sigma: np.ndarray) -> np.ndarray:
    """Noise of each run from its own residuals, each run taking its share of the dof."""
    n = np.array([int(run.used.sum()) for run in runs])
    share = 1.0 - result.nvarys / n.sum()
    pieces = np.split(result.residual, np.cumsum(n)[:-1])
    return np.array(
        [s * math.sqrt(np.sum(r**2) / (m * share)) for r, s, m in zip(pieces, sigma, n, strict=True)]
    )


def _solve(runs: Sequence[_Run], fixed: Mapping[str, float], reweight: int = 2):
    """Joint fit: starts from the tau profile, then refits with each run's residual noise."""
    sigma = np.array([run.noise for run in runs])
    starts = _starts(runs, sigma, fixed)
    if not starts:
        raise FitError("no starting point: the relaxation-time profile has no minimum")
    ref = starts[0]
    result = _minimise(runs, sigma, starts, ref, fixed)
    for _ in range(3):  # slack rows bend the fit; leave them out and look again
        slack = _slack(runs, _values(result, ref))
        if all(np.array_equal(a.used, b.used) for a, b in zip(runs, slack, strict=True)):
            break
        runs = slack
        result = _minimise(runs, sigma, [_values(result, ref)], ref, fixed)
    for _ in range(reweight):
        sigma = _run_noise(result, runs, sigma)
        if not np.all(sigma > 0):
            break  # an exact fit: keep the weights
        result = _minimise(runs, sigma, [_values(result, ref)], ref, fixed)
    if not result.success or not np.all(np.isfinite(result.residual)):
        raise FitError(f"the SLS least-squares fit did not converge: {result.message}")
    return runs, result, ref, sigma


def _slack(runs: Sequence[_Run], k: Mapping[str, float]) -> list[_Run]:
    """Runs with their slack rows left out: a strip carries no compression, so where the
    model force is below -3 noise while the measured force stays within 3 noise plus 2 %
    of the run's peak of zero (or below), the strip is slack and the SLS does not apply.
    Rows near zero force after loading start out left out (:func:`_run`): a fit through
    them would not predict the compression that gives them away."""
    out = []
    for run, f in zip(runs, _models(runs, k), strict=True):
        slack = run.window & (f < -3.0 * run.noise) & _near_zero(run.force, run.noise)
        left = {key: v for key, v in run.left_out.items() if key != SLACK}
        if slack.any():
            left[SLACK] = int(slack.sum())
        out.append(replace(run, used=run.window & ~slack, left_out=left))
    return out
