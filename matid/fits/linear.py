r"""Lines with a tare offset: the shared core of E_b and E_t (physics.md section 2).

Both stiffnesses are slopes: torque against tip_angle / free_length (magnetic bending,
:mod:`matid.fits.bending`) and torque against twist_angle / length (torsion,
:mod:`matid.fits.torsion`). Real channels carry a tare offset (a torque meter zeroed
under a small preload, an angle read from a shifted zero), so each file f gets its own
intercept c_f and all files of a specimen share the slope E::

    y_fi = c_f + E x_fi + e_fi                       (:func:`fit_lines`)

fitted by weighted least squares, each file weighted by 1 / s_f^2 with s_f its own
residual rms (iterated; a short tube twisted further is noisier). When the offsets are
not significant (Wald test, p >= OFFSET_ALPHA) the lines go through the origin: an
offset per file would cost precision for nothing. The interval is the
AR(1) sandwich of :mod:`matid.fits.stats` on Student's t with n_eff - p dof, so it holds
for dense records whose noise is correlated, and widens when the line misses the data;
:func:`matid.fits.stats.lack_of_fit` then names the misfit in a warning.

Sign: physics makes E > 0 (torque rises with twist, the magnet's torque with tip angle).
A file whose slope is clearly negative (t < -SIGN_T) has a flipped sign convention: it is
negated and a warning says so (:func:`orient`). A joint slope <= 0 is never a result
(FitError).

The linear range of a record is found by :func:`linear_range`: an F-test for curvature
(odd terms u|u|, u^3 on top of c + a u) corrected for correlated residuals, then a
segmented fit for the onset.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.stats

from matid.errors import FitError
from matid.fits import stats

#: Significance level of the curvature test of :func:`linear_range`.
LINEAR_RANGE_ALPHA = 0.01
#: Fewest points a linear range may hold.
LINEAR_RANGE_MIN_POINTS = 6
#: At most this many onsets are tried (evenly spread) by :func:`linear_range`.
LINEAR_RANGE_WINDOWS = 200
#: Tare offsets are fitted when the Wald test of "all offsets zero" gives p below this.
#: Large on purpose: a real offset dropped biases the slope, an absent one kept only costs
#: precision, so offsets go only when the data agree with none (measured at 0.05: E_b
#: intervals covered 90 of 100 and per-length slopes "disagreed" in 20 of 100 i.i.d. trials
#: with an offset of 0.3 % of full scale).
OFFSET_ALPHA = 0.5
#: A file's own slope below -SIGN_T standard errors means its sign convention is flipped.
SIGN_T = 3.0


def __getattr__(name: str):
    """The fits themselves live in bending.py / torsion.py; kept importable from here."""
    if name in ("fit_bending", "magnet_torque", "bending_torque"):
        from matid.fits import bending

        return getattr(bending, name)
    if name == "fit_torsion":
        from matid.fits import torsion

        return torsion.fit_torsion
    raise AttributeError(name)


# --------------------------------------------------------------------------- linear range


def _curvature_p(u: np.ndarray, y: np.ndarray, order: np.ndarray) -> float:
    """p-value of the F-test of ``y = c + a u`` against ``y = c + a u + b u|u| + d u^3``.

    The F statistic is divided by the AR(1) variance factor of the alternative's
    residuals taken in recording order (``order``), on n_eff denominator dof: correlated
    noise is not curvature.
    """
    one = np.ones_like(u)
    null = np.column_stack([one, u])
    alt = np.column_stack([one, u, u * np.abs(u), u**3])
    rss0 = float(np.sum((y - null @ np.linalg.lstsq(null, y, rcond=None)[0]) ** 2))
    coef, _, rank, _ = np.linalg.lstsq(alt, y, rcond=None)
    resid = y - alt @ coef
    rss1 = float(np.sum(resid**2))
    q, dof = rank - 2, u.size - rank
    if q < 1 or dof < 1:
        return 1.0
    if rss1 <= 0.0:
        return 0.0 if rss0 > 1e-24 * max(float(np.sum(y**2)), 1e-300) else 1.0
    factor, n_eff = stats.variance_factor(resid[np.argsort(order)], n_params=rank)
    f = max(rss0 - rss1, 0.0) / q / (rss1 / dof) / factor
    return float(scipy.stats.f.sf(f, q, max(n_eff - rank, 1.0)))


def _onset_rss(u: np.ndarray, y: np.ndarray, u0: float) -> float:
    """RSS of y = c + a u + b sgn(u) max(|u| - u0, 0)^2 (linear least squares in c, a, b)."""
    excess = np.maximum(np.abs(u) - u0, 0.0)
    design = np.column_stack([np.ones_like(u), u, np.sign(u) * excess**2])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    return float(np.sum((y - design @ coef) ** 2))


def linear_range(
    x: np.ndarray,
    y: np.ndarray,
    *,
    alpha: float = LINEAR_RANGE_ALPHA,
    min_points: int = LINEAR_RANGE_MIN_POINTS,
    max_windows: int = LINEAR_RANGE_WINDOWS,
) -> np.ndarray:
    """Mask of the points in the linear range |x| <= x0 of ``y = c + E x`` data.

    Points are ordered by |x| (twist in both directions alike); c absorbs a tare offset.

    1. Is there curvature at all? F-test of the line against the line plus the lowest
       odd terms u|u| and u^3 (u = x / max|x|; torque is odd in twist) over all points at
       level ``alpha``, corrected for correlated residuals. If not, every point is kept.
    2. Where does it start? Segmented regression for the onset u0 of a C^1 departure,
       ``y = c + a u + b sgn(u) max(|u| - u0, 0)^2``, u0 scanned over the sorted |u| (at
       most ``max_windows`` candidates, at least ``min_points`` below); the range is
       |u| <= u0 of least residual sum of squares. It uses the shape of the whole curve,
       unlike nested window tests that admit points past the onset.
    3. If curvature is still significant inside |u| <= u0 (a curve bent from the
       origin), the range is the largest nested window inside it that passes the test.
    With fewer than ``min_points`` finite points all of them are returned.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 1 or x.shape != y.shape:
        raise ValueError("x and y must be 1-d arrays of the same length")
    if min_points < 3:
        raise ValueError(f"min_points must be at least 3, got {min_points}")
    ok = np.isfinite(x) & np.isfinite(y)
    index = np.flatnonzero(ok)[np.argsort(np.abs(x[ok]), kind="stable")]
    n = index.size
    if n <= min_points or not np.any(x[index] != 0):
        return ok
    u, yy = x[index] / np.max(np.abs(x[index])), y[index]
    if _curvature_p(u, yy, index) >= alpha:
        return ok
    sizes = np.unique(
        np.linspace(min_points, n - 2, min(max(n - 1 - min_points, 1), max_windows)).astype(int)
    )
    rss = [_onset_rss(u, yy, abs(u[k - 1])) for k in sizes]
    k = int(sizes[int(np.argmin(rss))])
    if _curvature_p(u[:k], yy[:k], index[:k]) < alpha:
        inner = sizes[sizes <= k]
        passing = [m for m in inner if _curvature_p(u[:m], yy[:m], index[:m]) >= alpha]
        k = int(max(passing)) if passing else min_points
    return ok & (np.abs(x) <= np.abs(x[index[k - 1]]))


# --------------------------------------------------------------------------- records


@dataclass(frozen=True)
class Record:
    """One file of a linear test: x and y of every row, the rows used, and why rows are out.

    ``left_out`` counts rows left out by reason ("outside the window", "not finite",
    "beyond the linear range"); ``flipped`` is True when y was negated by :func:`orient`.
    """

    name: str
    x: np.ndarray
    y: np.ndarray
    used: np.ndarray
    left_out: dict[str, int] = field(default_factory=dict)
    flipped: bool = False

    def leave_out(self, keep: np.ndarray, reason: str) -> Record:
        """The record with the used rows outside ``keep`` left out for ``reason``."""
        dropped = int(np.sum(self.used & ~keep))
        left_out = dict(self.left_out)
        if dropped:
            left_out[reason] = left_out.get(reason, 0) + dropped
        return replace(self, used=self.used & keep, left_out=left_out)


def record(name: str, x: np.ndarray, y: np.ndarray, window: np.ndarray) -> Record:
    """A record with the rows outside ``window`` and the non-finite rows left out."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    rec = Record(name, x, y, np.ones(x.size, dtype=bool))
    rec = rec.leave_out(np.asarray(window, dtype=bool), "outside the window")
    return rec.leave_out(np.isfinite(x) & np.isfinite(y), "not finite")


def _line(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(slope, its standard error) of y = c + b x; se inf when undetermined."""
    if x.size < 3 or np.ptp(x) <= 0:
        return 0.0, math.inf
    design = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    s2 = float(np.sum((y - design @ coef) ** 2)) / (x.size - 2)
    return float(coef[1]), math.sqrt(s2 / float(np.sum((x - x.mean()) ** 2)))


def orient(records: Sequence[Record], quantity: str, against: str) -> tuple[list[Record], list[str]]:
    """Negate the y of every record whose own slope is clearly negative; say so.

    Physics makes ``quantity`` rise with ``against``; a slope below -SIGN_T standard
    errors is a flipped sign convention (a torque meter mounted the other way round).
    """
    out, warnings = [], []
    for rec in records:
        slope, se = _line(rec.x[rec.used], rec.y[rec.used])
        if slope < 0 and slope < -SIGN_T * se:
            out.append(replace(rec, y=-rec.y, flipped=True))
            warnings.append(
                f"{rec.name}: {quantity} falls as {against} rises (slope {slope:.3g}, t = "
                f"{slope / se:.1f}); taken as a flipped sign convention and {quantity} negated. "
                f'Check the channel\'s polarity, or set negate = ["{quantity}"] on the test'
            )
        else:
            out.append(rec)
    return out, warnings


# --------------------------------------------------------------------------- joint line


@dataclass(frozen=True)
class LineFit:
    """Joint fit ``y = c_f + E x`` over records: slope, interval, intercepts, diagnostics."""

    slope: float
    stderr: float
    ci95: tuple[float, float]
    n: int
    intercepts: dict[str, float]
    covariance: stats.Covariance
    lof: stats.LackOfFit
    sigma: dict[str, float]  # residual rms per file (the weights)
    offsets_estimated: dict[str, float]  # c_f of the fit with offsets, kept or not
    offset_p: float  # p-value of "all offsets are zero"

    @property
    def value(self) -> tuple[float, float, tuple[float, float], int]:
        """(slope, stderr, ci95, n): the first fields of an Estimate."""
        return self.slope, self.stderr, self.ci95, self.n

    @property
    def inflation(self) -> float:
        return float(self.covariance.inflation[0])

    def model(self, rec: Record) -> np.ndarray:
        return self.intercepts[rec.name] + self.slope * rec.x

    def info(self) -> dict[str, object]:
        return {
            "tare_offset": dict(self.intercepts),
            "tare_offset_estimated": dict(self.offsets_estimated),
            "tare_offset_p": self.offset_p,
            "noise": dict(self.sigma),
            "lack_of_fit": self.lof.as_info(),
            "residual_lag1_used": self.covariance.rho,
            "n_effective": self.covariance.n_eff,
            "interval_widening": self.inflation,
        }


def _design(xs: Sequence[np.ndarray], w: Sequence[float], offsets: bool) -> np.ndarray:
    """Weighted design: column 0 the slope, column 1 + f the intercept of file f (if offsets)."""
    n = sum(x.size for x in xs)
    design = np.zeros((n, 1 + (len(xs) if offsets else 0)))
    start = 0
    for f, (x, wf) in enumerate(zip(xs, w, strict=True)):
        design[start : start + x.size, 0] = wf * x
        if offsets:
            design[start : start + x.size, 1 + f] = wf
        start += x.size
    return design


def _solve(xs, ys, offsets: bool):
    """Iteratively reweighted fit: (coef, weighted design, weighted residuals, sigma, covariance)."""
    scale = float(np.max(np.abs(np.concatenate(ys)))) or 1.0
    sigma = [stats.difference_noise(y) or 1e-9 * scale for y in ys]
    for _ in range(4):
        w = [1.0 / s for s in sigma]
        design = _design(xs, w, offsets)
        rhs = np.concatenate([wf * y for wf, y in zip(w, ys, strict=True)])
        coef, *_ = np.linalg.lstsq(design, rhs, rcond=None)
        resid = np.split((rhs - design @ coef), np.cumsum([x.size for x in xs])[:-1])
        dof = [max(r.size - design.shape[1] // len(xs) - 1, 1) for r in resid]
        sigma = [
            max(s * math.sqrt(float(np.sum(r**2)) / d), 1e-12 * scale)
            for s, r, d in zip(sigma, resid, dof, strict=True)
        ]
    weighted = rhs - design @ coef
    try:
        cov = stats.ar1_covariance(design, weighted, [x.size for x in xs])
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise FitError(f"the slope's error cannot be computed: {exc}") from exc
    return coef, design, weighted, sigma, cov


def _offset_p(coef: np.ndarray, cov: stats.Covariance) -> float:
    """p-value of the Wald test that every tare offset is zero (F on the covariance's dof)."""
    c = coef[1:]
    wald = float(c @ np.linalg.solve(cov.cov[1:, 1:], c))
    return float(scipy.stats.f.sf(wald / c.size, c.size, cov.dof))


def fit_lines(records: Sequence[Record]) -> LineFit:
    """Weighted least squares of ``y = c_f + E x`` over the used rows of all records.

    Weights 1 / s_f with s_f the residual rms of file f, iterated from the
    second-difference noise. The offsets are kept when a Wald test on the AR(1)
    covariance finds them (p < OFFSET_ALPHA) or when the residuals are correlated (then
    the noise's level at x = 0 is itself an offset; measured: through the origin, AR(1)
    0.95 noise gave 77 % coverage); otherwise the lines go through the origin, which is
    then known, and the slope is not paid for with an intercept per file.
    Raises FitError when the rows cannot give a slope and its error.
    """
    recs = [r for r in records if r.used.sum() > 0]
    xs = [r.x[r.used] for r in recs]
    ys = [r.y[r.used] for r in recs]
    n = sum(x.size for x in xs)
    if not recs or n < len(recs) + 2 or any(np.ptp(x) <= 0 for x in xs):
        raise FitError(
            "a slope with a tare offset per file needs 2 distinct x per file and a spare "
            f"point, got {n} points"
        )
    coef, design, weighted, sigma, cov = _solve(xs, ys, offsets=True)
    offsets = {r.name: float(coef[1 + f]) for f, r in enumerate(recs)}
    # correlated noise wanders: its level at x = 0 is an offset the test cannot rule out
    p = _offset_p(coef, cov) if cov.rho == 0.0 else 0.0
    if p >= OFFSET_ALPHA:
        coef, design, weighted, sigma, cov = _solve(xs, ys, offsets=False)
    segments = [x.size for x in xs]
    slope, se = float(coef[0]), float(cov.stderr[0])
    return LineFit(
        slope,
        se,
        stats.interval(slope, se, cov.dof),
        n,
        {name: value if p < OFFSET_ALPHA else 0.0 for name, value in offsets.items()},
        cov,
        stats.lack_of_fit(weighted, design.shape[1], segments=segments),
        {r.name: s for r, s in zip(recs, sigma, strict=True)},
        offsets,
        p,
    )


def check_sign(fit: LineFit, parameter: str, quantity: str, against: str) -> list[str]:
    """FitError for a slope <= 0; a warning when its interval reaches zero."""
    if fit.slope <= 0:
        raise FitError(
            f"{parameter} = {fit.slope:.3g} <= 0: {quantity} does not rise with {against} in the "
            "data taken together; no stiffness can be given. Check the channels and their signs"
        )
    if fit.ci95[0] <= 0:
        return [
            f"{parameter} is not distinguishable from zero (95 % interval {fit.ci95[0]:.3g} .. "
            f"{fit.ci95[1]:.3g}); measure over a wider range of {against}"
        ]
    return []


def left_out_info(records: Sequence[Record]) -> dict[str, dict[str, int]]:
    """file -> reason -> rows left out (files with none omitted)."""
    return {r.name: dict(r.left_out) for r in records if r.left_out}


def r2(records: Sequence[Record], fit: LineFit) -> float:
    """Coefficient of determination of the used rows against their mean."""
    y = np.concatenate([r.y[r.used] for r in records])
    resid = np.concatenate([(r.y - fit.model(r))[r.used] for r in records])
    total = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum(resid**2)) / total if total > 0 else float("nan")
