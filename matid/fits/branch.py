r"""The loading branch of a record and its linear range (docs/contract.md section 10).

A record (x, y) in recording order (twist angle and torque, tip angle and torque,
deflection and force) may start at a tare or at an absolute angle, load, hold, unload,
load again, or go past yield. A stiffness is the slope of ``y = c + a x`` on the rows that
such a line describes; they are found in two steps, each row left out with its reason.

1. **Branch** (:func:`branch`). x is followed in recording order with a hysteresis
   ``tol = max(4 s_x, q)`` (s_x the second-difference noise of x, q its smallest step): a
   reversal is a move back by more than tol from the last extreme. A row moving x away
   from its start value x_0 is loading; a row moving back towards x_0 is unloading
   (the turning rows belong to the loading they start or end). A run of rows over which
   x stays within tol, at least ``HOLD_ROWS`` long and ``HOLD_RATIO`` times the median
   run, is a hold; a run of y likewise (with y's own tol) is a held load, x creeping.
   No start at zero and no direction is assumed.
2. **Linear range** (:func:`linear_range`). Among the loading rows, ordered by x, the
   stretch ``x_lo <= x <= x_hi`` that ``y = c + a x`` describes within the noise:

   a. F-test of the line against ``c + a u + b u^2 + d u^3 + e u|u|`` (u: x scaled to
      [-1, 1]; u|u| for records symmetric about their middle),
      divided by the AR(1) variance factor of the noise and taken on n_eff dof
      (correlated noise is not curvature). The noise is the residual, in recording
      order, of a smooth Legendre series (degree <= 12): the alternative's own residuals
      would count a curve it misses as correlated noise. Passing: every row.
   b. Otherwise the onsets of departure at either end by segmented regression,
      ``y = c + a u + b_lo min(u - u_lo, 0)^2 + b_hi max(u - u_hi, 0)^2`` (C^1 departures:
      toe, backlash or tare below u_lo; yield, softening or stiffening above u_hi), u_lo
      and u_hi by alternating scans of least residual sum of squares (started from either
      end, the better kept); a side whose term is not significant (the same corrected
      F-test, at alpha / candidates: the onset is the best of many) stays at the end of
      the data, and so does the start's side when it would hold more than ``TOE_SHARE``
      of the rows (a curve bent from the start, not a toe). It uses the shape of the
      whole curve, unlike window tests that admit rows past an onset.
   c. While curvature is still significant inside, the end whose removal leaves the
      straighter stretch (p larger by ``TRIM_PREFERENCE``) is trimmed, else the end away
      from the first recorded row, down to ``min_points``.

:func:`select` applies this to one file, or, when its test has a ``window``, takes
exactly the window's rows instead (docs/contract.md section 10); a :class:`Record`
keeps the mask of the rows left out for each reason, for the report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.stats

from matid.errors import DataError
from matid.fits import stats

#: Significance level of the curvature and onset tests.
LINEAR_RANGE_ALPHA = 0.01
#: Fewest points a linear range may hold.
LINEAR_RANGE_MIN_POINTS = 6
#: At most this many onsets are tried (evenly spread) per scan.
LINEAR_RANGE_WINDOWS = 200
#: A hold is a run of constant x at least this many rows long ...
HOLD_ROWS = 10
#: ... and this many times the median run of the record.
HOLD_RATIO = 5.0

UNLOADING = "unloading (x moves back towards its start)"
HOLD = "hold (x constant)"
HELD_LOAD = "held load (y constant while x creeps)"
BEFORE = "before the linear range (toe, backlash or tare)"
BEYOND = "beyond the linear range"


def _tolerance(x: np.ndarray) -> float:
    steps = np.abs(np.diff(x))
    positive = steps[steps > 1e-12 * max(float(np.max(np.abs(x))), 1e-300)]
    quantum = float(positive.min()) if positive.size else 0.0
    return max(4.0 * stats.difference_noise(x), quantum)


def _directions(x: np.ndarray, tol: float) -> np.ndarray:
    """+1 / -1: the way x moves at each row (with hysteresis ``tol``); 0 before any move."""
    out = np.zeros(x.size, dtype=int)
    direction, extreme, at = 0, x[0], 0
    for i, xi in enumerate(x):
        if direction == 0:
            if abs(xi - x[0]) > tol:
                direction, extreme, at = int(np.sign(xi - x[0])), xi, i
                out[:i] = direction
        elif direction * (xi - extreme) >= 0:
            extreme, at = xi, i
        elif direction * (extreme - xi) > tol:
            direction, extreme = -direction, xi
            out[at + 1 : i] = direction  # the rows since the extreme were already going back
            at = i
        out[i] = direction
    return out


def _holds(x: np.ndarray, tol: float) -> np.ndarray:
    """Rows in runs over which x stays within ``tol`` of the run's first row, long ones only."""
    starts, first = [0], x[0]
    for i in range(1, x.size):
        if abs(x[i] - first) > tol:
            starts.append(i)
            first = x[i]
    bounds = np.r_[starts, x.size]
    lengths = np.diff(bounds)
    limit = max(HOLD_ROWS, HOLD_RATIO * float(np.median(lengths)))
    hold = np.zeros(x.size, dtype=bool)
    for a, n in zip(bounds[:-1], lengths, strict=True):
        if n >= limit:
            hold[a : a + n] = True
    return hold


def branch(x: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """Masks of the rows of a finite record that are not on its loading branch, by reason.

    ``{UNLOADING: mask, HOLD: mask, HELD_LOAD: mask}`` (module docstring, step 1); every
    other row loads. A held load (a field or force held while x creeps) is a hold of y.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    none = np.zeros(x.size, dtype=bool)
    if x.size < 3 or np.ptp(x) <= 0:
        return {UNLOADING: none, HOLD: none, HELD_LOAD: none}
    tol = _tolerance(x)
    moving = _directions(x, tol)
    first = moving[np.flatnonzero(moving)[0]] if moving.any() else 0
    reach = moving * (x - x[0])  # > 0: moving away from the start value
    # within tol of the start, only the first direction loads (not noise on the way back)
    away = (moving == 0) | (reach > tol) | ((moving == first) & (reach >= 0))
    loading = away | np.r_[away[1:], False]  # a turning row starts the loading after it
    hold = _holds(x, tol)
    held = (_holds(y, _tolerance(y)) if np.ptp(y) > 0 else none) & ~hold
    return {UNLOADING: ~loading & ~hold & ~held, HOLD: hold, HELD_LOAD: held}


# --------------------------------------------------------------------------- linear range


def _curvature_p(u: np.ndarray, y: np.ndarray, order: np.ndarray) -> float:
    """p-value of the corrected F-test of ``c + a u`` against ``c + a u + b u^2 + d u^3 + e u|u|``."""
    one = np.ones_like(u)
    null = np.column_stack([one, u])
    alt = np.column_stack([one, u, u**2, u**3, u * np.abs(u)])
    return _extra_p(null, alt, y, _noise_factor(u, y, order))


#: Degree of the smooth fit whose residuals give the noise's correlation (at most).
NOISE_DEGREE = 12


def _noise_factor(u: np.ndarray, y: np.ndarray, order: np.ndarray) -> tuple[float, float]:
    """(f, n_eff) of :func:`matid.fits.stats.variance_factor` on the residuals, in recording
    order, of a Legendre series of degree up to NOISE_DEGREE: a curve the test's
    alternative misses would otherwise be read as correlated noise, and hide itself."""
    degree = int(min(NOISE_DEGREE, max(3, u.size // 10)))
    scaled = (u - u.min()) / max(float(np.ptp(u)), 1e-300) * 2.0 - 1.0
    basis = np.polynomial.legendre.legvander(scaled, degree)
    # normal equations of an orthogonal basis on [-1, 1]: well conditioned, and ~100x
    # faster than an SVD least squares of the tall matrix on a loaded machine
    coef, _, rank, _ = np.linalg.lstsq(basis.T @ basis, basis.T @ y, rcond=None)
    resid = y - basis @ coef
    return stats.variance_factor(resid[np.argsort(order)], n_params=rank)


def _extra_p(null: np.ndarray, alt: np.ndarray, y: np.ndarray, noise: tuple[float, float]) -> float:
    """p-value of the F-test of nested designs, divided by the AR(1) variance factor
    ``noise = (f, n_eff)`` of the noise, on n_eff denominator dof."""
    rss0 = float(np.sum((y - null @ np.linalg.lstsq(null, y, rcond=None)[0]) ** 2))
    coef, _, rank, _ = np.linalg.lstsq(alt, y, rcond=None)
    rank0 = np.linalg.matrix_rank(null)
    resid = y - alt @ coef
    rss1 = float(np.sum(resid**2))
    q, dof = rank - rank0, y.size - rank
    if q < 1 or dof < 1:
        return 1.0
    if rss1 <= 0.0:
        return 0.0 if rss0 > 1e-24 * max(float(np.sum(y**2)), 1e-300) else 1.0
    factor, n_eff = noise
    f = max(rss0 - rss1, 0.0) / q / (rss1 / dof) / factor
    return float(scipy.stats.f.sf(f, q, max(n_eff - rank, 1.0)))


def _hinges(u: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Design of ``c + a u + b_lo min(u - lo, 0)^2 + b_hi max(u - hi, 0)^2``."""
    return np.column_stack([np.ones_like(u), u, np.minimum(u - lo, 0.0) ** 2, np.maximum(u - hi, 0.0) ** 2])


def _rss(design: np.ndarray, y: np.ndarray) -> float:
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    return float(np.sum((y - design @ coef) ** 2))


def _descent(
    u: np.ndarray, y: np.ndarray, lo: int, hi: int, *, high_first: bool, min_points: int, windows: int
):
    """Alternating scans of the onsets from (lo, hi), the upper one first or the lower one."""
    n = u.size
    for k in range(6):
        if (k % 2 == 0) == high_first:
            his = np.unique(np.linspace(lo + min_points - 1, n - 1, min(n, windows)).astype(int))
            hi = int(his[np.argmin([_rss(_hinges(u, u[lo], u[j]), y) for j in his])])
        else:
            los = np.unique(np.linspace(0, hi - min_points + 1, min(n, windows)).astype(int))
            lo = int(los[np.argmin([_rss(_hinges(u, u[j], u[hi]), y) for j in los])])
    return lo, hi


def _onsets(u: np.ndarray, y: np.ndarray, order: np.ndarray, *, alpha: float, min_points: int, windows: int):
    """(lo, hi) indices into the sorted u of the departures' onsets (module docstring, step b).

    The scans start from either end (a one-sided hinge at the far end is a quadratic over
    all the data and would trap a descent that began there); the better pair is kept.
    """
    n = u.size
    pairs = [
        _descent(u, y, 0, n - 1, high_first=first, min_points=min_points, windows=windows)
        for first in (True, False)
    ]
    lo, hi = min(pairs, key=lambda p: _rss(_hinges(u, u[p[0]], u[p[1]]), y))
    full, noise = _hinges(u, u[lo], u[hi]), _noise_factor(u, y, order)
    # each onset is the best of up to ``windows`` candidates: Bonferroni, or noise makes a side
    strict = alpha / min(n, windows)
    low = _extra_p(full[:, [0, 1, 3]], full, y, noise) < strict
    high = _extra_p(full[:, [0, 1, 2]], full, y, noise) < strict
    # a toe is a small part at the start of loading; "most of the record before the line"
    # is a curve bent from the start, whose linear range trimming then finds at the start
    if np.argmin(order) < n / 2:
        low &= lo <= TOE_SHARE * n
    else:
        high &= hi >= (1.0 - TOE_SHARE) * n
    return (lo if low else 0), (hi if high else n - 1)


def _p(u, y, order, lo: int, hi: int) -> float:
    return _curvature_p(u[lo : hi + 1], y[lo : hi + 1], order[lo : hi + 1])


#: At most this share of the loading rows may lie before the linear range on the start's side.
TOE_SHARE = 0.5
#: Trimming removes the end nearer the record's start only when that is this much straighter.
TRIM_PREFERENCE = 10.0


def _trim(
    u: np.ndarray, y: np.ndarray, order: np.ndarray, lo: int, hi: int, *, alpha: float, min_points: int
):
    """Trim the end whose removal leaves the straighter stretch until no curvature is left.

    When neither end is clearly straighter (a curve bent alike everywhere), the end away
    from the first recorded row goes: the stiffness is the one at the start of loading.
    """
    first = int(np.argmin(order))  # the first recorded row, in the sorted order
    while hi - lo + 1 > min_points and _p(u, y, order, lo, hi) < alpha:
        step = min(max(1, (hi - lo + 1) // 50), hi - lo + 1 - min_points)
        left, right = _p(u, y, order, lo + step, hi), _p(u, y, order, lo, hi - step)
        if abs(first - lo) <= abs(first - hi):  # the start is at the low end: keep it
            trim_left = left > TRIM_PREFERENCE * right
        else:
            trim_left = TRIM_PREFERENCE * left >= right
        lo, hi = (lo + step, hi) if trim_left else (lo, hi - step)
    return lo, hi


def linear_range(
    x: np.ndarray,
    y: np.ndarray,
    *,
    alpha: float = LINEAR_RANGE_ALPHA,
    min_points: int = LINEAR_RANGE_MIN_POINTS,
    max_windows: int = LINEAR_RANGE_WINDOWS,
) -> np.ndarray:
    """Mask of the rows in the linear range ``x_lo <= x <= x_hi`` of ``y = c + a x`` data.

    Rows are taken as recorded (their order is the order of the noise); the range is
    found in x (module docstring, step 2), with no start at zero or direction assumed.
    With ``min_points`` finite rows or fewer, all of them are returned.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 1 or x.shape != y.shape:
        raise ValueError("x and y must be 1-d arrays of the same length")
    if min_points < 3:
        raise ValueError(f"min_points must be at least 3, got {min_points}")
    ok = np.isfinite(x) & np.isfinite(y)
    index = np.flatnonzero(ok)[np.argsort(x[ok], kind="stable")]
    if index.size <= min_points or np.ptp(x[index]) <= 0:
        return ok
    xs = x[index]
    u, yy = (xs - 0.5 * (xs[0] + xs[-1])) / (0.5 * (xs[-1] - xs[0])), y[index]
    if _curvature_p(u, yy, index) >= alpha:
        return ok
    lo, hi = _onsets(u, yy, index, alpha=alpha, min_points=min_points, windows=max_windows)
    lo, hi = _trim(u, yy, index, lo, hi, alpha=alpha, min_points=min_points)
    return ok & (x >= xs[lo]) & (x <= xs[hi])


def departure(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """Mask of the linear range and the sign of the curvature just beyond its upper end.

    The sign is that of ``b_hi`` of the segmented fit over the whole (sorted) record: < 0
    where y falls below the line (yield, softening), > 0 where it rises above it; 0 when
    nothing lies beyond.
    """
    mask = linear_range(x, y)
    ok = np.isfinite(x) & np.isfinite(y)
    if not np.any(ok & ~mask & (x > np.max(x[mask], initial=-np.inf))):
        return mask, 0.0
    xs = np.sort(x[ok])
    u = (x[ok] - 0.5 * (xs[0] + xs[-1])) / (0.5 * (xs[-1] - xs[0]))
    hi = (np.max(x[mask]) - 0.5 * (xs[0] + xs[-1])) / (0.5 * (xs[-1] - xs[0]))
    design = _hinges(u, -np.inf, hi)[:, [0, 1, 3]]
    coef, *_ = np.linalg.lstsq(design, y[ok], rcond=None)
    return mask, float(np.sign(coef[2]))


# --------------------------------------------------------------------------- records


@dataclass(frozen=True)
class Record:
    """One file of a linear test: x and y of every row, the rows used, and why rows are out.

    ``excluded`` maps a reason ("outside the window", "not finite", "unloading ...",
    "hold ...", "before the linear range ...", "beyond the linear range") to the mask of
    the rows left out for it; ``flipped`` is True when y was negated by :func:`orient`.
    """

    name: str
    x: np.ndarray
    y: np.ndarray
    used: np.ndarray
    excluded: dict[str, np.ndarray] = field(default_factory=dict)
    flipped: bool = False

    @property
    def left_out(self) -> dict[str, int]:
        """Rows left out, counted by reason."""
        return {reason: int(mask.sum()) for reason, mask in self.excluded.items()}

    def leave_out(self, keep: np.ndarray, reason: str) -> Record:
        """The record with the used rows outside ``keep`` left out for ``reason``."""
        dropped = self.used & ~np.asarray(keep, dtype=bool)
        if not dropped.any():
            return self
        excluded = dict(self.excluded)
        excluded[reason] = excluded.get(reason, np.zeros(self.x.size, dtype=bool)) | dropped
        return replace(self, used=self.used & ~dropped, excluded=excluded)

    def rows_left_out(self) -> dict[str, list[list[int]]]:
        """reason -> [first, last] data-row ranges (0-based) left out for it."""
        out = {}
        for reason, mask in self.excluded.items():
            edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
            out[reason] = [[int(a), int(b) - 1] for a, b in zip(edges[::2], edges[1::2], strict=True)]
        return out


def record(name: str, x: np.ndarray, y: np.ndarray, window: np.ndarray) -> Record:
    """A record with the rows outside ``window`` and the non-finite rows left out."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    rec = Record(name, x, y, np.ones(x.size, dtype=bool))
    rec = rec.leave_out(np.asarray(window, dtype=bool), "outside the window")
    return rec.leave_out(np.isfinite(x) & np.isfinite(y), "not finite")


def automatic(rec: Record) -> Record:
    """The record cut to its loading branch's linear range (:mod:`matid.fits.branch`)."""
    idx = np.flatnonzero(rec.used)
    for reason, mask in branch(rec.x[idx], rec.y[idx]).items():
        keep = np.ones(rec.x.size, dtype=bool)
        keep[idx[mask]] = False
        rec = rec.leave_out(keep, reason)
    idx = np.flatnonzero(rec.used)
    if idx.size == 0:
        return rec
    inside = np.zeros(rec.x.size, dtype=bool)
    inside[idx] = linear_range(rec.x[idx], rec.y[idx])
    x0, xs = rec.x[idx[0]], rec.x[inside]
    near = np.abs(rec.x - x0) < np.min(np.abs(xs - x0), initial=np.inf)
    rec = rec.leave_out(inside | ~near, BEFORE)
    return rec.leave_out(inside, BEYOND)


def select(
    name: str,
    x: np.ndarray,
    y: np.ndarray,
    window: np.ndarray,
    ranges: Mapping[str, tuple[float, float]],
    *,
    file,
) -> Record:
    """The rows of one file that enter a line fit.

    With a ``window`` (``ranges``: the test's column -> (low, high), SI) exactly its
    finite rows, at least LINEAR_RANGE_MIN_POINTS of them (else DataError naming the
    window); without one, the loading branch's linear range (:func:`automatic`).
    """
    rec = record(name, x, y, window)
    if not ranges:
        if not rec.used.any():
            raise DataError("no row with finite values", file=file)
        return automatic(rec)
    if rec.used.sum() < LINEAR_RANGE_MIN_POINTS:
        text = ", ".join(f"{column} = [{lo:.6g}, {hi:.6g}]" for column, (lo, hi) in ranges.items())
        raise DataError(
            f"the window {{{text}}} (SI) holds {int(rec.used.sum())} rows with finite values; a line "
            f"with an offset needs at least {LINEAR_RANGE_MIN_POINTS}: widen the window",
            file=file,
        )
    return rec


def left_out_info(records: Sequence[Record]) -> dict[str, dict[str, int]]:
    """file -> reason -> rows left out (files with none omitted)."""
    return {r.name: dict(r.left_out) for r in records if r.left_out}


def rows_info(records: Sequence[Record]) -> dict[str, dict[str, list[list[int]]]]:
    """file -> reason -> [first, last] row ranges left out (files with none omitted)."""
    return {r.name: r.rows_left_out() for r in records if r.excluded}


def range_info(records: Sequence[Record]) -> dict[str, list[float]]:
    """file -> [x_min, x_max] of the rows fitted."""
    return {r.name: [float(np.min(r.x[r.used])), float(np.max(r.x[r.used]))] for r in records if r.used.any()}
