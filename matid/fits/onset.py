r"""The linear range of a record: the stretch of x that ``y = c + a x`` describes within the noise.

Rows are the loading rows of :mod:`matid.fits.branch`, in recording order (the order of
the noise); the range is found in x, with no start at zero or direction assumed:

   a. F-test of the line against ``c + a u + b u^2 + d u^3 + e u|u|`` (u: x scaled to
      [-1, 1]; u|u| for records symmetric about their middle),
      divided by the AR(1) variance factor of the noise and taken on n_eff dof
      (correlated noise is not curvature). The noise is the residual, in recording
      order, of a smooth Legendre series (degree <= 12, raised while it misses a curve by
      more than twice the model-free noise, as a yield's kink): the alternative's own residuals
      would count a curve it misses as correlated noise. Passing: every row.
   b. Otherwise the onsets of departure at either end by segmented regression,
      ``y = c + a u + b_lo min(u - u_lo, 0)^2 + b_hi max(u - u_hi, 0)^2`` (C^1 departures:
      toe, backlash or tare below u_lo; yield, softening or stiffening above u_hi), u_lo
      and u_hi by alternating scans of least residual sum of squares (started from either
      end, the better kept); a side whose term is not significant (the same corrected
      F-test, at alpha / candidates: the onset is the best of many) stays at the end of
      the data, and so does the start's side when it would hold more than ``TOE_SHARE``
      of the rows (a curve bent from the start, not a toe); so does the far side when the
      same departure started at the near onset fits as well (:func:`_distinct`: the "line"
      between them is the start of a curve). It uses the shape of the whole curve, unlike
      window tests that admit rows past an onset.
   c. While curvature is still significant inside, the end whose removal leaves the
      straighter stretch (p larger by ``TRIM_PREFERENCE``) is trimmed, else the end away
      from the first recorded row, down to ``LINEAR_RANGE_MIN_POINTS``.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.special

from matid.fits import stats

#: Significance level of the curvature and onset tests.
LINEAR_RANGE_ALPHA = 0.01
#: Fewest points a linear range may hold.
LINEAR_RANGE_MIN_POINTS = 6
#: At most this many onsets are tried (evenly spread) per scan.
LINEAR_RANGE_WINDOWS = 200


def _curvature_p(u: np.ndarray, y: np.ndarray, order: np.ndarray) -> float:
    """p-value of the corrected F-test of ``c + a u`` against ``c + a u + b u^2 + d u^3 + e u|u|``."""
    one = np.ones_like(u)
    null = np.column_stack([one, u])
    alt = np.column_stack([one, u, u**2, u**3, u * np.abs(u)])
    return _extra_p(null, alt, y, _noise_factor(u, y, order))


#: Degree of the smooth fit whose residuals give the noise's correlation (at most).
NOISE_DEGREE = 12


#: The series follows the curve until its residuals are within this factor of the model-free
#: noise (second differences) ...
NOISE_FOLLOWS = 2.0
#: ... raising its degree by this factor, up to one degree per ten rows and NOISE_DEGREE_MAX.
NOISE_DEGREE_GROWTH = 1.5
NOISE_DEGREE_MAX = 40


def _noise_factor(u: np.ndarray, y: np.ndarray, order: np.ndarray) -> tuple[float, float]:
    """(f, n_eff) of :func:`matid.fits.stats.variance_factor` on the residuals, in recording
    order, of a Legendre series of degree up to NOISE_DEGREE: a curve the test's
    alternative misses would otherwise be read as correlated noise, and hide itself.

    A curve that a series of that degree cannot follow either (a kink in the slope, as a yield's,
    on a record of low noise) leaves residuals far above the noise, and they would be read as
    noise of correlation near 1 (rho 0.98 on a flexural coupon: factor 81, the yield unseen). So
    while the residuals' sd exceeds NOISE_FOLLOWS x the model-free noise of
    :func:`matid.fits.stats.difference_noise`, the degree rises by NOISE_DEGREE_GROWTH, up to one
    per ten rows and NOISE_DEGREE_MAX (at most four more fits). Noise itself (i.i.d. residuals
    about the model-free level, or AR(1) up to rho ~0.7, whose sd lies within that factor of its
    second-difference level) stops it at once.
    """
    degree = int(min(NOISE_DEGREE, max(6, u.size // 10)))
    top = max(degree, min(u.size // 10, NOISE_DEGREE_MAX))
    scaled = (u - u.min()) / max(float(np.ptp(u)), 1e-300) * 2.0 - 1.0
    level = NOISE_FOLLOWS * stats.difference_noise(y[np.argsort(order)])
    while True:
        resid, rank = _legendre_fit(scaled, y, degree)  # orthogonal on [-1, 1]
        if degree >= top or float(np.sqrt(np.mean(resid**2))) <= level:
            return stats.variance_factor(resid[np.argsort(order)], n_params=rank)
        degree = min(int(math.ceil(degree * NOISE_DEGREE_GROWTH)), top)


def _legendre_fit(x: np.ndarray, y: np.ndarray, degree: int) -> tuple[np.ndarray, int]:
    """:func:`_fit` of the Legendre series of ``degree`` in x (in [-1, 1]) to y. On a record of more
    than SCAN_BLOCK values of its Vandermonde matrix, the normal equations and the residuals are
    built a block of rows at a time: the whole matrix of a 7.4e6-row record is 770 MB."""
    rows = max(1, SCAN_BLOCK // (degree + 1))
    if x.size <= rows:
        return _fit(np.polynomial.legendre.legvander(x, degree), y)
    blocks = [slice(a, a + rows) for a in range(0, x.size, rows)]
    normal, right = np.zeros((degree + 1, degree + 1)), np.zeros(degree + 1)
    for b in blocks:
        design = np.polynomial.legendre.legvander(x[b], degree)
        normal += design.T @ design
        right += design.T @ y[b]
    coef, _, rank, _ = np.linalg.lstsq(normal, right, rcond=None)
    resid = np.empty(x.size)
    for b in blocks:
        resid[b] = y[b] - np.polynomial.legendre.legvander(x[b], degree) @ coef
    return resid, int(rank)


def _extra_p(null: np.ndarray, alt: np.ndarray, y: np.ndarray, noise: tuple[float, float]) -> float:
    """p-value of the F-test of nested designs, divided by the AR(1) variance factor
    ``noise = (f, n_eff)`` of the noise, on n_eff denominator dof (``scipy.special.fdtrc``: the
    survival function of ``scipy.stats.f``, the same value without its per-call cost)."""
    resid0, rank0 = _fit(null, y)
    rss0 = float(np.sum(resid0**2))
    resid, rank = _fit(alt, y)
    rss1 = float(np.sum(resid**2))
    q, dof = rank - rank0, y.size - rank
    if q < 1 or dof < 1:
        return 1.0
    if rss1 <= 0.0:
        return 0.0 if rss0 > 1e-24 * max(float(np.sum(y**2)), 1e-300) else 1.0
    factor, n_eff = noise
    f = max(rss0 - rss1, 0.0) / q / (rss1 / dof) / factor
    return float(scipy.special.fdtrc(q, max(n_eff - rank, 1.0), f))


def _hinges(u: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Design of ``c + a u + b_lo min(u - lo, 0)^2 + b_hi max(u - hi, 0)^2``."""
    return np.column_stack([np.ones_like(u), u, np.minimum(u - lo, 0.0) ** 2, np.maximum(u - hi, 0.0) ** 2])


def _fit(design: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, int]:
    """Residuals and rank of the least-squares fit of ``design`` to ``y`` (one column or more) by
    the normal equations, rank deficiency allowed: accurate for a few columns of order one, and
    ~100x cheaper than an SVD of the tall matrix (the onset scans make ~10^3 fits)."""
    coef, _, rank, _ = np.linalg.lstsq(design.T @ design, design.T @ y, rcond=None)
    return y - design @ coef, int(rank)


def _rss(design: np.ndarray, y: np.ndarray) -> float:
    """Residual sum of squares of the least-squares fit of ``design``."""
    return float(np.sum(_fit(design, y)[0] ** 2))


def _scan(fixed: np.ndarray, columns: np.ndarray, y: np.ndarray) -> np.ndarray:
    """RSS of ``y`` on ``fixed`` plus each column of ``columns`` in turn (n x K), at once.

    With P the projection off ``fixed``: RSS_k = |Py|^2 - (Ph_k . Py)^2 / |Ph_k|^2.
    """
    resid, _ = _fit(fixed, np.column_stack([y, columns]))
    ry, rh = resid[:, 0], resid[:, 1:]
    norm = np.sum(rh**2, axis=0)
    gain = np.divide(
        (rh.T @ ry) ** 2, norm, out=np.zeros_like(norm), where=norm > 1e-12 * max(float(norm.max()), 1e-300)
    )
    return float(ry @ ry) - gain


#: Elements of one block of candidate columns in :func:`_best` (memory bound on long records).
SCAN_BLOCK = 4_000_000


def _best(fixed: np.ndarray, make, candidates: np.ndarray, y: np.ndarray) -> int:
    """The candidate onset whose column ``make(c)`` on top of ``fixed`` leaves the least RSS
    (:func:`_scan` over the candidates, a block at a time)."""
    size = max(1, SCAN_BLOCK // y.size)
    rss = [_scan(fixed, make(candidates[i : i + size]), y) for i in range(0, candidates.size, size)]
    return int(candidates[np.argmin(np.concatenate(rss))])


def _descent(u: np.ndarray, y: np.ndarray, lo: int, hi: int, *, high_first: bool):
    """Alternating scans of the onsets from (lo, hi), the upper one first or the lower one."""
    n, one, m = u.size, np.ones_like(u), min(u.size, LINEAR_RANGE_WINDOWS)
    for k in range(6):
        if (k % 2 == 0) == high_first:
            his = np.unique(np.linspace(lo + LINEAR_RANGE_MIN_POINTS - 1, n - 1, m).astype(int))
            fixed = np.column_stack([one, u, np.minimum(u - u[lo], 0.0) ** 2])
            hi = _best(fixed, lambda c: np.maximum(u[:, None] - u[c], 0.0) ** 2, his, y)
        else:
            los = np.unique(np.linspace(0, hi - LINEAR_RANGE_MIN_POINTS + 1, m).astype(int))
            fixed = np.column_stack([one, u, np.maximum(u - u[hi], 0.0) ** 2])
            lo = _best(fixed, lambda c: np.minimum(u[:, None] - u[c], 0.0) ** 2, los, y)
    return lo, hi


def _onsets(u: np.ndarray, y: np.ndarray, order: np.ndarray):
    """(lo, hi) indices into the sorted u of the departures' onsets (module docstring, step b).

    The scans start from either end (a one-sided hinge at the far end is a quadratic over
    all the data and would trap a descent that began there); the better pair is kept.
    """
    n = u.size
    pairs = [_descent(u, y, 0, n - 1, high_first=first) for first in (True, False)]
    lo, hi = min(pairs, key=lambda p: _rss(_hinges(u, u[p[0]], u[p[1]]), y))
    full, noise = _hinges(u, u[lo], u[hi]), _noise_factor(u, y, order)
    # each onset is the best of up to LINEAR_RANGE_WINDOWS candidates: Bonferroni, or noise makes a side
    strict = LINEAR_RANGE_ALPHA / min(n, LINEAR_RANGE_WINDOWS)
    low = _extra_p(full[:, [0, 1, 3]], full, y, noise) < strict
    high = _extra_p(full[:, [0, 1, 2]], full, y, noise) < strict
    # a toe is a small part at the start of loading; "most of the record before the line"
    # is a curve bent from the start, whose linear range trimming then finds at the start
    # likewise a departure on the far side that the data cannot tell from one at the near onset
    # (the hinge's quadratic then covers the whole record) is a curve bent from the start
    if np.argmin(order) < n / 2:
        low &= lo <= TOE_SHARE * n
        high &= _distinct(u, y, full, lo, hi, noise, far=3)
    else:
        high &= hi >= (1.0 - TOE_SHARE) * n
        low &= _distinct(u, y, full, hi, lo, noise, far=2)
    return (lo if low else 0), (hi if high else n - 1)


def _distinct(u, y, full: np.ndarray, near: int, onset: int, noise, *, far: int) -> bool:
    """Whether the far side's departure at ``onset`` fits better than the same departure started
    at the near onset ``near`` (no line between them), by the corrected F-test at
    LINEAR_RANGE_ALPHA on one dof: else the stretch between the onsets is no line but the start
    of a curve (a closed tube on a machine angle channel: an onset 11 rows into 1143)."""
    moved = full.copy()
    moved[:, far] = (np.maximum if far == 3 else np.minimum)(u - u[near], 0.0) ** 2
    rss_far, rss_near = _rss(full, y), _rss(moved, y)
    dof = y.size - full.shape[1]
    if rss_far <= 0.0 or dof < 1 or onset == near:
        return True
    factor, n_eff = noise
    f = max(rss_near - rss_far, 0.0) / (rss_far / dof) / factor
    return float(scipy.special.fdtrc(1, max(n_eff - full.shape[1], 1.0), f)) < LINEAR_RANGE_ALPHA


def _p(u, y, order, lo: int, hi: int) -> float:
    return _curvature_p(u[lo : hi + 1], y[lo : hi + 1], order[lo : hi + 1])


#: At most this share of the loading rows may lie before the linear range on the start's side.
TOE_SHARE = 0.5
#: Trimming removes the end nearer the record's start only when that is this much straighter.
TRIM_PREFERENCE = 10.0


def _trim(u: np.ndarray, y: np.ndarray, order: np.ndarray, lo: int, hi: int):
    """Trim the end whose removal leaves the straighter stretch until no curvature is left.

    When neither end is clearly straighter (a curve bent alike everywhere), the end away
    from the first recorded row goes: the stiffness is the one at the start of loading.
    """
    first = int(np.argmin(order))  # the first recorded row, in the sorted order
    known: dict[tuple[int, int], float] = {}  # the stretch kept is one of the two just tested

    def p(a: int, b: int) -> float:
        if (a, b) not in known:
            known[a, b] = _p(u, y, order, a, b)
        return known[a, b]

    while hi - lo + 1 > LINEAR_RANGE_MIN_POINTS and p(lo, hi) < LINEAR_RANGE_ALPHA:
        step = min(max(1, (hi - lo + 1) // 50), hi - lo + 1 - LINEAR_RANGE_MIN_POINTS)
        left, right = p(lo + step, hi), p(lo, hi - step)
        if abs(first - lo) <= abs(first - hi):  # the start is at the low end: keep it
            trim_left = left > TRIM_PREFERENCE * right
        else:
            trim_left = TRIM_PREFERENCE * left >= right
        lo, hi = (lo + step, hi) if trim_left else (lo, hi - step)
    return lo, hi


def linear_range(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Mask of the rows in the linear range ``x_lo <= x <= x_hi`` of ``y = c + a x`` data, rows
    in recording order (module docstring); with LINEAR_RANGE_MIN_POINTS finite rows or fewer,
    all of them."""
    return linear_ranges(x, y)[0]


def linear_ranges(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(linear range, accepted range): the mask of :func:`linear_range` and that of the rows
    between the onsets of step b, before trimming: the stretch the onset test cannot tell from
    one line at its (Bonferroni-strict) level. Where the slope differs between the two, the
    choice of range is part of the slope's uncertainty (:func:`matid.fits.linear.range_spread`)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 1 or x.shape != y.shape:
        raise ValueError("x and y must be 1-d arrays of the same length")
    ok = np.isfinite(x) & np.isfinite(y)
    index = np.flatnonzero(ok)[np.argsort(x[ok], kind="stable")]
    if index.size <= LINEAR_RANGE_MIN_POINTS or np.ptp(x[index]) <= 0:
        return ok, ok
    xs = x[index]
    u, yy = (xs - 0.5 * (xs[0] + xs[-1])) / (0.5 * (xs[-1] - xs[0])), y[index]
    if _curvature_p(u, yy, index) >= LINEAR_RANGE_ALPHA:
        return ok, ok
    first = _onsets(u, yy, index)
    lo, hi = _trim(u, yy, index, *first)
    accepted = ok & (x >= xs[first[0]]) & (x <= xs[first[1]])
    return ok & (x >= xs[lo]) & (x <= xs[hi]), accepted


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
