"""Which rows of a three-point bend enter the E_s fit, and why the others do not.

A bend record is cut in four steps, each shown in the report (``Series.used``
and ``info["rows_left_out"]``):

1. ``window`` of the test (docs/contract.md sections 7 and 10,
   ``Measurement.in_window``). A window replaces the automatic range: steps 3
   and 4 are skipped and exactly its rows on the loading branch enter.
2. The **loading branch** ends at the peak force: rows after it (yield,
   fracture, or unloading at falling deflection) are left out. Rows before the
   peak at a deflection not above every earlier one (a crosshead reversal) are
   left out too.
3. The **toe** (slack taken up at low force, or rows before contact) is
   compensated as ASTM D790 (section 12.1) does: the tangent of steepest slope
   of the loading curve is extended to zero force; its deflection intercept d0
   becomes the zero of deflection (d <- d - d0) and rows at d <= d0 are left
   out. It is applied only when a toe is there (:func:`toe_offset`) and d0 > 0. Without a
   toe, rows below zero deflection whose force is within ``PRE_CONTACT_NOISE`` noise
   deviations of zero (crosshead scatter of either sign before the nose touches) are left
   out as before contact; a force above that at a negative deflection stays an error.
4. **Yield**: the force falling below the line of the initial stretch before
   the peak (a plastic hinge, a kink) is found as the upper onset of the linear
   range of :mod:`matid.fits.onset`; rows beyond it are left out when the
   departure is downwards (a stiffening, as the rod's on round rollers, is
   what the model describes and stays).

Before any solver runs, :func:`check_plausible` rejects data that make the
specimen absurd: an initial compliance d/F below the pure-bending compliance
S^3/(48 E_b) means a negative shear compliance, e.g. a force column in a wrong
unit (DataError naming file and column); an all-zero force column is a FitError.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.errors import DataError, FitError
from matid.fits import onset, stats

#: A toe is compensated when the initial slope is below this fraction of the typical early slope.
TOE_SLOPE_RATIO = 0.5
#: Compliance below this fraction of pure bending: the data are absurd (wrong unit), not noisy.
ABSURD_COMPLIANCE_RATIO = 0.5
#: Rows below zero deflection whose |force| is within this many noise deviations are before contact.
PRE_CONTACT_NOISE = 5.0


@dataclass(frozen=True)
class Cut:
    """Rows of one bend file in the fit (``used``), the toe shift d0, and why rows were left out."""

    used: np.ndarray  # bool over all rows of the file
    d0: float  # deflection zero moved by the toe compensation [m]
    reasons: dict[str, int]  # reason -> rows left out for it


def _slopes(d: np.ndarray, F: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares slope dF/dd and intercept of every run of ``width`` consecutive rows."""
    k = np.arange(d.size - width + 1)
    idx = k[:, None] + np.arange(width)[None, :]
    x, y = d[idx], F[idx]
    xm, ym = x.mean(axis=1, keepdims=True), y.mean(axis=1, keepdims=True)
    sxx = ((x - xm) ** 2).sum(axis=1)
    slope = np.where(sxx > 0, ((x - xm) * (y - ym)).sum(axis=1) / np.where(sxx > 0, sxx, 1.0), 0.0)
    return slope, ym[:, 0] - slope * xm[:, 0]


def toe_offset(d: np.ndarray, F: np.ndarray) -> float:
    """ASTM D790 toe compensation: deflection where the tangent after the toe reaches zero force.

    A toe is there when the initial slope is below ``TOE_SLOPE_RATIO`` of the
    median slope over the first half of the branch (a smoothly stiffening curve,
    as the rod's on round rollers, stays near it). The linear region starts where the
    slope has levelled off after the toe (within 5 % of the slope one window
    later); the tangent is the line over its linear range (:func:`onset.linear_range`
    from there), as D790 takes it on the linear region: one window's line (n/8 rows)
    moved d0 by its noise, ~0.3 % of the range and E_s by 1-2 %. 0 when there is no toe.
    """
    width = max(4, d.size // 8)
    if d.size < 3 * width:
        return 0.0
    slope, intercept = _slopes(d, F, width)
    reference = float(np.median(slope[: max(1, slope.size // 2)]))
    if reference <= 0 or slope[0] >= TOE_SLOPE_RATIO * reference:
        return 0.0
    later = slope[np.minimum(np.arange(slope.size) + width, slope.size - 1)]
    level = np.nonzero((slope >= 0.95 * later) & (slope > TOE_SLOPE_RATIO * reference))[0]
    j = int(level[0]) if level.size else int(np.argmax(slope))
    a, b = slope[j], intercept[j]
    line = onset.linear_range(d[j:], F[j:])  # the tangent over the whole linear region, not one window
    if line.sum() >= onset.LINEAR_RANGE_MIN_POINTS:
        fitted, at = np.polyfit(d[j:][line], F[j:][line], 1)
        a, b = (fitted, at) if fitted > 0 else (a, b)
    d0 = -b / a
    return float(d0) if d0 > 0 else 0.0


def _drop(used: np.ndarray, out: np.ndarray, reason: str, reasons: dict[str, int]) -> np.ndarray:
    """``used`` without the rows ``out``, counted in ``reasons`` when there are any."""
    if out.any():
        reasons[reason] = int(out.sum())
    return used & ~out


def _loading(d: np.ndarray, F: np.ndarray, used: np.ndarray, reasons: dict[str, int]) -> np.ndarray:
    """The used rows up to the peak force with a deflection above every earlier row (step 2)."""
    idx = np.nonzero(used)[0]
    if not idx.size:
        return used
    after = used & (np.arange(d.size) > idx[int(np.argmax(F[idx]))])
    used = _drop(used, after, "after the peak force (yield, fracture or unloading)", reasons)
    earlier = np.r_[-np.inf, np.maximum.accumulate(np.where(used, d, -np.inf))[:-1]]
    return _drop(used, used & (d <= earlier), "deflection not above every earlier row (reversal)", reasons)


def _yield(d: np.ndarray, F: np.ndarray, used: np.ndarray, reasons: dict[str, int]) -> np.ndarray:
    """The used rows without those past a downward departure from the line (step 4)."""
    idx = np.nonzero(used)[0]
    if idx.size <= 2 * onset.LINEAR_RANGE_MIN_POINTS:
        return used
    inside, curvature = onset.departure(d[idx], F[idx])
    if curvature >= 0:
        return used
    top = float(np.max(d[idx][inside]))
    return _drop(
        used, used & (d > top), f"past yield (force below the line beyond {1e3 * top:.4g} mm)", reasons
    )


def cut(d: np.ndarray, F: np.ndarray, window: np.ndarray, *, windowed: bool = False) -> Cut:
    """The rows of a bend record that enter the fit (module docstring, steps 1-4).

    ``windowed``: the test has a window, which replaces the automatic toe and yield cuts.
    """
    reasons: dict[str, int] = {}
    used = _loading(d, F, _drop(window, ~window, "outside the test's window", reasons), reasons)
    if windowed:
        return Cut(used, 0.0, reasons)
    idx = np.nonzero(used)[0]
    d0 = toe_offset(d[idx], F[idx]) if idx.size else 0.0
    if d0 > 0:
        toe = used & (d <= d0)
        reasons[f"toe (slack) before the ASTM D790 zero at {1e3 * d0:.4g} mm"] = int(toe.sum())
        used &= ~toe
    elif idx.size:
        # crosshead scatter of either sign around zero before the nose touches (an MTS 793 export):
        # rows below zero deflection whose force is within the noise of zero have not touched yet
        before = used & (d < 0)
        if before.any() and np.max(np.abs(F[before])) <= PRE_CONTACT_NOISE * stats.difference_noise(F[idx]):
            reason = "before contact (deflection below zero, force within the noise)"
            used = _drop(used, before, reason, reasons)
    return Cut(_yield(d, F, used, reasons), d0, reasons)


def check_plausible(d: np.ndarray, F: np.ndarray, *, span: float, E_b: float, file) -> None:
    """Reject bend data that no tube can give, before the solver (module docstring)."""
    if not np.any(F > 0):
        raise FitError(
            f"{file.name}: the force column has no positive value on the loading branch "
            '(all zero, or compression recorded as negative: see negate = ["force"])'
        )
    n = max(3, d.size // 5)
    dd, ff = d[:n], F[:n]
    if np.dot(dd, ff) <= 0:
        raise FitError(f"{file.name}: no rising force at the start of the loading branch")
    compliance = float(np.dot(dd, dd) / np.dot(dd, ff))
    bending = span**3 / (48.0 * E_b)
    if compliance < ABSURD_COMPLIANCE_RATIO * bending:
        raise DataError(
            f"the initial slope F/d = {1 / compliance:.4g} N/m is {bending / compliance:.3g} times "
            f"stiffer than bending alone with E_b = {E_b:.4g} N m^2 (negative shear compliance): "
            "check the units of the force and deflection columns",
            file=file,
            column="force",
        )
