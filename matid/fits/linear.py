r"""Lines with a tare offset: the shared core of E_b and E_t (physics.md section 2).

Both stiffnesses are slopes: torque against tip_angle / free_length (magnetic bending,
:mod:`matid.fits.bending`) and torque against twist_angle / length (torsion,
:mod:`matid.fits.torsion`). Real channels carry a tare offset (a torque meter zeroed
under a small preload, an angle read from a shifted zero), so each file f gets its own
intercept c_f and all files of a specimen share the slope E::

    y_fi = c_f + E x_fi + e_fi                       (:func:`fit_lines`)

fitted by weighted least squares as an lmfit ``Model`` per file (the slope a shared ``Parameter``,
each offset its own, ``vary=False`` where a value is fixed: the offsets at 0 for lines through the
origin, or the slope given), each file weighted by 1 / s_f^2 with s_f its own residual rms
(iterated; a short tube twisted further is noisier). When the offsets are not significant (Wald
test, p >= OFFSET_ALPHA) the lines go through the origin: an offset per file would cost precision
for nothing. Atop lmfit's result, matid gives the interval as the AR(1) sandwich of
:mod:`matid.fits.stats` on Student's t with n_eff - p dof (at least the HC3 variance: noise growing
along the line), so it holds for dense records whose noise is correlated, and widens when the line
misses the data; :func:`matid.fits.stats.lack_of_fit` then names the misfit in a warning. A line
that misses the data, or holds few of the loading rows, is not the curve's one slope: its interval
then also spans the slopes over plausible ranges (:func:`range_spread`), since the noise of one
chosen range does not say what the choice moves. Which rows enter: :func:`matid.fits.branch.select`,
each row left out with its reason.

Sign: physics makes E > 0 (torque rises with twist, the magnet's torque with tip angle).
A file whose slope on its fitted rows is clearly negative (t < -SIGN_T) has a flipped
sign convention: it is negated and a warning says so (:func:`orient`), unless its torque is
computed from the field and angles. A joint slope <= 0 is never a result (FitError).

Warnings carry a machine-readable kind (:class:`Warning`, ``Estimate.extra
["warning_kinds"]``) so that a status per value can be decided from them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import lmfit
import numpy as np
import scipy.stats
from scipy.linalg import block_diag

from matid.errors import FitError
from matid.fits import branch, stats
from matid.fits.branch import Record
from matid.model.results import Estimate, Series, TestFit

#: Tare offsets are fitted when the Wald test of "all offsets zero" gives p below this.
#: Large on purpose: a real offset dropped biases the slope, an absent one kept only costs
#: precision, so offsets go only when the data agree with none (measured at 0.05: E_b
#: intervals covered 90 of 100 and per-length slopes "disagreed" in 20 of 100 i.i.d. trials
#: with an offset of 0.3 % of full scale).
OFFSET_ALPHA = 0.5
#: A file's own slope below -SIGN_T standard errors means its sign convention is flipped.
SIGN_T = 3.0


# --------------------------------------------------------------------------- records


def _line(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(slope, its standard error) of y = c + b x; se inf when undetermined."""
    if x.size < 3 or np.ptp(x) <= 0:
        return 0.0, math.inf
    design = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    s2 = float(np.sum((y - design @ coef) ** 2)) / (x.size - 2)
    return float(coef[1]), math.sqrt(s2 / float(np.sum((x - x.mean()) ** 2)))


@dataclass(frozen=True)
class Warning:
    """A warning of a fit: its text and a machine-readable kind for the value's status."""

    kind: str  # sign_flipped, zero_in_interval, little_linear, misfit, range_spread, slopes_disagree
    text: str


def orient(records: Sequence[Record], quantity: str, against: str) -> tuple[list[Record], list[Warning]]:
    """Negate the y of every record whose own slope on its used rows is clearly negative; say so.

    Physics makes ``quantity`` rise with ``against``; a slope below -SIGN_T standard
    errors is a flipped sign convention (a torque meter mounted the other way round), never
    in a ``computed`` record (no meter: a falling line there is left to :func:`check_sign`)."""
    out, warnings = [], []
    for rec in records:
        slope, se = _line(rec.x[rec.used], rec.y[rec.used])
        if slope < 0 and slope < -SIGN_T * se and not rec.computed:
            out.append(replace(rec, y=-rec.y, flipped=True))
            warnings.append(
                Warning(
                    "sign_flipped",
                    f"{rec.name}: {quantity} falls as {against} rises (slope {slope:.3g}, t = "
                    f"{slope / se:.1f}); taken as a flipped sign convention and {quantity} negated. "
                    f'Check the channel\'s polarity, or set negate = ["{quantity}"] on the test',
                )
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


def tared_line(x: np.ndarray, slope: float = 1.0, offset: float = 0.0) -> np.ndarray:
    """The line with a tare offset: ``y = offset + slope * x``."""
    return offset + slope * x


def _parameters(n_files: int, offsets: bool, slope: float):
    """The shared slope and one offset per file, held at 0 (``vary=False``) without offsets."""
    params = lmfit.Parameters()
    params.add("slope", value=slope)
    for f in range(n_files):
        params.add(f"f{f}_slope", expr="slope")
        params.add(f"f{f}_offset", value=0.0, vary=offsets)
    return params


def _residual(params, models, xs, ys, w) -> np.ndarray:
    """Weighted residuals ``w_f (y - c_f - E x)`` of every file, concatenated in file order."""
    return np.concatenate(
        [wf * (y - m.eval(params, x=x)) for m, x, y, wf in zip(models, xs, ys, w, strict=True)]
    )


def _design(xs: Sequence[np.ndarray], w: Sequence[float], offsets: bool) -> np.ndarray:
    """Weighted Jacobian of the model: column 0 the slope, column 1 + f the offset of file f."""
    slope = np.concatenate([wf * x for x, wf in zip(xs, w, strict=True)])[:, None]
    if not offsets:
        return slope
    return np.hstack([slope, block_diag(*[np.full((x.size, 1), wf) for x, wf in zip(xs, w, strict=True)])])


def _solve(xs, ys, offsets: bool):
    """Iteratively reweighted lmfit fit, one Model :func:`tared_line` per file (prefix ``f<i>_``):
    (slope and offset of each file, weighted design, weighted residuals, sigma, covariance)."""
    scale = float(np.max(np.abs(np.concatenate(ys)))) or 1.0
    sigma = [stats.difference_noise(y) or 1e-9 * scale for y in ys]
    models = [lmfit.Model(tared_line, prefix=f"f{f}_") for f in range(len(xs))]
    params = _parameters(len(xs), offsets, _line(np.concatenate(xs), np.concatenate(ys))[0] or 1.0)
    for _ in range(4):
        w = [1.0 / s for s in sigma]
        result = lmfit.minimize(_residual, params, args=(models, xs, ys, w), method="leastsq")
        params = result.params
        resid = np.split(result.residual, np.cumsum([x.size for x in xs])[:-1])
        dof = [max(r.size - result.nvarys // len(xs) - 1, 1) for r in resid]
        sigma = [
            max(s * math.sqrt(float(np.sum(r**2)) / d), 1e-12 * scale)
            for s, r, d in zip(sigma, resid, dof, strict=True)
        ]
    w = [1.0 / s for s in sigma]
    weighted = _residual(params, models, xs, ys, w)
    design = _design(xs, w, offsets)
    try:
        cov = stats.ar1_covariance(design, weighted, [x.size for x in xs])
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise FitError(f"the slope's error cannot be computed: {exc}") from exc
    coef = np.array([params["slope"].value] + [params[f"f{f}_offset"].value for f in range(len(xs))])
    return coef, design, weighted, sigma, cov


def _offset_p(coef: np.ndarray, cov: stats.Covariance) -> float:
    """p-value of the Wald test that every tare offset is zero (F on the covariance's dof)."""
    c = coef[1:]
    wald = float(c @ np.linalg.solve(cov.cov[1:, 1:], c))
    return float(scipy.stats.f.sf(wald / c.size, c.size, cov.dof))


def fit_lines(records: Sequence[Record]) -> LineFit:
    """Weighted least squares of ``y = c_f + E x`` over the used rows of all records (module
    docstring). The offsets are also kept when the residuals are correlated: the noise's level
    at x = 0 is then itself an offset (measured: through the origin, AR(1) 0.95 noise gave 77 %
    coverage). Raises FitError when the rows cannot give a slope and its error.
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
    cov = stats.heteroscedastic_floor(design, weighted, cov)  # after the offsets' test
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


def check_sign(fit: LineFit, parameter: str, quantity: str, against: str) -> list[Warning]:
    """FitError for a slope <= 0; a warning when its interval reaches zero."""
    if fit.slope <= 0:
        raise FitError(
            f"{parameter} = {fit.slope:.3g} <= 0: {quantity} does not rise with {against} in the "
            "data taken together; no stiffness can be given. Check the channels and their signs"
        )
    if fit.ci95[0] <= 0:
        text = (
            f"{parameter} is not distinguishable from zero (95 % interval {fit.ci95[0]:.3g} .. "
            f"{fit.ci95[1]:.3g}); measure over a wider range of {against}"
        )
        return [Warning("zero_in_interval", text)]
    return []


#: Below this share of a file's loading rows in the linear range, the estimate carries a warning.
MIN_LINEAR_SHARE = 0.5


def _share(r: Record) -> tuple[int, int, bool]:
    """(rows in the linear range, loading rows, whether that is under MIN_LINEAR_SHARE) of a record."""
    used = int(r.used.sum())
    loading = used + sum(int(r.excluded[k].sum()) for k in (branch.BEFORE, branch.BEYOND) if k in r.excluded)
    return used, loading, loading > used and used < MIN_LINEAR_SHARE * loading


def share_warnings(records: Sequence[Record]) -> list[Warning]:
    """A warning for each file whose linear range holds under MIN_LINEAR_SHARE of its loading rows."""
    shares = [(r.name, *_share(r)) for r in records]
    text = "{}: only {} of {} loading points are in the linear range"
    return [Warning("little_linear", text.format(*s[:3])) for s in shares if s[3]]


#: After these warnings the line is not the data's one slope: its interval carries the range's choice.
RANGE_KINDS = ("misfit", "little_linear")


def _extended(r: Record) -> list[np.ndarray]:
    """The fitted rows extended over the loading rows left out before them, after them, and both:
    the ranges a reader takes who does not share the onset test's choice. For a record whose linear
    range holds few of its loading rows (:func:`_share`) only; else none."""
    if not _share(r)[2]:
        return []
    none = np.zeros(r.x.size, dtype=bool)
    before, beyond = (r.excluded.get(k, none) for k in (branch.BEFORE, branch.BEYOND))
    return [r.used | before, r.used | beyond, r.used | before | beyond]


def range_slopes(records: Sequence[Record]) -> list[float]:
    """Slopes of ``y = c + b x`` over each half (in x) of each record's fitted rows and of the rows
    its onset test accepts as one line (``Record.accepted``), and, where the linear range holds few
    of the loading rows, over the fitted rows extended to either end of the loading (:func:`_extended`;
    whole, not halved): the slopes a reader could have taken as "the" slope of a curve that has none.
    Halves or ranges with under 3 distinct rows give none."""
    out = []
    for r in records:
        for mask in (r.used, r.accepted):
            if mask is None or not mask.any():
                continue
            x, y = r.x[mask], r.y[mask]
            for half in np.array_split(np.argsort(x, kind="stable"), 2):
                slope, se = _line(x[half], y[half])
                if math.isfinite(se):
                    out.append(slope)
        for mask in _extended(r):
            slope, se = _line(r.x[mask], r.y[mask])
            if math.isfinite(se):
                out.append(slope)
    return out


def range_spread(
    records: Sequence[Record], fit: LineFit, warnings: Sequence[Warning], parameter: str, advice: str
) -> tuple[LineFit, list[Warning]]:
    """The fit with its interval widened to the spread of :func:`range_slopes`, and why, after a warning
    of RANGE_KINDS (a misfit, few loading rows in the range) or where a record bends (:func:`branch.bent`):
    the noise of one range understates what the choice moves. Else, or inside the interval, unchanged."""
    bent = branch.bent(records)
    if not (bent or any(w.kind in RANGE_KINDS for w in warnings)):
        return fit, []
    slopes = range_slopes(records)
    low, high = min(slopes, default=fit.ci95[0]), max(slopes, default=fit.ci95[1])
    if fit.ci95[0] <= low and high <= fit.ci95[1]:
        return fit, []
    ci = (min(fit.ci95[0], low), max(fit.ci95[1], high))
    extended = ", and over them extended to either end of the loading" if any(map(_extended, records)) else ""
    text = (
        f"{bent}{parameter} depends on the range fitted: over the halves of the rows fitted and of the rows "
        f"the onset test accepts as one line{extended}, the slope runs from {low:.4g} to {high:.4g}; the "
        f"95 % interval ({ci[0]:.4g} to {ci[1]:.4g}) includes this spread. Set a window to the range "
        f"you mean, or record more points in the small-strain range. {advice}"
    ).rstrip()
    return replace(fit, ci95=ci), [Warning("range_spread", text)]


def fit_slope(
    records: Sequence[Record], *, specimen: str, parameter: str, against: str, model: str, advice: str
) -> tuple[list[Record], LineFit, list[Warning]]:
    """Records oriented (:func:`orient`), their joint line, and its warnings: sign, linear share,
    the lack-of-fit warning of :mod:`matid.fits.stats` naming ``model``, and after either of
    those the spread of the slope over plausible ranges (:func:`range_spread`)."""
    records, warnings = orient(records, "torque", against)
    try:
        fit = fit_lines(records)
        warnings += check_sign(fit, parameter, "torque", against)
    except FitError as exc:
        raise FitError(f"specimen {specimen}: {exc}") from exc
    warnings += share_warnings(records)
    text = fit.lof.warning(model, fit.inflation, advice)
    warnings += [Warning("misfit", text)] if text else []
    fit, spread = range_spread(records, fit, warnings, parameter, advice)
    return records, fit, warnings + spread


def slope_result(kind: str, specimen: str, measurements, parameter: str, line, lengths, x_label: str, info):
    """The TestFit of a slope: ``line`` = (records, fit, warnings) of :func:`fit_slope`, one series
    per file labelled with its length. The estimate's extra holds ``warning_kinds`` (the
    warnings' kinds in their order) and ``fitted_rows`` (file -> rows fitted), from which a
    status per value weighs how much the slope rests on."""
    records, fit, warnings = line
    series = tuple(
        Series(f"{r.name} (L = {length * 1e3:.4g} mm)", r.x, r.y, fit.model(r), r.used)
        for r, length in zip(records, lengths, strict=True)
    )
    extra = {
        "ci_method": "t-ar1" if fit.covariance.rho else "t",
        "tare_offset_N_m": fit.intercepts,
        "warning_kinds": tuple(w.kind for w in warnings),
        "fitted_rows": {r.name: int(r.used.sum()) for r in records},
    }
    texts = tuple(w.text for w in warnings)
    return TestFit(
        kind=kind,
        specimen=specimen,
        tests=tuple(m.test for m in measurements),
        estimates=(Estimate(parameter, *fit.value, "linear", texts, extra),),
        series=series,
        x_label=x_label,
        y_label="torque [N m]",
        info={**info, **fit.info()},
    )


def r2(records: Sequence[Record], fit: LineFit) -> float:
    """Coefficient of determination of the used rows against their mean."""
    y = np.concatenate([r.y[r.used] for r in records])
    resid = np.concatenate([(r.y - fit.model(r))[r.used] for r in records])
    total = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum(resid**2)) / total if total > 0 else float("nan")
