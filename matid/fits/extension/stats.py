"""Uncertainty of the joint SLS fit (:mod:`matid.fits.extension.fit`): covariance, standard
errors, correlations, 95 % intervals and lack of fit.

Standard errors are taken in the log-parameters and carried to SI by the delta method,
``se(k) = k se(log k)``, then replaced by the AR(1) sandwich of :mod:`matid.fits.stats`
(dense records have correlated residuals). k1 gets a t-interval; k2 and eta, which act
through ``exp(-t k2 / eta)``, a t-interval of log k or, when identifiable, the profile
likelihood.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence

import lmfit
import numpy as np

from matid.fits import stats
from matid.fits.extension.lsq import _ORDER, _PARAM_NAMES, _minimise, _values, n_params, residual

#: Central-difference step of the sandwich's Jacobian in the log-parameters.
_STEP = 1e-6

# --------------------------------------------------------------------------- uncertainty


def _covariance_fit(runs, sigma, minimizer, result, ref, fixed):
    """The fit (Minimizer, MinimizerResult) whose covariance gives the standard errors.

    A singular covariance means a flat direction (tau far below the sampling interval or
    far beyond the runs): k2 is then held where it is, so k1 and eta get errors
    conditional on it and k2 gets none (and is reported as not identifiable).
    """
    if result.errorbars or "k2" in fixed or result.nvarys < 2:
        return minimizer, result
    k = _values(result.params, ref)
    return _minimise(runs, sigma, [k], ref, {**fixed, "k2": k["k2"]})


def _stderr(result, ref: Mapping[str, float]) -> dict[str, float | None]:
    """Standard errors in SI by the delta method: se(k) = k se(log k)."""
    k = _values(result.params, ref)
    out: dict[str, float | None] = {}
    for name in _ORDER:
        se_log = result.params[name].stderr if result.params[name].vary else None
        out[name] = None if se_log is None or not np.isfinite(se_log) else k[name] * se_log
    return out


def jacobian(params: lmfit.Parameters, runs, sigma, ref) -> np.ndarray:
    """d residual / d x over the used rows for the varied x, by central differences of step
    ``_STEP`` on a copy of the lmfit Parameters (a step past a bound stops there, as the
    Parameter clips it)."""
    work, names = params.copy(), [n for n in _ORDER if params[n].vary]

    def at(x: np.ndarray) -> np.ndarray:
        for name, value in zip(names, x, strict=True):
            work[name].value = value
        return residual(work, runs, sigma, ref, True)

    return stats.central_jacobian(at, np.array([params[n].value for n in names]), _STEP)


def _sandwich(result, runs, sigma, ref, se):
    """Standard errors from the AR(1) sandwich covariance of :mod:`matid.fits.stats` on
    :func:`jacobian`, on every used row (also where the fit ran on bin means): lmfit's i.i.d.
    errors would shrink with the sampling rate, not with the information. Returns (se,
    covariance); the covariance is None (and se unchanged) when a parameter has no error.
    """
    names = [n for n in _ORDER if result.params[n].vary]
    if not names or any(se[n] is None for n in names):
        return se, None
    try:
        jac = jacobian(result.params, runs, sigma, ref)
        rows = residual(result.params, runs, sigma, ref, rows=True)
        cov = stats.ar1_covariance(jac, rows, [int(r.used.sum()) for r in runs])
    except (ValueError, np.linalg.LinAlgError):
        return se, None
    k = _values(result.params, ref)
    return {**se, **{name: k[name] * float(s) for name, s in zip(names, cov.stderr, strict=True)}}, cov


def _correlation(result) -> dict[str, float]:
    """Correlations of the fitted parameters, keyed "sls_a|sls_b" (equal to those of the logs
    to first order, since k = k_ref exp(x) scales each axis only)."""
    out = {}
    for i, a in enumerate(_ORDER):
        correl = result.params[a].correl or {}
        for b in _ORDER[i + 1 :]:
            if b in correl:
                out[f"{_PARAM_NAMES[a]}|{_PARAM_NAMES[b]}"] = float(correl[b])
    return out


def _profile(minimizer, result, ref, names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """95 % profile-likelihood intervals in SI: ``lmfit.conf_interval`` (its F-test) on the
    log-parameters; a side lmfit cannot bracket gives no interval."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ci = lmfit.conf_interval(minimizer, result, p_names=list(names), sigmas=[0.95])
    except (lmfit.minimizer.MinimizerException, ValueError, RuntimeError):
        return {}
    out = {}
    for name in names:
        low, high = ci[name][0][1], ci[name][-1][1]
        if np.isfinite(low) and np.isfinite(high):
            out[name] = (ref[name] * math.exp(low), ref[name] * math.exp(high))
    return out


def _intervals(minimizer, result, ref, se, *, profile: bool, dof: float) -> dict[str, tuple]:
    """95 % intervals: ((low, high), method) per fitted parameter (module docstring); the
    profile likelihood, with ``profile`` (k2 and eta identifiable), where lmfit brackets it."""
    k = _values(result.params, ref)
    tq = stats.t95(dof)
    out = {}
    for name in _ORDER:
        if se[name] is not None:
            if name == "k1":
                out[name] = (stats.interval(k[name], se[name], dof), "t")
            else:
                wald = stats.wald_log_interval(k[name], se[name], tq)
                if wald is not None:
                    out[name] = (wald, "t-log")
    if profile:
        names = [n for n in ("k2", "eta") if result.params[n].vary and se[n] is not None]
        for name, interval in _profile(minimizer, result, ref, names).items():
            out[name] = (interval, "profile")
    return out


_ADVICE = (
    "Check the fit plots; a model with more arms (prony_*) or a window on the part the model "
    "follows may describe the runs"
)


def _misfit(result, runs, ref, cov, *, unresolved: bool) -> tuple[stats.LackOfFit, str | None]:
    """Lack of fit of the SLS on the residuals of the used rows, and its warning (None if it fits).

    The residuals are weighted by each run's model-free noise (``run.noise``), not by the residual
    noise the fit was weighted with: that comes from the residuals of the fit before the last and,
    where k2 and eta are not identifiable, moves with where along the flat valley that fit landed
    (0.26 % on one run, which moved the printed reduced chi2 from 7.07 to 7.03 at one landing of
    tests/fits/extension/test_sls_independent.py), while the residuals themselves do not. Where
    they are not identifiable (``unresolved``) the warning does not state by how much the intervals
    were widened for it (``info["interval_widening"]`` does): the factor comes from the Jacobian
    where the fit landed and moves with it (3.0x against 3.1x on two ramps at two rates)."""
    rows = residual(result.params, runs, [run.noise for run in runs], ref, rows=True)
    lof = stats.lack_of_fit(rows, n_params(result.nvarys, runs), segments=[int(r.used.sum()) for r in runs])
    widening = float(np.max(cov.inflation)) if cov is not None and not unresolved else None
    return lof, lof.warning("the standard linear solid", widening, _ADVICE)
