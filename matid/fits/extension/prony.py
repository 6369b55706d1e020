r"""Generalised Maxwell (n-term Prony) solid for extension runs, chosen against the SLS.

A spring k0 in parallel with n Maxwell arms (spring k_i in series with a dashpot of
relaxation time tau_i), in force units against engineering strain eps, from rest::

    F(t) = k0 eps(t) + sum_i f_i(t),     f_i' + f_i / tau_i = k_i eps'(t),    f_i(0) = 0

so the relaxation modulus is the Prony series G(t) = k0 + sum_i k_i exp(-t / tau_i).
n = 1 is the standard linear solid (k0 = sls_k1, k1 = sls_k2, tau1 = sls_eta / sls_k2).
Each arm is the SLS arm of :func:`matid.physics.sls.sls_force` with unit stiffness,
so for fixed taus the force is linear in (k0, k_1..k_n).

Fit (:func:`fit_prony`): variable projection. The outer least squares (lmfit
``least_squares`` on bounded ``Parameters``) moves log tau_i; the inner one solves
(k0, k_i) >= 0 by NNLS on the rows used, each run weighted by its
noise sigma_j. The covariance of (log k0, log k_i, log tau_i) is the AR(1) sandwich of
:mod:`matid.fits.stats` on the numerical Jacobian.

Choice (:func:`choose`): n = 1, 2, 3 by the Bayesian information criterion on the same
weights, BIC_n = N' ln(RSS_n / N) + (2n + 1) ln N', with N' the effective number of
independent residuals of the fit with the most arms (N' = N for uncorrelated residuals; correlated noise
would otherwise buy arms); a model with more arms is preferred only when it lowers BIC by
more than BIC_MARGIN (strong evidence, Kass & Raftery 1995). AIC = N' ln(RSS/N) +
2 (2n + 1) is reported beside it.

Reported parameter names: ``prony_k0`` (equilibrium stiffness, N), ``prony_k1`` ..
``prony_k3`` (arm stiffnesses, N), ``prony_tau1`` .. ``prony_tau3`` (relaxation times, s),
arms ordered by tau, fastest first.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import lmfit
import numpy as np
from scipy import optimize

from matid.fits import stats
from matid.fits.extension.reduce import Reduction
from matid.model.results import Estimate
from matid.physics.sls import History, sls_force

#: Most arms tried.
MAX_TERMS = 3
#: BIC decrease a model with more arms needs to be preferred.
BIC_MARGIN = 10.0


@dataclass(frozen=True)
class Data:
    """One run for the fit: all rows (the history), the rows used, the run's noise sd, how its
    rows become residuals (``rows``; default one per used row), and whether its force has a
    free offset (projected out as the stiffnesses are: :meth:`centred`)."""

    t: np.ndarray
    eps: np.ndarray
    force: np.ndarray
    used: np.ndarray
    sigma: float
    rows: Reduction | None = None
    offset: bool = False  # a free force offset (slack or preload, :mod:`matid.fits.extension.start`)

    @functools.cached_property
    def history(self) -> History:
        return History(self.t, self.eps)

    @functools.cached_property
    def reduce(self) -> Reduction:
        return Reduction(self.used) if self.rows is None else self.rows

    def centred(self, values: np.ndarray) -> np.ndarray:
        """``values`` (rows, or rows x columns) less their mean over the used rows when the run
        has a free force offset, else unchanged."""
        return values - np.mean(values[self.used], axis=0) if self.offset else values


def arm(t: np.ndarray, eps: np.ndarray, tau: float) -> np.ndarray:
    """Force of a unit-stiffness Maxwell arm of relaxation time tau under the strain history."""
    return sls_force(t, eps, 0.0, 1.0, tau)


def prony_force(t, eps, k0: float, ks: Sequence[float], taus: Sequence[float]) -> np.ndarray:
    """``F = k0 eps + sum_i f_i`` for the strain history ``(t, eps)`` (linear between samples)."""
    out = k0 * np.asarray(eps, dtype=float)
    for k, tau in zip(ks, taus, strict=True):
        out = out + k * arm(t, eps, tau)
    return out


#: Arms already computed during one fit: (run index, tau) -> arm over all rows of that run.
Arms = dict[tuple[int, float], np.ndarray]


def _basis(data: Sequence[Data], taus, arms: Arms) -> tuple[np.ndarray, np.ndarray]:
    """Weighted design [eps, arm(tau_1), ...] and weighted force over the used rows.

    An arm already computed for the same run and tau is reused from ``arms``: a
    finite-difference Jacobian moves one tau at a time, so most of its arms repeat.
    """
    cols, rhs = [], []
    for i, d in enumerate(data):
        block = [d.eps]
        for tau in taus:
            key = (i, float(tau))
            if key not in arms:
                arms[key] = d.history.force(0.0, 1.0, tau)  # = arm(d.t, d.eps, tau)
            block.append(arms[key])
        cols.append(d.reduce(d.centred(np.column_stack(block))) / d.sigma)
        rhs.append(d.reduce(d.centred(d.force)) / d.sigma)
    return np.vstack(cols), np.concatenate(rhs)


def _inner(data, log_taus, arms: Arms) -> tuple[np.ndarray, np.ndarray]:
    """NNLS stiffnesses for these taus and the weighted residuals."""
    design, rhs = _basis(data, np.exp(log_taus), arms)
    scale = np.maximum(np.linalg.norm(design, axis=0), 1e-300)
    coef, _ = optimize.nnls(design / scale, rhs)
    coef = coef / scale
    return coef, design @ coef - rhs


def _model_residual(data, x: np.ndarray, n_terms: int) -> np.ndarray:
    """Weighted residuals for x = (log k0, log k_1..n, log tau_1..n)."""
    k = np.exp(x[: n_terms + 1])
    taus = np.exp(x[n_terms + 1 :])
    return np.concatenate(
        [d.centred(prony_force(d.t, d.eps, k[0], k[1:], taus) - d.force)[d.used] / d.sigma for d in data]
    )


@dataclass(frozen=True)
class PronyFit:
    """An n-arm fit: values, log-parameter covariance, RSS (weighted), BIC and AIC."""

    n_terms: int
    k0: float
    ks: tuple[float, ...]
    taus: tuple[float, ...]
    residual: np.ndarray  # weighted, on every used row (also when fitted on bin means)
    n: int
    covariance: stats.Covariance | None
    rows: int | None = None  # rows fitted

    @property
    def rss(self) -> float:
        return float(np.dot(self.residual, self.residual))

    @property
    def n_params(self) -> int:
        return 2 * self.n_terms + 1

    def bic_at(self, n_eff: float) -> float:
        """BIC with the information of ``n_eff`` independent residuals."""
        return stats.bic(self.rss, self.n, self.n_params, n_eff)

    def aic_at(self, n_eff: float) -> float:
        return n_eff * math.log(self.rss / self.n) + 2.0 * self.n_params

    def values(self) -> dict[str, float]:
        """Parameter name -> value, arms fastest first."""
        out = {"prony_k0": self.k0}
        for i, (k, tau) in enumerate(zip(self.ks, self.taus, strict=True), start=1):
            out[f"prony_k{i}"] = k
            out[f"prony_tau{i}"] = tau
        return out

    @property
    def determined(self) -> bool:
        """Whether the data determine every parameter: a covariance with finite standard errors."""
        if self.covariance is None:
            return False
        variance = np.diag(self.covariance.cov)
        return bool(np.all(np.isfinite(variance) & (variance >= 0.0)))

    def stderr(self) -> dict[str, float | None]:
        """Standard errors by the delta method, se(p) = p se(log p); None when singular."""
        names = [f"prony_k{i}" for i in range(self.n_terms + 1)]
        names += [f"prony_tau{i}" for i in range(1, self.n_terms + 1)]
        values = self.values()
        if self.covariance is None:
            return dict.fromkeys(names)
        se_log = self.covariance.stderr
        return {name: values[name] * float(s) for name, s in zip(names, se_log, strict=True)}


def _starts(low: float, high: float, n_terms: int) -> list[np.ndarray]:
    """log tau starts spread over the observed window [low, high] (min dt, max duration)."""
    edges = np.linspace(math.log(low), math.log(high), n_terms + 2)[1:-1]
    return [edges + shift * (edges[1] - edges[0] if n_terms > 1 else 1.0) for shift in (0.0, 0.5, -0.5)]


def _tau_params(start: np.ndarray, bounds: tuple[float, float]) -> lmfit.Parameters:
    """lmfit parameters log tau_1..n, bounded to the observed window widened 100x each side."""
    out = lmfit.Parameters()
    for i, value in enumerate(np.clip(start, *bounds), start=1):
        out.add(f"log_tau{i}", value=float(value), min=bounds[0], max=bounds[1])
    return out


def _outer(params: lmfit.Parameters, data, arms: Arms) -> np.ndarray:
    """Weighted residuals at these taus with the stiffnesses projected out (NNLS)."""
    return _inner(data, np.sort(np.array(list(params.valuesdict().values()))), arms)[1]


def _budget(n_terms: int) -> int:
    """Residual evaluations allowed to one outer fit: scipy's own default for trf (100 n
    iterations' function evaluations) with the n more of each 2-point Jacobian. lmfit's
    default (2000 (n + 1)) lets a model with a vanishing arm, which the data cannot
    determine, wander for thousands of evaluations."""
    return 100 * n_terms * (n_terms + 1)


def fit_prony(data: Sequence[Data], n_terms: int) -> PronyFit | None:
    """The n-arm fit (module docstring) with the least weighted RSS over the starts, or None
    when an arm vanishes (k_i = 0)."""
    low = min(float(np.median(np.diff(d.t))) for d in data)
    high = max(float(d.t[-1] - d.t[0]) for d in data)
    bounds = (math.log(low / 100.0), math.log(high * 100.0))
    best = None
    arms: Arms = {}
    for start in _starts(low, high, n_terms):
        minimizer = lmfit.Minimizer(_outer, _tau_params(start, bounds), fcn_args=(data, arms))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = minimizer.minimize(
                method="least_squares", x_scale=1.0, diff_step=1e-4, max_nfev=_budget(n_terms)
            )
        if best is None or result.chisqr < best.chisqr:
            best = result
    log_taus = np.sort(np.array(list(best.params.valuesdict().values())))
    coef, resid = _inner(data, log_taus, arms)
    if np.any(coef <= 0) or np.any(np.diff(log_taus) < 1e-3):
        return None  # a vanished or duplicated arm: this n says nothing beyond n - 1
    x = np.r_[np.log(coef), log_taus]
    rows = _model_residual(data, x, n_terms)
    if any(d.reduce.starts is not None for d in data):  # bin means: the criteria see every row
        resid = rows
    return PronyFit(
        n_terms,
        float(coef[0]),
        tuple(float(k) for k in coef[1:]),
        tuple(float(t) for t in np.exp(log_taus)),
        resid,
        resid.size,
        _cov(data, x, n_terms, rows),
        sum(int(d.used.sum()) for d in data),
    )


def _cov(data, x: np.ndarray, n_terms: int, r0: np.ndarray) -> stats.Covariance | None:
    """AR(1) sandwich covariance of the log-parameters on a central-difference Jacobian, on
    every used row (also where the fit itself ran on bin means: the rows carry the AR(1)
    structure the sandwich models); ``r0``: the weighted residuals on those rows at x."""
    jac = stats.central_jacobian(lambda y: _model_residual(data, y, n_terms), x, 1e-5)
    try:
        return stats.ar1_covariance(jac, r0, [int(d.used.sum()) for d in data])
    except (ValueError, np.linalg.LinAlgError):
        return None


@dataclass(frozen=True)
class Choice:
    """The fits tried (n -> fit) and the number of arms preferred."""

    fits: dict[int, PronyFit]
    best: int
    n_eff: float  # independent residuals the criteria count (see choose)

    @property
    def delta_bic(self) -> float:
        """BIC of the SLS minus that of the preferred model (0 when the SLS is preferred)."""
        return self.fits[1].bic_at(self.n_eff) - self.fits[self.best].bic_at(self.n_eff)

    def table(self) -> dict[str, dict[str, float]]:
        """n arms -> BIC, AIC and weighted RSS, for ``TestFit.info``."""
        return {
            f"{n} arm{'s' if n > 1 else ''}": {
                "bic": f.bic_at(self.n_eff),
                "aic": f.aic_at(self.n_eff),
                "rss_weighted": f.rss,
            }
            for n, f in sorted(self.fits.items())
        }


def choose(data: Sequence[Data], max_terms: int = MAX_TERMS) -> Choice | None:
    """Fit n = 1..max_terms arms; prefer more arms only when BIC drops by BIC_MARGIN per step."""
    fits: dict[int, PronyFit] = {}
    for n in range(1, max_terms + 1):
        fit = fit_prony(data, n)
        if fit is None:
            break
        fits[n] = fit
    if 1 not in fits:
        return None
    # correlated residuals carry less information than their count: the criteria use the
    # effective sample size of the richest fit (its residuals are the closest to the noise;
    # the SLS's own would count a misfit as correlated noise), else noise wander buys arms
    richest = fits[max(fits)]
    segments = [int(d.used.sum()) for d in data]
    n_eff = (
        stats.effective_n(richest.residual, segments, richest.n_params)
        if richest.covariance is not None
        else float(fits[1].n)
    )
    # a model the data do not determine is no evidence against the SLS, and would leave E_e
    # without an interval: an arm faster than the sampling (it decays between two readings, a
    # step the instantaneous stiffness absorbs) or a singular covariance. The first is read
    # from the data, not from round-off: whether lmfit's covariance of such an arm comes out
    # singular depends on the versions (lmfit 1.3.0 / scipy 1.11 gave finite errors on the
    # record of test_e_e_of_a_true_sls_keeps_its_interval, 1.3.4 / 1.17 did not)
    step = min(float(np.median(np.diff(d.t))) for d in data if d.t.size > 1) if data else 0.0
    best = 1
    for n in sorted(fits)[1:]:
        taus = [fits[n].values()[f"prony_tau{i}"] for i in range(1, n + 1)]
        resolved = fits[n].determined and min(taus) >= step
        if resolved and fits[best].bic_at(n_eff) - fits[n].bic_at(n_eff) > BIC_MARGIN:
            best = n
    return Choice(fits, best, n_eff)


# --------------------------------------------------------------------------- reporting


def _estimate(name: str, value: float, se: float | None, dof: float, n: int, warnings_=()) -> Estimate:
    se = se if se is not None and math.isfinite(se) else None
    ci = None
    if se is not None and value > 0:
        ci = stats.wald_log_interval(value, se, stats.t95(dof))
    return Estimate(name, value, se, ci, n, "prony", tuple(warnings_), {"ci_method": "t-log" if ci else None})


def preferred(choice: Choice, sls_k1: float, longest_run: float) -> tuple[tuple[Estimate, ...], str, str]:
    """Estimates of the preferred multi-arm model, the warning for E_e and the one for sls_*.

    E_e becomes the equilibrium stiffness prony_k0 of the preferred model: the SLS k1 of
    a solid with more arms mixes the slower arms into the "static" stiffness.
    """
    fit = choice.fits[choice.best]
    values, se = fit.values(), fit.stderr()
    dof = fit.covariance.dof if fit.covariance is not None else float(fit.n - fit.n_params)
    slow = max(fit.taus)
    k0_warn = ()
    if slow > 5.0 * longest_run:
        k0_warn = (
            f"the slowest arm (tau = {slow:.3g} s) is longer than 5x the longest run ({longest_run:.3g} s): "
            "prony_k0 includes whatever relaxes more slowly; add a longer hold to confirm it",
        )
    estimates = tuple(
        _estimate(name, value, se[name], dof, fit.rows or fit.n, k0_warn if name == "prony_k0" else ())
        for name, value in values.items()
    )
    arms = f"a {fit.n_terms}-arm Prony (generalised Maxwell) model"
    e_e = (
        f"the standard linear solid does not describe these runs: {arms} fits far better (BIC lower "
        f"by {choice.delta_bic:.0f}); E_e is its equilibrium stiffness prony_k0 = {fit.k0:.4g} N, "
        f"where the SLS would give {sls_k1:.4g} N; see the prony_* parameters"
    )
    sls = (
        f"the standard linear solid does not describe these runs ({arms} is preferred, BIC lower by "
        f"{choice.delta_bic:.0f}): the SLS parameters are not material constants here; see prony_*"
    )
    return estimates, e_e, sls
