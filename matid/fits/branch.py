r"""The loading branch of a record and its linear range (docs/contract.md section 10).

A record (x, y) in recording order (twist angle and torque, tip angle and torque,
deflection and force) may start at a tare or at an absolute angle, load, hold, unload,
load again, or go past yield. A stiffness is the slope of ``y = c + a x`` on the rows that
such a line describes; they are found in two steps, each row left out with its reason.

1. **Branch** (:func:`branch`). x is followed in recording order with a hysteresis
   ``tol = max(4 s_x, q)`` (s_x the second-difference noise of x, q its smallest step): a
   reversal is a move back by more than tol from the last extreme. A row moving x away
   from its start value x_0, on the side where x goes furthest, is loading; a row moving
   back towards x_0, or on past it, is unloading (the turning rows belong to the loading
   they start or end): a record that starts under a preload and is unloaded to rest
   returns past its start on a branch of its own (hysteresis), not a second loading. A run
   of rows over which x stays within tol, at least ``HOLD_ROWS`` long and ``HOLD_RATIO``
   times the median run, is a hold; a run of y likewise (with y's own tol) is a held load,
   x creeping.
   No start at zero and no direction is assumed.
2. **Linear range** (:func:`matid.fits.onset.linear_range`): among the loading rows, the
   stretch of x that a line plus offset describes within the noise.

:func:`select` applies this to one file, or, when its test has a ``window``, takes
exactly the window's rows instead (docs/contract.md section 10); a :class:`Record`
keeps the mask of the rows left out for each reason, for the report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from matid.errors import DataError
from matid.fits import stats
from matid.fits.onset import LINEAR_RANGE_MIN_POINTS, linear_ranges

#: A hold is a run of constant x at least this many rows long ...
HOLD_ROWS = 10
#: ... and this many times the median run of the record.
HOLD_RATIO = 5.0

UNLOADING = "unloading (x moves back towards its start)"
HOLD = "hold (x constant)"
HELD_LOAD = "held load (y constant while x creeps)"
BEFORE = "before the linear range (toe, backlash or tare)"
BEYOND = "beyond the linear range"
PAST_PEAK = "past the peak (y falls after its largest value)"
#: y falls past its peak when it drops this many noise deviations below it.
PEAK_FALL = 5.0


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
    lengths = np.diff(np.r_[starts, x.size])
    return np.repeat(lengths >= max(HOLD_ROWS, HOLD_RATIO * float(np.median(lengths))), lengths)


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
    # the way the record goes furthest from its start loads; a move the other way, past the start
    # too, is a return (a preload taken off, a nudge before the test), not a second loading
    main = np.sign(x[np.argmax(np.abs(x - x[0]))] - x[0])
    away = (moving == 0) | ((moving == main) & (main * (x - x[0]) >= 0))
    loading = away | np.r_[away[1:], False]  # a turning row starts the loading after it
    hold = _holds(x, tol)
    held = (_holds(y, _tolerance(y)) if np.ptp(y) > 0 else none) & ~hold
    return {UNLOADING: ~loading & ~hold & ~held, HOLD: hold, HELD_LOAD: held}


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
    #: y computed from other channels (a tip magnet's m B sin(psi - theta)), not read from a
    #: meter whose polarity could be flipped: :func:`matid.fits.linear.orient` never negates it.
    computed: bool = False
    #: Rows the onset test accepts as one line, before trimming (:func:`matid.fits.onset.linear_ranges`);
    #: None with a window or before :func:`automatic`.
    accepted: np.ndarray | None = None

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


#: The quadratic term of a parabola through a record's fitted rows lies more than this many standard
#: errors from zero: the curve bends inside the range fitted (the bar of the extension fit's
#: :func:`matid.fits.extension.checks.nonlinear`).
BEND_T = 3.0


def bend(rec: Record) -> float:
    """|t| of the quadratic term of ``y = c + b u + q u^2`` (u: x scaled over its range) over the
    rows the onset test accepts as one line (``accepted``; the fitted rows with a window), in
    recording order, its standard error the AR(1) sandwich of :mod:`matid.fits.stats` (0 with
    under 10 rows). A long dense record that softens passes the onset test while a parabola over
    those rows still finds its bend, and trimming stops where the bend is no longer significant:
    the noise interval of the range kept then understates what the choice of range moves."""
    rows = rec.used if rec.accepted is None else rec.accepted
    x, y = rec.x[rows], rec.y[rows]
    if x.size < 10 or np.ptp(x) <= 0:
        return 0.0
    u = (x - x.mean()) / np.ptp(x)
    design = np.column_stack([np.ones_like(u), u, u**2])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    se = stats.ar1_covariance(design, y - design @ coef).stderr[2]
    return abs(float(coef[2])) / se if se > 0 else 0.0


def bent(records: Sequence[Record]) -> str:
    """Which records bend (:func:`bend` above ``BEND_T``), said for a warning; empty when none does."""
    names = [r.name for r in records if bend(r) > BEND_T]
    if not names:
        return ""
    said = "the rows the onset test accepts as one line bend (a parabola's curvature is significant)"
    return f"{', '.join(names)}: {said}; "


def record(name: str, x: np.ndarray, y: np.ndarray, window: np.ndarray) -> Record:
    """A record with the rows outside ``window`` and the non-finite rows left out."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    rec = Record(name, x, y, np.ones(x.size, dtype=bool))
    rec = rec.leave_out(np.asarray(window, dtype=bool), "outside the window")
    return rec.leave_out(np.isfinite(x) & np.isfinite(y), "not finite")


def past_peak(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Mask of the loading rows beyond the peak of y, when y then falls (yield, a tube that
    buckles or slips): no line through the origin's side of a peak describes them, and the
    smooth departures of :mod:`matid.fits.onset` cannot follow a fall. The peak is the largest y
    in the way y goes over the first quarter of the reach; beyond it y must fall as a trend: the
    line through the rows beyond drops by more than PEAK_FALL second-difference noise deviations
    of y, with its slope PEAK_FALL standard errors below zero. So a plateau (softening) stays for
    the linear-range search, and so does noise: the largest reading of a noisy record is not a peak."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    none = np.zeros(x.size, dtype=bool)
    if x.size < 3:
        return none
    reach = np.abs(x - x[0])
    start = np.argsort(reach, kind="stable")[: max(4, x.size // 4)]  # the way y goes at first
    sign = np.sign(np.polyfit(reach[start], y[start], 1)[0]) if np.ptp(reach[start]) > 0 else 1.0
    z = sign * (y - y[0])
    peak = int(np.argmax(z))
    beyond = reach > reach[peak]
    if beyond.sum() < 4 or np.ptp(reach[beyond]) <= 0:
        return none
    (slope, offset), cov = np.polyfit(reach[beyond], z[beyond], 1, cov=True)
    drop = -slope * np.ptp(reach[beyond])
    falls = slope < -PEAK_FALL * np.sqrt(cov[0, 0]) and drop > PEAK_FALL * stats.difference_noise(y)
    return beyond if falls else none


def automatic(rec: Record) -> Record:
    """The record cut to its loading branch's linear range (:mod:`matid.fits.branch`)."""
    idx = np.flatnonzero(rec.used)
    for reason, mask in branch(rec.x[idx], rec.y[idx]).items():
        keep = np.ones(rec.x.size, dtype=bool)
        keep[idx[mask]] = False
        rec = rec.leave_out(keep, reason)
    idx = np.flatnonzero(rec.used)
    keep = np.ones(rec.x.size, dtype=bool)
    keep[idx[past_peak(rec.x[idx], rec.y[idx])]] = False
    rec = rec.leave_out(keep, PAST_PEAK)
    idx = np.flatnonzero(rec.used)
    if idx.size == 0:
        return rec
    inside, accepted = np.zeros(rec.x.size, dtype=bool), np.zeros(rec.x.size, dtype=bool)
    inside[idx], accepted[idx] = linear_ranges(rec.x[idx], rec.y[idx])
    x0, xs = rec.x[idx[0]], rec.x[inside]
    near = np.abs(rec.x - x0) < np.min(np.abs(xs - x0), initial=np.inf)
    rec = rec.leave_out(inside | ~near, BEFORE)
    return replace(rec.leave_out(inside, BEYOND), accepted=accepted)


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


def left_out_info(records: Sequence[Record]) -> dict[str, object]:
    """file -> reason -> rows left out (``left_out``) and their [first, last] row ranges
    (``left_out_rows``), files with none omitted; the files whose sign was flipped."""
    return {
        "left_out": {r.name: dict(r.left_out) for r in records if r.left_out},
        "left_out_rows": {r.name: r.rows_left_out() for r in records if r.excluded},
        "sign_flipped": [r.name for r in records if r.flipped],
    }


def range_info(records: Sequence[Record]) -> dict[str, list[float]]:
    """file -> [x_min, x_max] of the rows fitted."""
    return {r.name: [float(np.min(r.x[r.used])), float(np.max(r.x[r.used]))] for r in records if r.used.any()}
