r"""Statistics shared by the fits: noise, lack of fit, intervals under correlated residuals.

Every fit here is (or is linearised to) least squares ``y = f(x; p) + e``. Two things can
make its textbook interval ``p -+ t se`` a confident wrong number on real records:

1. **Lack of fit.** The model misses a systematic part of the data. Then the residual rms
   exceeds the point-to-point noise and the residuals run in long same-sign stretches.
   :func:`lack_of_fit` compares the residual variance with a model-free noise estimate
   from second differences (:func:`difference_noise`)::

       sigma_d = 1.4826 MAD(r_{i+1} - 2 r_i + r_{i-1}) / sqrt(6)      (sd of e if i.i.d.)
       reduced_chi2 = [sum r^2 / (n - p)] / sigma_d^2

   and counts runs of equal sign (Wald-Wolfowitz: E[runs] = 1 + 2 n+ n- / n).
2. **Correlated noise.** Dense test-machine records sample faster than their noise
   decorrelates (filters, drift, vibration), so neighbouring residuals share sign even
   for a true model. The i.i.d. covariance then understates the error by up to
   sqrt((1 + rho) / (1 - rho)).

Both are handled by one covariance (:func:`ar1_covariance`): the least-squares sandwich
with an AR(1) correlation of the residuals, R_ij = rho^|i - j| within a segment (a file)::

    cov = s^2 (J'J)^-1 J' R J (J'J)^-1,      s^2 = sum r^2 / tr[(I - H) R]

with rho the lag-1 autocorrelation of the residuals, corrected for its small-sample
bias (Kendall 1954: E[rho_hat] ~ rho - (1 + 3 rho) / n, and about -p/n more for the
p fitted parameters), and used only when significant (rho_hat sqrt(n) > 2). The
interval uses Student's t on ``n_eff - p`` degrees of freedom, with the effective sample
size ``n_eff = n (1 - rho) / (1 + rho)`` (:func:`effective_n`). A misfit shows up as
a large rho and a large s^2, so it widens the interval too: the interval then says
"the line/model cannot be trusted this closely", which is what the data support.

Distributions (t, F, chi-square, normal) are scipy.stats' own, here and in every fit (the
onset scans of :mod:`matid.fits.onset` call ``scipy.special.fdtrc``, the function behind
``scipy.stats.f.sf``, without the distribution object's ~0.1 ms per call).

``segments`` is a sequence of segment lengths summing to ``len(residuals)`` (one per
file, in the order the rows were recorded); None means one segment. Residuals must be in
recording order, not sorted by x: correlation lives along time.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import signal
from scipy import stats as sstats

#: Reduced chi-square (residual variance / difference noise) above which a fit is a misfit.
MISFIT_CHI2 = 2.0
#: p-value of the runs test (too few sign changes) below which residuals are systematic.
MISFIT_RUNS_P = 1e-3
#: p-value of the lag-1 autocorrelation test (one-sided, r1 too large) below which residuals are
#: systematic. Either test suffices: both measure serial dependence, and the runs test, which sees only
#: signs, is weak on short records (a bend of 30 rows with r1 = 0.69, z = 4.0, has runs p = 0.0014).
MISFIT_LAG1_P = 1e-3
#: Fewest residuals for a lack-of-fit decision (fewer: no decision, no warning).
MIN_POINTS = 12
#: Lag-1 autocorrelation is used when rho_hat sqrt(n) exceeds this (about 2.3 % one-sided).
RHO_Z = 2.0
#: Largest rho used: beyond, the record holds about one independent value per segment.
RHO_MAX = 0.999


def _bounds(n: int, segments: Sequence[int] | None) -> list[tuple[int, int]]:
    """(start, stop) of each segment; segments must sum to n."""
    if segments is None:
        return [(0, n)]
    lengths = [int(s) for s in segments]
    if sum(lengths) != n or any(s < 0 for s in lengths):
        raise ValueError(f"segments {lengths} do not add up to {n} rows")
    edges = np.cumsum([0, *lengths])
    return [(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def difference_noise(y: np.ndarray, segments: Sequence[int] | None = None) -> float:
    """Model-free noise sd from second differences: ``1.4826 MAD(d2) / sqrt(6)``.

    Second differences remove any smooth signal (or smooth misfit); the MAD ignores
    kinks (ramp ends). Quantised records can make the MAD zero; then the rms of d2 is
    used. Returns 0.0 when there are fewer than 3 points in every segment.
    """
    y = np.asarray(y, dtype=float)
    d2 = np.concatenate(
        [np.diff(y[a:b], 2) for a, b in _bounds(y.size, segments) if b - a >= 3] or [np.zeros(0)]
    )
    if d2.size == 0:
        return 0.0
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    if mad > 0:
        return 1.4826 * mad / math.sqrt(6.0)
    return float(np.sqrt(np.mean(d2**2) / 6.0))


def lag1(residuals: np.ndarray, segments: Sequence[int] | None = None) -> float:
    """Lag-1 autocorrelation of the residuals, pooled over segments (about their mean)."""
    r = np.asarray(residuals, dtype=float)
    num = den = 0.0
    for a, b in _bounds(r.size, segments):
        piece = r[a:b] - np.mean(r[a:b])
        num += float(np.dot(piece[1:], piece[:-1]))
        den += float(np.dot(piece, piece))
    return num / den if den > 0 else 0.0


def lag1_p(rho: float, n: int, segments: Sequence[int] | None = None) -> float:
    """One-sided p-value of a lag-1 autocorrelation ``rho`` of ``n`` independent residuals: under
    independence rho is about normal with mean -m/n (m segments, each mean removed) and variance
    1/n (Anderson 1942; Box, Jenkins & Reinsel, Time Series Analysis, section 2.1.6). 1.0 below 3 rows."""
    if n < 3:
        return 1.0
    m = len(_bounds(n, segments))
    return float(sstats.norm.sf((rho + m / n) * math.sqrt(n)))


def runs(residuals: np.ndarray, segments: Sequence[int] | None = None) -> tuple[int, float, float]:
    """Runs of equal sign: (observed, expected, p of so few), summed over segments.

    Wald-Wolfowitz with the normal approximation; zeros are dropped.
    """
    r = np.asarray(residuals, dtype=float)
    observed, mean, var = 0, 0.0, 0.0
    for a, b in _bounds(r.size, segments):
        s = np.sign(r[a:b])
        s = s[s != 0]
        n_pos, n_neg = int(np.sum(s > 0)), int(np.sum(s < 0))
        n = n_pos + n_neg
        if n < 2:
            continue
        observed += 1 + int(np.sum(s[1:] != s[:-1]))
        mean += 1.0 + 2.0 * n_pos * n_neg / n
        var += 2.0 * n_pos * n_neg * (2.0 * n_pos * n_neg - n) / (n * n * (n - 1))
    if var <= 0:
        return observed, mean, 1.0
    return observed, mean, float(sstats.norm.cdf((observed - mean + 0.5) / math.sqrt(var)))


def ar1_rho(residuals: np.ndarray, segments: Sequence[int] | None = None, n_params: int = 0) -> float:
    """Bias-corrected lag-1 autocorrelation used for the covariance (0 when not significant)."""
    r = np.asarray(residuals, dtype=float)
    n = r.size
    rho = lag1(r, segments)
    if n < 4 or rho * math.sqrt(n) <= RHO_Z:
        return 0.0
    n_seg = len(_bounds(n, segments))
    corrected = rho + (1.0 + 3.0 * rho) * n_seg / n + n_params / n
    return float(min(max(corrected, 0.0), RHO_MAX))


def mean_variance_factor(m: np.ndarray, rho: float) -> np.ndarray:
    """Var(mean of m consecutive AR(1) values) / (sd^2 / m): ``1 + 2 sum_k (1 - k/m) rho^k``
    for k < m, i.e. ``(1 + rho)/(1 - rho) - 2 rho (1 - rho^m) / (m (1 - rho)^2)``; 1 at m = 1."""
    m = np.asarray(m, dtype=float)
    if rho == 0.0:
        return np.ones_like(m)
    return (1.0 + rho) / (1.0 - rho) - 2.0 * rho * (1.0 - rho**m) / (m * (1.0 - rho) ** 2)


def _neff(n: int, rho: float) -> float:
    return n * (1.0 - rho) / (1.0 + rho)


def effective_n(residuals: np.ndarray, segments: Sequence[int] | None = None, n_params: int = 0) -> float:
    """Effective number of independent residuals: ``n (1 - rho) / (1 + rho)`` (AR(1))."""
    return variance_factor(residuals, segments, n_params)[1]


def _ar1_apply(matrix: np.ndarray, rho: float, bounds) -> np.ndarray:
    """R @ matrix for R_ij = rho^|i-j| inside each segment: a forward and a backward
    exponential filter, O(n) instead of forming R."""
    if rho == 0.0:
        return matrix.copy()
    out = np.empty_like(matrix)
    for a, b in bounds:
        block = matrix[a:b]
        forward = signal.lfilter([1.0], [1.0, -rho], block, axis=0)
        backward = signal.lfilter([1.0], [1.0, -rho], block[::-1], axis=0)[::-1]
        out[a:b] = forward + backward - block
    return out


@dataclass(frozen=True)
class Covariance:
    """Covariance of least-squares parameters under AR(1)-correlated residuals.

    ``cov`` the sandwich covariance, ``cov_iid`` the textbook s^2 (J'J)^-1 with
    s^2 = RSS / (n - p), ``rho`` the correlation used, ``dof`` the t degrees of freedom
    (n_eff - p, at least 1), ``inflation`` sqrt(diag(cov) / diag(cov_iid)) per parameter.
    """

    cov: np.ndarray
    cov_iid: np.ndarray
    rho: float
    n_eff: float
    dof: float

    @property
    def stderr(self) -> np.ndarray:
        return np.sqrt(np.diag(self.cov))

    @property
    def inflation(self) -> np.ndarray:
        iid = np.sqrt(np.diag(self.cov_iid))
        return np.divide(self.stderr, iid, out=np.ones_like(iid), where=iid > 0)


def ar1_covariance(
    jacobian: np.ndarray, residuals: np.ndarray, segments: Sequence[int] | None = None
) -> Covariance:
    """Sandwich covariance ``s^2 (J'J)^-1 J'RJ (J'J)^-1`` with ``s^2 = RSS / tr[(I-H)R]``.

    ``jacobian`` (n x p) of the (weighted) model in the parameters, ``residuals`` (n) in
    recording order. Under i.i.d. residuals (rho not significant) this is the textbook
    covariance on n - p dof. Raises ValueError for a rank-deficient Jacobian.
    """
    J = np.asarray(jacobian, dtype=float)
    r = np.asarray(residuals, dtype=float)
    if J.ndim == 1:
        J = J[:, None]
    n, p = J.shape
    if r.shape != (n,):
        raise ValueError(f"residuals of shape {r.shape} do not match a jacobian of {n} rows")
    if n <= p:
        raise ValueError(f"{n} points cannot give errors for {p} parameters")
    bounds = _bounds(n, segments)
    jtj_inv = np.linalg.inv(J.T @ J)  # LinAlgError for singular J
    rss = float(np.dot(r, r))
    cov_iid = rss / (n - p) * jtj_inv
    rho = ar1_rho(r, segments, p)
    if rho == 0.0:
        return Covariance(cov_iid, cov_iid, 0.0, float(n), float(n - p))
    rj = _ar1_apply(J, rho, bounds)
    middle = J.T @ rj
    trace = n - float(np.trace(jtj_inv @ middle))  # tr[(I - H) R]
    s2 = rss / max(trace, 1e-12 * n)
    cov = s2 * jtj_inv @ middle @ jtj_inv
    n_eff = sum(_neff(b - a, rho) for a, b in bounds)
    return Covariance(cov, cov_iid, rho, n_eff, max(n_eff - p, 1.0))


def heteroscedastic_floor(jacobian: np.ndarray, residuals: np.ndarray, cov: Covariance) -> Covariance:
    """``cov`` scaled up to at least the HC3 variance of the first parameter (the slope), which
    holds when the scatter grows along the line (a torque from a noisy angle, noise proportional
    to the load) where s^2 (J'J)^-1 assumes one level. Lines with noise sd proportional to x, 400
    seeds: coverage 87 / 88 / 91 % -> 93 / 92 / 96 % at 15 / 40 / 150 rows."""
    J, r = np.atleast_2d(np.asarray(jacobian, dtype=float).T).T, np.asarray(residuals, dtype=float)
    jtj_inv = np.linalg.inv(J.T @ J)
    leverage = np.einsum("ij,jk,ik->i", J, jtj_inv, J)
    u = r / (1.0 - np.minimum(leverage, 0.999))
    hc3 = jtj_inv @ (J.T * u**2) @ J @ jtj_inv
    ratio = hc3[0, 0] / cov.cov[0, 0] if cov.cov[0, 0] > 0 else 1.0
    return replace(cov, cov=cov.cov * ratio) if ratio > 1.0 else cov


def central_jacobian(f, x: np.ndarray, step: float) -> np.ndarray:
    """Jacobian of the vector function ``f`` at ``x`` by central differences of ``step``."""
    return np.column_stack([(f(x + step * e) - f(x - step * e)) / (2 * step) for e in np.eye(x.size)])


def t95(dof: float) -> float:
    """Student's t quantile of a two-sided 95 % interval on ``dof`` (at least 1) degrees of freedom."""
    return float(sstats.t.ppf(0.975, max(dof, 1.0)))


def bic(rss: float, n: int, n_params: int, n_eff: float) -> float:
    """BIC of ``n`` weighted residuals whose squares sum to ``rss``, with the information of
    ``n_eff`` independent ones (AR(1): :func:`effective_n`)."""
    return n_eff * math.log(rss / n) + n_params * math.log(n_eff)


def interval(value: float, se: float, dof: float) -> tuple[float, float]:
    """The 95 % interval ``value -+ t95(dof) se``."""
    half = t95(dof) * se
    return value - half, value + half


@dataclass(frozen=True)
class LackOfFit:
    """Residuals against noise: is the model a description of the data within the noise?

    ``noise`` the model-free point-to-point sd, ``rms`` the residual sd (n - p dof),
    ``reduced_chi2`` = (rms / noise)^2, ``lag1`` the residuals' lag-1 autocorrelation,
    ``lag1_p`` its one-sided p-value under independence (:func:`lag1_p`),
    ``runs``/``runs_expected``/``runs_p`` the sign-runs test; ``misfit`` when the
    residuals exceed the noise (reduced_chi2 > MISFIT_CHI2) and are systematic by either
    test of serial dependence (runs_p < MISFIT_RUNS_P or lag1_p < MISFIT_LAG1_P; the two
    are strongly correlated under independence, so the union's false-alarm rate is below
    2e-3, and the chi-square condition must hold as well); ``decided`` is False for fewer
    than MIN_POINTS residuals.
    """

    noise: float
    rms: float
    reduced_chi2: float
    lag1: float
    runs: int
    runs_expected: float
    runs_p: float
    decided: bool
    lag1_p: float = 1.0

    @property
    def serial(self) -> bool:
        """Residuals serially dependent by either test (runs or lag-1 autocorrelation)."""
        return self.runs_p < MISFIT_RUNS_P or self.lag1_p < MISFIT_LAG1_P

    @property
    def misfit(self) -> bool:
        return self.decided and self.reduced_chi2 > MISFIT_CHI2 and self.serial

    def as_info(self) -> dict[str, float | int | bool]:
        """Plain figures for ``TestFit.info``."""
        return {
            "reduced_chi2": float(self.reduced_chi2),
            "noise": float(self.noise),
            "residual_rms": float(self.rms),
            "lag1_autocorrelation": float(self.lag1),
            "runs": int(self.runs),
            "runs_expected": float(self.runs_expected),
            "runs_p": float(self.runs_p),
            "lag1_p": float(self.lag1_p),
            "misfit": bool(self.misfit),
        }

    def warning(self, model: str, inflation: float | None = None, advice: str = "") -> str | None:
        """Warning text naming the misfit, or None when the model fits within the noise.

        ``model`` names what was fitted ("the line torque = c + E_t x", "the SLS"),
        ``inflation`` the factor the interval was widened by, ``advice`` what to do.
        """
        if not self.misfit:
            return None
        widened = (
            f"; the interval is widened {inflation:.1f}x for it" if inflation and inflation > 1.05 else ""
        )
        text = (
            f"{model} does not describe the data within their noise: the residuals are "
            f"{math.sqrt(self.reduced_chi2):.1f}x the point-to-point noise "
            f"(reduced chi2 {self.reduced_chi2:.3g}) and run in long stretches of one "
            f"sign ({self.runs} runs where {self.runs_expected:.0f} are expected, lag-1 r = "
            f"{self.lag1:.2f}): a systematic misfit, or noise that wanders slowly{widened}"
        )
        return f"{text}. {advice}" if advice else text


def lack_of_fit(residuals: np.ndarray, n_params: int, *, segments: Sequence[int] | None = None) -> LackOfFit:
    """Compare residuals (recording order) with their second-difference noise
    (:func:`difference_noise`, which a smooth misfit does not reach): see :class:`LackOfFit`."""
    r = np.asarray(residuals, dtype=float)
    n = r.size
    dof = max(n - n_params, 1)
    rms = math.sqrt(float(np.dot(r, r)) / dof)
    sd = difference_noise(r, segments)
    chi2 = (rms / sd) ** 2 if sd > 0 else (math.inf if rms > 0 else 1.0)
    observed, expected, p = runs(r, segments)
    rho = lag1(r, segments)
    decided = n >= MIN_POINTS
    return LackOfFit(sd, rms, chi2, rho, observed, expected, p, decided, lag1_p(rho, n, segments))


def variance_factor(
    residuals: np.ndarray, segments: Sequence[int] | None = None, n_params: int = 0
) -> tuple[float, float]:
    """(f, n_eff): the AR(1) factor ``f = (1 + rho) / (1 - rho)`` by which correlated residuals
    inflate the variance of a smooth contrast (a slope, a curvature term), and the
    effective sample size ``n / f``; (1, n) when rho is not significant."""
    r = np.asarray(residuals)
    rho = ar1_rho(r, segments, n_params)
    return (1.0 + rho) / (1.0 - rho), _neff(r.size, rho)


def ar1_noise(rng: np.random.Generator, n: int, phi: float) -> np.ndarray:
    """Stationary AR(1) noise of unit marginal sd: e_i = phi e_(i-1) + sqrt(1 - phi^2) w_i.

    For coverage checks of the intervals above (tests and ``benchmarks/``): dense
    test-machine records have residuals of this kind.
    """
    innovations = rng.normal(size=n) * np.sqrt(1.0 - phi**2)
    innovations[0] = rng.normal()
    return signal.lfilter([1.0], [1.0, -phi], innovations)


#: Largest argument of math.exp that stays finite (log of the largest float, 709.78...).
_EXP_MAX = math.log(sys.float_info.max)


def wald_log_interval(value: float, se: float, tq: float) -> tuple[float, float] | None:
    """value * exp(-+ tq se/value): the Wald interval of log k, positive by construction.

    None where exp(tq se/value) overflows a float (se > ~300 value: the interval would span
    more than 600 decades): no interval rather than one that is not a number.
    """
    spread = tq * se / value
    if not spread < _EXP_MAX:
        return None
    return value * math.exp(-spread), value * math.exp(spread)
