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
from collections.abc import Mapping

import numpy as np

from matid.errors import FitError
from matid.fits import stats
from matid.fits.extension.lsq import _ORDER, _PARAM_NAMES, LsqFit, _minimise, _values
from matid.fits.extension.profile import Uncertainty, jacobian, profile_limits, uncertainty

# --------------------------------------------------------------------------- uncertainty


def _covariance_fit(runs, sigma, result: LsqFit, ref, fixed) -> tuple[LsqFit, Uncertainty]:
    """The fit whose covariance gives the standard errors, and that covariance.

    A singular covariance means a flat direction (tau far below the sampling interval or
    far beyond the runs): k2 is then held where it is, so k1 and eta get errors
    conditional on it and k2 gets none (and is reported as not identifiable).
    """
    unc = uncertainty(result)
    if unc.errorbars or "k2" in fixed or result.nvarys < 2:
        return result, unc
    k = _values(result, ref)
    held = _minimise(runs, sigma, [k], ref, {**fixed, "k2": k["k2"]})
    return held, uncertainty(held)


def _stderr(result: LsqFit, unc: Uncertainty, ref: Mapping[str, float]) -> dict[str, float | None]:
    """Standard errors in SI by the delta method: se(k) = k se(log k)."""
    k = _values(result, ref)
    out: dict[str, float | None] = {}
    for name in _ORDER:
        se_log = unc.stderr.get(name)
        out[name] = None if se_log is None or not np.isfinite(se_log) else k[name] * se_log
    return out


def _sandwich(result: LsqFit, runs, sigma, ref, se):
    """Standard errors from the AR(1) sandwich covariance of :mod:`matid.fits.stats`.

    Dense extension records have correlated residuals (and a misfit looks the same):
    the i.i.d. errors then shrink with the sampling rate, not with the information. The
    Jacobian of the weighted residuals in the log-parameters is the central-difference
    one of :func:`matid.fits.extension.profile.jacobian`. Returns (se, covariance); the
    covariance is None (and se unchanged) when a parameter has no error.
    """
    names = list(result.free)
    if not names or any(se[n] is None for n in names):
        return se, None
    try:
        jac = jacobian(result, runs, sigma, ref)
        cov = stats.ar1_covariance(jac, result.residual, [int(r.used.sum()) for r in runs])
    except (ValueError, np.linalg.LinAlgError):
        return se, None
    k = _values(result, ref)
    out = dict(se)
    for name, se_log in zip(names, cov.stderr, strict=True):
        out[name] = k[name] * float(se_log)
    return out, cov


def _correlation(unc: Uncertainty) -> dict[str, float]:
    """Correlations of the fitted parameters, keyed "sls_a|sls_b" (equal to those of the logs
    to first order, since k = k_ref exp(x) scales each axis only)."""
    out = {}
    for i, a in enumerate(_ORDER):
        correl = unc.correl.get(a, {})
        for b in _ORDER[i + 1 :]:
            if b in correl:
                out[f"{_PARAM_NAMES[a]}|{_PARAM_NAMES[b]}"] = float(correl[b])
    return out


def _profile(result, unc, runs, sigma, ref, names) -> dict[str, tuple[float, float]]:
    """95 % profile-likelihood intervals (:mod:`matid.fits.extension.profile`) in SI."""
    try:
        limits = profile_limits(result, unc, names, runs, sigma, ref)
    except (FitError, ValueError, RuntimeError):
        return {}
    return {
        name: (ref[name] * math.exp(low), ref[name] * math.exp(high)) for name, (low, high) in limits.items()
    }


def _intervals(result, unc, runs, sigma, ref, se, *, profile: bool, dof: float) -> dict[str, tuple]:
    """95 % intervals: (low, high, method) per fitted parameter.

    k1 enters F linearly: a t-interval. k2 and eta act through exp(-t k2/eta), so the
    chi-square is not quadratic in them; when they are identifiable their interval is the
    profile likelihood, else (or if profiling fails) the t-interval of log k.
    """
    k = _values(result, ref)
    tq = stats.t_ppf(0.975, max(dof, 1.0))
    out = {}
    for name in _ORDER:
        if se[name] is not None:
            if name == "k1":
                out[name] = (*stats.interval(k[name], se[name], dof), "t")
            else:
                wald = stats.wald_log_interval(k[name], se[name], tq)
                if wald is not None:
                    out[name] = (*wald, "t-log")
    if profile:
        names = [n for n in ("k2", "eta") if n in result.free and se[n] is not None]
        for name, (low, high) in _profile(result, unc, runs, sigma, ref, names).items():
            out[name] = (low, high, "profile")
    return out


_ADVICE = (
    "Check the fit plots; a model with more arms (prony_*) or a window on the part the model "
    "follows may describe the runs"
)


def _misfit(result, runs, cov) -> tuple[stats.LackOfFit, str | None]:
    """Lack of fit of the SLS on the weighted residuals, and its warning (None if it fits)."""
    lof = stats.lack_of_fit(result.residual, result.nvarys, segments=[int(r.used.sum()) for r in runs])
    widening = float(np.max(cov.inflation)) if cov is not None else None
    return lof, lof.warning("the standard linear solid", widening, _ADVICE)
