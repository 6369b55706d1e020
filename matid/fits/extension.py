r"""Standard linear solid (extension test): responses and the joint fit (physics.md section 1).

A spring k1 in parallel with a Maxwell arm (spring k2 in series with a dashpot eta),
in force units against engineering strain eps, from rest::

    F(t) = k1 eps(t) + f2(t),      f2' + (k2/eta) f2 = k2 eps'(t),      f2(0) = 0

Relaxation time tau = eta / k2. For a strain history that is linear between samples
(rate r_i on [t_{i-1}, t_i], dt_i = t_i - t_{i-1}) the update is exact::

    a_i  = exp(-dt_i / tau)
    f2_i = a_i f2_{i-1} + eta r_i (1 - a_i)

and for a constant-rate ramp eps = r t::

    F = k1 r t + eta r (1 - exp(-t / tau))

The slope dF/deps tends to k1 once t >> tau, so the static extension stiffness is
E_e = k1. k2 and eta are identifiable only when tau lies inside the observed time
window of some run; otherwise the fit says so instead of printing a bare number.

The fit (:func:`fit_extension`) is a joint weighted least-squares fit over all runs of
one specimen in log-parameters ``log(k / k_start)`` (positive, well scaled). Starts come
from variable projection: for fixed tau the model is linear in (k1, eta), so a grid of
tau over the observed window is solved by non-negative least squares and the best
local minima seed lmfit.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import lmfit
import numpy as np
from scipy import optimize
from scipy import stats as sstats

from matid.errors import DataError, FitError
from matid.fits import prony, stats
from matid.fits.sls import History, sls_force, sls_ramp  # noqa: F401  (sls_force, sls_ramp: public here too)
from matid.results import Estimate, Series, TestFit

if TYPE_CHECKING:
    from matid.ingest import Measurement

#: Names ``fixed`` may use, and the SLS parameter each one fixes.
_FIXED_NAMES = {"E_e": "k1", "sls_k1": "k1", "sls_k2": "k2", "sls_eta": "eta"}
_PARAM_NAMES = {"k1": "sls_k1", "k2": "sls_k2", "eta": "sls_eta"}
#: Identifiability thresholds (see :func:`_unidentifiable`).
_MIN_TAU_SAMPLES = 3.0
_MAX_TAU_RUNS = 5.0
_MAX_CORR = 0.98
_MAX_REL_STDERR = 0.5


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class _Run:
    """One extension run in SI: time, strain, force, and a model-free noise level."""

    name: str
    t: np.ndarray
    eps: np.ndarray
    force: np.ndarray
    noise: float  # from second differences, before any fit
    rate: float  # typical |strain rate| while straining [1/s]
    window: np.ndarray  # rows inside the test's window
    used: np.ndarray  # rows whose residuals enter the fit (the model runs over all rows)
    left_out: Mapping[str, int] = field(default_factory=dict)  # reason -> rows

    @functools.cached_property
    def history(self) -> History:
        return History(self.t, self.eps)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def dt(self) -> float:
        return float(np.median(np.diff(self.t)))


def difference_noise(y: np.ndarray) -> float:
    """Model-free noise level: ``1.4826 MAD(second differences) / sqrt(6)``.

    Second differences remove a smooth signal; MAD ignores kinks (ramp ends).
    """
    d2 = np.diff(np.asarray(y, dtype=float), 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def _unique(runs: list[_Run]) -> list[_Run]:
    """Runs with distinct names (files of the same name in different folders get #2, #3)."""
    seen: dict[str, int] = {}
    out = []
    for run in runs:
        seen[run.name] = seen.get(run.name, 0) + 1
        name = run.name if seen[run.name] == 1 else f"{run.name} #{seen[run.name]}"
        out.append(replace(run, name=name))
    return out


def _run(m: Measurement) -> _Run:
    table, test = m.table, m.test
    name = Path(table.path).name
    for column in ("time", "force"):
        if column not in table:
            raise DataError(f"extension test needs a '{column}' column", file=table.path)
    if "strain" in table:
        eps = np.asarray(table["strain"], dtype=float)
    elif "elongation" in table:
        eps = np.asarray(table["elongation"], dtype=float) / test.params["gauge_length"]
    else:
        raise DataError("extension test needs a 'strain' or 'elongation' column", file=table.path)
    t = np.asarray(table["time"], dtype=float)
    force = np.asarray(table["force"], dtype=float)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(eps)) and np.all(np.isfinite(force))):
        raise DataError("time, strain and force must be finite in every row", file=table.path)
    if t.size < 5:
        raise FitError(f"{name}: only {t.size} samples; an extension run needs at least 5")
    if np.any(np.diff(t) <= 0):
        row = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise DataError("time must increase strictly", file=table.path, row=row, column="time")
    if np.ptp(eps) <= 0 or np.ptp(force) <= 0:
        raise FitError(f"{name}: strain or force does not change; nothing to fit")
    r = np.abs(np.diff(eps) / np.diff(t))
    rate = float(np.median(r[r > 0.1 * r.max()]))
    noise = difference_noise(force) or 1e-9 * float(np.max(np.abs(force)))
    used = np.asarray(m.in_window(), dtype=bool)
    if used.sum() < 5:
        raise DataError(f"only {int(used.sum())} rows inside the window; a fit needs 5", file=table.path)
    outside = {"outside the window": int((~used).sum())} if not used.all() else {}
    # provisionally slack: near zero after the strip was loaded; the fit then decides
    loaded = np.cumsum(force > 0.1 * float(np.max(force))) > 0
    provisional = used & loaded & _near_zero(force, noise)
    if provisional.any() and (used & ~provisional).sum() >= 5:
        outside[SLACK] = int(provisional.sum())
        return _Run(name, t, eps, force, noise, rate, used, used & ~provisional, outside)
    return _Run(name, t, eps, force, noise, rate, used, used, outside)


def _near_zero(force: np.ndarray, noise: float) -> np.ndarray:
    """Rows whose force is within 3 noise plus 2 % of the run's peak of zero, or below."""
    return force < 3.0 * noise + 0.02 * float(np.max(np.abs(force)))


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

#: Log-parameters may move this far (natural log) from their start: a factor of ~1e8.
_LOG_BOUND = 18.0
_ORDER = ("k1", "k2", "eta")


def _params(start: Mapping[str, float], ref: Mapping[str, float], fixed: Mapping[str, float]):
    """lmfit parameters x = log(k / k_ref): positive and of order one whatever the SI scale."""
    params = lmfit.Parameters()
    for name in _ORDER:
        value = math.log(fixed.get(name, start[name]) / ref[name])
        params.add(name, value=value, vary=name not in fixed, min=-_LOG_BOUND, max=_LOG_BOUND)
    return params


def _values(params: lmfit.Parameters, ref: Mapping[str, float]) -> dict[str, float]:
    return {name: ref[name] * math.exp(params[name].value) for name in _ORDER}


def _models(runs: Sequence[_Run], k: Mapping[str, float]) -> list[np.ndarray]:
    return [run.history.force(k["k1"], k["k2"], k["eta"]) for run in runs]  # = sls_force(run.t, run.eps, ...)


def _residual(params, runs, sigma, ref) -> np.ndarray:
    """Weighted residuals (F_model - F) / sigma_run over all runs."""
    models = _models(runs, _values(params, ref))
    return np.concatenate(
        [(f - run.force)[run.used] / s for f, run, s in zip(models, runs, sigma, strict=True)]
    )


def _minimise(runs, sigma, starts, ref, fixed) -> tuple[lmfit.Minimizer, lmfit.minimizer.MinimizerResult]:
    """Least squares from each start; the lowest chi-square wins."""
    best = None
    for start in starts:
        minimizer = lmfit.Minimizer(
            _residual, _params(start, ref, fixed), fcn_args=(runs, sigma, ref), nan_policy="raise"
        )
        try:
            result = minimizer.minimize(method="leastsq")
        except ValueError as exc:  # NaN in the residuals
            raise FitError(f"the SLS model could not be evaluated: {exc}") from exc
        if best is None or result.chisqr < best[1].chisqr:
            best = (minimizer, result)
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
    minimizer, result = _minimise(runs, sigma, starts, ref, fixed)
    for _ in range(3):  # slack rows bend the fit; leave them out and look again
        slack = _slack(runs, _values(result.params, ref))
        if all(np.array_equal(a.used, b.used) for a, b in zip(runs, slack, strict=True)):
            break
        runs = slack
        minimizer, result = _minimise(runs, sigma, [_values(result.params, ref)], ref, fixed)
    for _ in range(reweight):
        sigma = _run_noise(result, runs, sigma)
        if not np.all(sigma > 0):
            break  # an exact fit: keep the weights
        minimizer, result = _minimise(runs, sigma, [_values(result.params, ref)], ref, fixed)
    if not result.success or not np.all(np.isfinite(result.residual)):
        raise FitError(f"the SLS least-squares fit did not converge: {result.message}")
    return runs, minimizer, result, ref, sigma


#: Why slack rows are left out (a key of ``_Run.left_out`` and ``info["left_out"]``).
SLACK = "slack strip (force about 0 while the model would push)"


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


# --------------------------------------------------------------------------- uncertainty


def _covariance_fit(runs, sigma, minimizer, result, ref, fixed):
    """The fit whose covariance gives the standard errors.

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


def _sandwich(result, runs, sigma, ref, se):
    """Standard errors from the AR(1) sandwich covariance of :mod:`matid.fits.stats`.

    Dense extension records have correlated residuals (and a misfit looks the same):
    the i.i.d. errors of lmfit then shrink with the sampling rate, not with the
    information. The Jacobian of the weighted residuals in the log-parameters is taken
    by central differences. Returns (se, covariance); the covariance is None (and se
    unchanged) when a parameter has no error.
    """
    names = [n for n in _ORDER if result.params[n].vary]
    if not names or any(se[n] is None for n in names):
        return se, None
    h = 1e-6
    columns = []
    for name in names:
        up, down = result.params.copy(), result.params.copy()
        up[name].value += h
        down[name].value -= h
        columns.append((_residual(up, runs, sigma, ref) - _residual(down, runs, sigma, ref)) / (2 * h))
    try:
        cov = stats.ar1_covariance(
            np.column_stack(columns), result.residual, [int(r.used.sum()) for r in runs]
        )
    except (ValueError, np.linalg.LinAlgError):
        return se, None
    k = _values(result.params, ref)
    out = dict(se)
    for name, se_log in zip(names, cov.stderr, strict=True):
        out[name] = k[name] * float(se_log)
    return out, cov


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


def _wald_log(value: float, se: float, tq: float) -> tuple[float, float]:
    """value * exp(-+ t se/value): the Wald interval of log k, positive by construction."""
    return value * math.exp(-tq * se / value), value * math.exp(tq * se / value)


def _profile(minimizer, result, ref, names: Sequence[str]) -> dict[str, tuple[float, float]]:
    """95 % profile-likelihood intervals (lmfit conf_interval, F-test = t on nfree dof)."""
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
    """95 % intervals: (low, high, method) per fitted parameter.

    k1 enters F linearly: a t-interval. k2 and eta act through exp(-t k2/eta), so the
    chi-square is not quadratic in them; when they are identifiable their interval is the
    profile likelihood, else (or if profiling fails) the t-interval of log k.
    """
    k = _values(result.params, ref)
    tq = float(sstats.t.ppf(0.975, max(dof, 1.0)))
    out = {}
    for name in _ORDER:
        if se[name] is not None:
            if name == "k1":
                out[name] = (k[name] - tq * se[name], k[name] + tq * se[name], "t")
            else:
                out[name] = (*_wald_log(k[name], se[name], tq), "t-log")
    if profile:
        names = [n for n in ("k2", "eta") if result.params[n].vary and se[n] is not None]
        for name, (low, high) in _profile(minimizer, result, ref, names).items():
            out[name] = (low, high, "profile")
    return out


# --------------------------------------------------------------------------- identifiability


def _unidentifiable(k, se, corr, runs: Sequence[_Run], fixed: Mapping[str, float]) -> list[str]:
    """Why k2 and eta cannot be told apart from these runs (empty list: they can)."""
    if "k2" in fixed and "eta" in fixed:
        return []
    tau = k["eta"] / k["k2"]
    dt = min(run.dt for run in runs)
    longest = max(run.duration for run in runs)
    reasons = []
    if tau < _MIN_TAU_SAMPLES * dt:
        reasons.append(
            f"relaxation time tau = {tau:.3g} s is shorter than {_MIN_TAU_SAMPLES:g} sample "
            f"intervals ({dt:.3g} s) in every run"
        )
    if tau > _MAX_TAU_RUNS * longest:
        reasons.append(
            f"relaxation time tau = {tau:.3g} s is longer than {_MAX_TAU_RUNS:g} x the longest "
            f"run ({longest:.3g} s)"
        )
    r = corr.get("sls_k2|sls_eta")
    if r is not None and abs(r) > _MAX_CORR:
        reasons.append(f"k2 and eta are correlated (r = {r:.3f})")
    for name in ("k2", "eta"):
        if name in fixed:
            continue
        if se[name] is None:
            reasons.append(f"no standard error for {_PARAM_NAMES[name]} (singular fit)")
        elif se[name] > _MAX_REL_STDERR * k[name]:
            reasons.append(f"{_PARAM_NAMES[name]} relative standard error {se[name] / k[name]:.0%}")
    return reasons


def _k1_warnings(k, se, runs: Sequence[_Run], unresolved: bool) -> tuple[str, ...]:
    """Cautions on E_e = k1: a relaxation slower than the runs would hide in it."""
    tau = k["eta"] / k["k2"]
    longest = max(run.duration for run in runs)
    dashpot = tau < _MIN_TAU_SAMPLES * min(run.dt for run in runs)  # k1 is then clean
    out = []
    if tau > _MAX_TAU_RUNS * longest or (unresolved and not dashpot):
        out.append(
            f"no relaxation is resolved within the runs (longest {longest:.3g} s): E_e is the "
            "stiffness on that time scale and includes any slower-relaxing part; add a slower "
            "run or a hold to confirm it"
        )
    if se["k1"] is None or se["k1"] > _MAX_REL_STDERR * k["k1"]:
        out.append("E_e is poorly determined (relative standard error above 50 %)")
    return tuple(out)


# --------------------------------------------------------------------------- the fit


def _fixed(fixed: Mapping[str, float]) -> dict[str, float]:
    """``fixed`` by SLS name (k1, k2, eta), validated."""
    out: dict[str, float] = {}
    for key, value in fixed.items():
        if key not in _FIXED_NAMES:
            raise ValueError(f"fixed: unknown parameter {key!r} (one of {', '.join(_FIXED_NAMES)})")
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"fixed: {key} must be positive and finite, got {value}")
        name = _FIXED_NAMES[key]
        if name in out and not math.isclose(out[name], value, rel_tol=1e-12):
            raise ValueError("fixed: E_e and sls_k1 are the same parameter but differ")
        out[name] = float(value)
    return out


def _estimate(parameter, name, k, se, ci, n, fixed, warn=()) -> Estimate:
    if name in fixed:
        return Estimate(parameter, k[name], None, None, n, "fixed")
    low, high, how = ci.get(name, (None, None, None))
    return Estimate(
        parameter,
        k[name],
        se[name],
        None if low is None else (low, high),
        n,
        "sls",
        tuple(warn),
        {"ci_method": how},
    )


def _series(runs: Sequence[_Run], models: Sequence[np.ndarray]) -> tuple[Series, ...]:
    return tuple(
        Series(f"{run.name}, strain rate {run.rate:.3g} 1/s", run.eps, run.force, f, run.used)
        for run, f in zip(runs, models, strict=True)
    )


def _info(runs, models, k, sigma, nfree: int) -> dict[str, object]:
    """Fit summary. reduced_chi2 is measured against the model-free (second-difference)
    noise, not the residual noise used as weights, so values well above 1 flag misfit.
    ``plot_data["force_time"]`` holds, per run, time, measured and model force and the
    rows used, for a force-against-time figure of ramp-hold and relaxation runs."""
    chi2 = sum(
        float(np.sum(((f - run.force)[run.used] / run.noise) ** 2))
        for f, run in zip(models, runs, strict=True)
    )
    return {
        "tau_s": k["eta"] / k["k2"],
        "time_window_s": [min(run.dt for run in runs), max(run.duration for run in runs)],
        "reduced_chi2": chi2 / nfree,
        "noise_N": {run.name: float(s) for run, s in zip(runs, sigma, strict=True)},
        "n_runs": len(runs),
        "left_out": {run.name: dict(run.left_out) for run in runs if run.left_out},
        "plot_data": {
            "force_time": {
                run.name: {"time_s": run.t, "force_N": run.force, "model_N": f, "used": run.used}
                for run, f in zip(runs, models, strict=True)
            }
        },
    }


_ADVICE = (
    "Check the fit plots; a model with more arms (prony_*) or a window on the part the model "
    "follows may describe the runs"
)


def _misfit(result, runs, cov) -> tuple[stats.LackOfFit, str | None]:
    """Lack of fit of the SLS on the weighted residuals, and its warning (None if it fits)."""
    lof = stats.lack_of_fit(result.residual, result.nvarys, segments=[int(r.used.sum()) for r in runs])
    widening = float(np.max(cov.inflation)) if cov is not None else None
    return lof, lof.warning("the standard linear solid", widening, _ADVICE)


def _prony(runs, sigma, k, fixed_k):
    """The Prony comparison: (choice or None, extra estimates, E_e warning, sls warning)."""
    if fixed_k:
        return None, (), None, None
    data = [prony.Data(r.t, r.eps, r.force, r.used, float(s)) for r, s in zip(runs, sigma, strict=True)]
    choice = prony.choose(data)
    if choice is None or choice.best == 1:
        return choice, (), None, None
    longest = max(run.duration for run in runs)
    estimates, e_e, sls = prony.preferred(choice, k["k1"], longest)
    return choice, estimates, e_e, sls


def fit_extension(
    measurements: Sequence[Measurement], *, specimen: str, fixed: Mapping[str, float] = {}
) -> TestFit:
    """Joint SLS fit of all extension runs of one specimen: E_e = k1, k2, eta with 95 % intervals,
    and beside it the Prony model BIC prefers (:mod:`matid.fits.prony`).

    Residuals of run j are weighted by 1/sigma_j, its own noise estimated from its
    residuals; only rows inside the window and not slack enter (the model runs over
    every row: it has a memory). Intervals are the AR(1) sandwich of
    :mod:`matid.fits.stats`. ``fixed`` may hold any of E_e (= sls_k1), sls_k2, sls_eta.
    """
    fixed_k = _fixed(fixed)
    if not measurements:
        raise FitError(f"specimen {specimen}: no extension runs to fit")
    if len(fixed_k) == 3:
        raise FitError(f"specimen {specimen}: k1, k2 and eta are all fixed; nothing to fit")
    runs = _unique([_run(m) for m in measurements])
    runs, minimizer, result, ref, sigma = _solve(runs, fixed_k)
    minimizer, result = _covariance_fit(runs, sigma, minimizer, result, ref, fixed_k)
    k = _values(result.params, ref)
    se, cov = _sandwich(result, runs, sigma, ref, _stderr(result, ref))
    corr = _correlation(result)
    reasons = _unidentifiable(k, se, corr, runs, fixed_k)
    correlated = cov is not None and cov.rho > 0
    dof = cov.dof if cov is not None else result.nfree
    ci = _intervals(minimizer, result, ref, se, profile=not reasons and not correlated, dof=dof)
    n = int(result.ndata)
    lof, misfit = _misfit(result, runs, cov)
    choice, prony_estimates, prony_e_e, prony_sls = _prony(runs, sigma, k, fixed_k)
    why = [f"k2 and eta are not identifiable from the rates given: {'; '.join(reasons)}"] if reasons else []
    sls_warn = [w for w in (misfit, prony_sls) if w]
    k1_warn = list(_k1_warnings(k, se, runs, bool(reasons))) if "k1" not in fixed_k else []
    e_e = _estimate("E_e", "k1", k, se, ci, n, fixed_k, [*k1_warn, *sls_warn])
    if prony_estimates:
        k0 = prony_estimates[0]
        e_e = replace(k0, parameter="E_e", warnings=(prony_e_e, *k0.warnings))
    estimates = (
        e_e,
        _estimate("sls_k1", "k1", k, se, ci, n, fixed_k, [*k1_warn, *sls_warn]),
        _estimate("sls_k2", "k2", k, se, ci, n, fixed_k, [*why, *sls_warn]),
        _estimate("sls_eta", "eta", k, se, ci, n, fixed_k, [*why, *sls_warn]),
        *prony_estimates,
    )
    models = _models(runs, k)
    info = _info(runs, models, k, sigma, result.nfree)
    info["lack_of_fit"] = lof.as_info()
    info["n_effective"] = cov.n_eff if cov is not None else float(n)
    info["interval_widening"] = float(np.max(cov.inflation)) if cov is not None else 1.0
    if choice is not None:
        info["model_choice"] = {"arms_preferred": choice.best, **choice.table()}
    return TestFit(
        kind="extension",
        specimen=specimen,
        tests=tuple(m.test for m in measurements),
        estimates=estimates,
        series=_series(runs, models),
        x_label="strain [1]",
        y_label="force [N]",
        correlation=corr,
        info=info,
    )
