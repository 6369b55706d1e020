"""The joint SLS least squares of :mod:`matid.fits.extension.fit`: starts, minimisation, slack rows.

Parameters are lmfit ``Parameters`` x = log(k / k_ref) for k in (k1, k2, eta), bounded at
+-18 (a factor of ~1e8 from the start), a ``[[fixed]]`` value held with ``vary=False``.
Starts come from variable projection: for fixed tau = eta / k2 the model
``F = k1 eps + eta g(t; tau)`` is linear in (k1, eta), so a grid of tau over the observed
window is solved by non-negative least squares and the best local minima seed lmfit's
``leastsq`` (Levenberg-Marquardt). From several starts the lowest chi-square wins. The
fit is then refitted with slack rows left out and with each run weighted by its own
residual noise.

The fit is an lmfit ``Minimizer`` on a residual function, not a ``Model``: it is one joint
fit over several runs, each with its own noise weight and its own used rows, while the
model runs over every row of a run (the solid has a memory).

A run that starts at slack or a preload (``_Run.offset``, :mod:`matid.fits.extension.start`)
carries a free force offset ``c``: ``F = c + k1 eps + f2``. It is linear and unbounded, so it is
projected out (variable projection, as the Prony fit does with its stiffnesses): for any
(k1, k2, eta) it is the mean of the run's measured less model force over its used rows
(:func:`_offsets`), and the residual lmfit sees is centred. The Jacobian of that residual gives
(k1, k2, eta) errors that include the offset's correlation with them (Golub and Pereyra 1973).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import lmfit
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
    """For fixed tau, F = k1 eps + eta g(t; tau) is linear: solve (k1, eta) >= 0 by NNLS (a run's
    free force offset projected out first: its columns centred, :func:`_centred`).

    Returns (cost, k1, eta); fixed k1, eta (or eta = k2 tau for fixed k2) are held.
    """
    pairs = list(zip(runs, sigma, strict=True))
    eps = np.concatenate([run.reduce(_centred(run, run.eps)) / s for run, s in pairs])
    g = np.concatenate(
        [run.reduce(_centred(run, run.history.force(0.0, 1.0 / tau, 1.0))) / s for run, s in pairs]
    )
    y = np.concatenate([run.reduce(_centred(run, run.force)) / s for run, s in pairs])
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


def _params(
    start: Mapping[str, float], ref: Mapping[str, float], fixed: Mapping[str, float]
) -> lmfit.Parameters:
    """lmfit parameters x = log(k / k_ref): of order one whatever the SI scale, bounded at
    +-_LOG_BOUND; a ``[[fixed]]`` value is a parameter with ``vary=False``."""
    out = lmfit.Parameters()
    for name in _ORDER:
        value = math.log(fixed.get(name, start[name]) / ref[name])
        out.add(name, value=value, vary=name not in fixed, min=-_LOG_BOUND, max=_LOG_BOUND)
    return out


def _values(params: lmfit.Parameters, ref: Mapping[str, float]) -> dict[str, float]:
    return {name: ref[name] * math.exp(params[name].value) for name in _ORDER}


def _offset(run: _Run, model: np.ndarray) -> float:
    """The run's force offset for this model force: 0, or with a free offset (``run.offset``)
    the mean of measured less model force over its used rows (also the least squares one on
    bin means: a bin of m rows weighs sqrt(m) times its mean)."""
    return float(np.mean((run.force - model)[run.used])) if run.offset else 0.0


def _centred(run: _Run, values: np.ndarray) -> np.ndarray:
    """``values`` less their mean over the used rows for a run with a free offset (projected off
    the offset's column), else unchanged."""
    return values - float(np.mean(values[run.used])) if run.offset else values


def _models(runs: Sequence[_Run], k: Mapping[str, float]) -> list[np.ndarray]:
    """Model force of each run over all its rows, its force offset (:func:`_offset`) included."""
    out = []
    for run in runs:
        f = run.history.force(k["k1"], k["k2"], k["eta"])  # = sls_force(run.t, run.eps, ...)
        out.append(f + _offset(run, f))
    return out


def n_params(nvarys: int, runs: Sequence[_Run]) -> int:
    """Parameters of the fit: lmfit's varied ones and one force offset per run that has one."""
    return nvarys + sum(run.offset for run in runs)


def residual(params: lmfit.Parameters, runs, sigma, ref, rows: bool = False) -> np.ndarray:
    """Weighted residuals (F_model - F) / sigma_run of all runs: over their bin means on a long
    record (:mod:`matid.fits.extension.reduce`), else, or with ``rows``, over the used rows."""
    models = _models(runs, _values(params, ref))
    return np.concatenate(
        [
            (f - run.force)[run.used] / s if rows else run.reduce(f - run.force) / s
            for f, run, s in zip(models, runs, sigma, strict=True)
        ]
    )


def _minimise(runs, sigma, starts, ref, fixed) -> tuple[lmfit.Minimizer, lmfit.minimizer.MinimizerResult]:
    """lmfit ``leastsq`` from each start; the lowest chi-square wins."""
    best = None
    for start in starts:
        minimizer = lmfit.Minimizer(
            residual, _params(start, ref, fixed), fcn_args=(runs, sigma, ref), nan_policy="raise"
        )
        try:
            result = minimizer.minimize(method="leastsq")
        except ValueError as exc:  # NaN in the residuals
            raise FitError(f"the SLS model could not be evaluated: {exc}") from exc
        if best is None or result.chisqr < best[1].chisqr:
            best = (minimizer, result)
    return best


def _run_noise(resid: np.ndarray, nvarys: int, runs: Sequence[_Run], sigma: np.ndarray) -> np.ndarray:
    """Noise of each run from its own residuals on every used row (``resid``, weighted by
    ``sigma``; also for a run fitted on bin means, whose weights then match the fit on every
    row), each run taking its share of the dof."""
    n = np.array([int(run.used.sum()) for run in runs])
    share = 1.0 - nvarys / n.sum()
    pieces = np.split(resid, np.cumsum(n)[:-1])
    return np.array(
        [s * math.sqrt(np.sum(r**2) / (m * share)) for r, s, m in zip(pieces, sigma, n, strict=True)]
    )


def _solve(runs: Sequence[_Run], fixed: Mapping[str, float], reweight: int = 2):
    """Joint fit: starts from the tau profile, then refits with each run's residual noise.

    Returns (runs, minimizer, result, ref, sigma): the runs with their slack rows, the
    lmfit Minimizer and MinimizerResult of the last fit, the scale k_ref and the run noise.
    """
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
        resid = residual(result.params, runs, sigma, ref, rows=True)
        sigma = _run_noise(resid, n_params(result.nvarys, runs), runs, sigma)
        if not np.all(sigma > 0):
            break  # an exact fit: keep the weights
        minimizer, result = _minimise(runs, sigma, [_values(result.params, ref)], ref, fixed)
    if not result.success or not np.all(np.isfinite(result.residual)):
        raise FitError(f"the SLS least-squares fit did not converge: {result.message}")
    return runs, minimizer, result, ref, sigma


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
