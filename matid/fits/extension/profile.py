r"""Covariance and profile-likelihood intervals of the joint SLS fit, as lmfit defined them.

Both work on the free log-parameters ``x = log(k / k_ref)`` of
:mod:`matid.fits.extension.lsq` (n data, p free parameters, nfree = n - p).

Covariance (lmfit ``leastsq``): with J the Jacobian of the weighted residuals at the
optimum (lmdif's own forward differences, carried from its internal variable to x, see
:func:`matid.fits.extension.lsq._least_squares`) and J = QR::

    cov = (R^T R)^-1 * chi2 / max(nfree, 1),     se_i = sqrt(cov_ii),
    corr_ij = cov_ij / (se_i se_j)

It is singular (no standard errors, no correlations) when R has a zero on its diagonal
(a parameter that does not move the residuals at all); the error bars count as valid
only when every se_i is positive (so finite). The AR(1) sandwich uses a separate
central-difference Jacobian (:func:`jacobian`, step 1e-6, clipped at the bounds). Without valid error bars
:func:`matid.fits.extension.stats._covariance_fit` holds k2 and refits.

Profile likelihood (lmfit ``conf_interval`` with ``sigmas=[0.95]``, the F-test
``f_compare``): for a trial value v of one log-parameter the others are refitted from
the optimum, and::

    prob(v) = F_cdf((chi2(v) / chi2_best - 1) * nfree / 1;  1, nfree)

(F_cdf of a negative argument is 0). The 95 % limits are where prob = 0.95. Each side
is bracketed by stepping out from the optimum by se (or by max(0.2 |x|, 1e-3) when se
is not in (0, |x|)), at most 200 steps and not past x = +-18; the stepping stops without
a bracket when prob grows by less than 1e-5 (relative) in a step. The root is then
found by TOMS 748 (relative tolerance 5e-5, as lmfit). A side without a bracket has no
finite limit, and the parameter gets no profile interval.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from matid.fits.extension.lsq import _LOG_BOUND, _ORDER, LsqFit, _least_squares, _residual, max_nfev
from matid.fits.stats import f_cdf

#: Central-difference step of the Jacobian in the log-parameters.
_STEP = 1e-6
#: Probability level of the profile interval, and lmfit's stepping limits.
_LEVEL = 0.95
_MAX_STEPS = 200
_MIN_REL_CHANGE = 1e-5


@dataclass(frozen=True)
class Uncertainty:
    """Standard errors and correlations of the free log-parameters by name (empty when the
    covariance is singular), and whether the error bars are valid."""

    stderr: dict[str, float]
    correl: dict[str, dict[str, float]]
    errorbars: bool


def jacobian(fit: LsqFit, runs, sigma, ref) -> np.ndarray:
    """d residual / d x for the free x, by central differences; a step past +-18 stops at
    the bound (as lmfit's bounded Parameter clipped the value it was given), over 2 steps."""
    columns = []
    for name in fit.free:
        step = np.zeros(len(_ORDER))
        step[_ORDER.index(name)] = _STEP
        up = _residual(np.clip(fit.x + step, -_LOG_BOUND, _LOG_BOUND), runs, sigma, ref)
        down = _residual(np.clip(fit.x - step, -_LOG_BOUND, _LOG_BOUND), runs, sigma, ref)
        columns.append((up - down) / (2 * _STEP))
    return np.column_stack(columns)


def uncertainty(fit: LsqFit) -> Uncertainty:
    """Standard errors and correlations from the covariance of ``fit`` (module docstring)."""
    if fit.covar is None:
        return Uncertainty({}, {}, False)
    with np.errstate(all="ignore"):
        se = np.sqrt(np.diag(fit.covar))
        corr = fit.covar / np.outer(se, se)
    names = fit.free
    stderr = {name: float(s) for name, s in zip(names, se, strict=True)}
    correl = {a: {b: float(corr[i, j]) for j, b in enumerate(names) if j != i} for i, a in enumerate(names)}
    return Uncertainty(stderr, correl, bool(np.all(se > 0)))


# --------------------------------------------------------------------------- profile


def f_compare(best: LsqFit, trial: LsqFit) -> float:
    """lmfit's F-test: probability that holding one parameter fits worse by chance."""
    nfix = best.nvarys - trial.nvarys
    dchi = trial.chisqr / best.chisqr - 1.0
    return f_cdf(dchi * best.nfree / nfix, nfix, best.nfree)


class _Profile:
    """prob(v) for one parameter, each trial refitted from the optimum and remembered."""

    def __init__(self, best: LsqFit, name: str, runs, sigma, ref):
        self.best, self.name, self.index = best, name, _ORDER.index(name)
        self.others = [n for n in best.free if n != name]
        self.args = (runs, sigma, ref)
        self.cache: dict[float, float] = {}

    def prob(self, value: float) -> float:
        if value not in self.cache:
            x0 = self.best.x.copy()
            x0[self.index] = value
            # lmfit refits with the fit's own Minimizer, whose budget is that of the fit
            trial = _least_squares(x0, self.others, *self.args, budget=max_nfev(self.best.nvarys))
            self.cache[value] = f_compare(self.best, trial)
        return self.cache[value]

    def bracket(self, se: float, direction: int) -> tuple[float, float]:
        """Step out from the optimum until prob >= 0.95 (lmfit's find_limit): (limit, prob)."""
        start = self.best.at(self.name)
        step = se if 0 < se < abs(start) else max(abs(start) * 0.2, 0.001)
        old, limit, bound = 0.0, start, False
        for i in range(1, _MAX_STEPS + 2):
            limit += step * direction
            if abs(limit) > _LOG_BOUND:
                limit, bound = math.copysign(_LOG_BOUND, limit), True
            new = self.prob(limit)
            change = (new - old) / max(new, old, 1e-12)
            old = new
            if new >= _LEVEL or (bound and new < _LEVEL) or i > _MAX_STEPS or change < _MIN_REL_CHANGE:
                break
        return limit, old

    def limit(self, se: float, direction: int) -> float:
        """Where prob = 0.95 on one side, or +-inf when the stepping found no bracket."""
        limit, top = self.bracket(se, direction)
        if _LEVEL > top:
            return direction * math.inf
        low, high = sorted([limit, self.best.at(self.name)])
        sol = optimize.root_scalar(
            lambda v: self.prob(v) - _LEVEL, method="toms748", bracket=(low, high), rtol=0.5e-4
        )
        return sol.root if sol.converged else math.nan


def profile_limits(best: LsqFit, unc: Uncertainty, names: Sequence[str], runs, sigma, ref):
    """name -> (low, high) in the log-parameter, for each name with both limits finite.

    Raises ValueError (as lmfit did) when fewer than two parameters vary or a name has no
    standard error; a refit that cannot be evaluated raises FitError.
    """
    if best.nvarys < 2 or any(unc.stderr.get(n) is None for n in names):
        raise ValueError("profile likelihood: needs two free parameters with standard errors")
    out = {}
    for name in names:
        profile = _Profile(best, name, runs, sigma, ref)
        low, high = profile.limit(unc.stderr[name], -1), profile.limit(unc.stderr[name], 1)
        if np.isfinite(low) and np.isfinite(high):
            out[name] = (low, high)
    return out
