r"""Linear stiffness tests: E_b from magnetic bending, E_t from torsion (physics.md section 2).

Magnetic bending with a tip magnet of moment m in a uniform field B at angle psi: the
magnet applies a pure end torque, and a pure end moment bends an inextensible rod into
a circular arc, so at any deflection::

    tau = m B sin(psi - theta) = E_b theta / L          (theta tip angle, L free length)

Torsion, in the linear range only::

    tau = E_t phi / L                                   (phi twist of one end, L length)

Both stiffnesses are slopes of a line through the origin, fitted jointly over all files
(lengths) of one specimen by least squares::

    E = sum(x y) / sum(x^2),   se(E) = s / sqrt(sum(x^2)),   s^2 = sum((y - E x)^2) / (n - 1)

with a 95 % interval E -+ t_{0.975, n-1} se(E). The linear range of torsion data is found
from the data by :func:`linear_range`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from scipy import stats

from matid.errors import DataError, FitError
from matid.results import Estimate, Series, TestFit

if TYPE_CHECKING:
    from matid.ingest import Measurement, Table
    from matid.study import Test

#: Significance level of the curvature test of :func:`linear_range`.
LINEAR_RANGE_ALPHA = 0.01
#: Fewest points a linear range may hold.
LINEAR_RANGE_MIN_POINTS = 6
#: At most this many nested windows are tested (evenly spread) by :func:`linear_range`.
LINEAR_RANGE_WINDOWS = 200
#: p-value below which per-length bending slopes are said to disagree.
SLOPES_ALPHA = 0.01


# --------------------------------------------------------------------------- model


def magnet_torque(
    moment: float, field: np.ndarray, field_angle: np.ndarray, tip_angle: np.ndarray
) -> np.ndarray:
    """End torque of a tip magnet in a uniform field: ``tau = m B sin(psi - theta)``."""
    return moment * np.asarray(field) * np.sin(np.asarray(field_angle) - np.asarray(tip_angle))


def bending_torque(table: Table, test: Test) -> np.ndarray:
    """Torque [N m]: the torque column, else ``m B sin(psi - theta)`` from the test's
    magnet_moment m and the field B, field_angle psi and tip_angle theta columns."""
    if "torque" in table:
        return np.asarray(table["torque"], dtype=float)
    moment = test.params.get("magnet_moment")
    if moment is None:
        raise DataError(
            "no 'torque' column, and the test has no magnet_moment in study.toml to compute "
            "it from field and field_angle",
            file=table.path,
        )
    for column in ("field", "field_angle", "tip_angle"):
        if column not in table:
            raise DataError(f"no 'torque' column and no '{column}' column", file=table.path)
    return magnet_torque(moment, table["field"], table["field_angle"], table["tip_angle"])


# --------------------------------------------------------------------------- line through 0


def slope_through_origin(x: np.ndarray, y: np.ndarray) -> tuple[float, float, int]:
    """Least-squares slope of ``y = E x``: returns (E, se(E), n) with s^2 on n - 1 dof."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = x.size
    sxx = float(np.dot(x, x))
    if n < 2 or sxx <= 0:
        raise FitError(f"a slope needs at least 2 points with x != 0, got {n}")
    slope = float(np.dot(x, y)) / sxx
    s2 = float(np.sum((y - slope * x) ** 2)) / (n - 1)
    return slope, float(np.sqrt(s2 / sxx)), n


def weighted_joint_slope(xs: Sequence[np.ndarray], ys: Sequence[np.ndarray]) -> tuple[float, float, int]:
    """Slope of y = E x over several files, each weighted by its own residual noise.

    Files differ in noise (a short tube is twisted further, and a torque
    meter's noise scales with its range), so an unweighted pooled slope is
    inefficient and its standard error wrong. Iterated: w_f = 1/s_f^2 with s_f
    the rms residual of file f about the joint line (n_f - 1 dof), then
    E = sum w x y / sum w x^2, se^2 = [sum w r^2 / (n - 1)] / sum w x^2.
    """
    slope, _, n = slope_through_origin(np.concatenate(xs), np.concatenate(ys))
    if len(xs) == 1:
        return slope_through_origin(xs[0], ys[0])
    for _ in range(3):
        s2 = [float(np.sum((y - slope * x) ** 2)) / max(x.size - 1, 1) for x, y in zip(xs, ys, strict=True)]
        floor = 1e-30 + 1e-12 * max(s2)
        w = [np.full(x.size, 1.0 / max(s, floor)) for x, s in zip(xs, s2, strict=True)]
        W, X, Y = np.concatenate(w), np.concatenate(xs), np.concatenate(ys)
        slope = float(np.sum(W * X * Y) / np.sum(W * X * X))
    chi2 = float(np.sum(W * (Y - slope * X) ** 2)) / (n - 1)
    return slope, float(np.sqrt(chi2 / np.sum(W * X * X))), n


def _joint_slope(x, y, specimen: str) -> tuple[float, float, int]:
    try:
        return slope_through_origin(x, y)
    except FitError as exc:
        raise FitError(f"specimen {specimen}: {exc}") from exc


def _ci95(value: float, se: float, n: int) -> tuple[float, float]:
    half = float(stats.t.ppf(0.975, n - 1)) * se
    return value - half, value + half


def _r2(x: np.ndarray, y: np.ndarray, slope: float) -> float:
    """Coefficient of determination against the mean (not the inflated through-origin one)."""
    total = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum((y - slope * x) ** 2)) / total if total > 0 else float("nan")


def _finite(x: np.ndarray, y: np.ndarray, path: Path) -> np.ndarray:
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        raise DataError("no row with finite values", file=path)
    return ok


# --------------------------------------------------------------------------- bending


def _bending_xy(m: Measurement) -> tuple[np.ndarray, np.ndarray, float]:
    """x = tip_angle / free_length [rad/m], y = torque [N m], and L [m] of one file."""
    if "tip_angle" not in m.table:
        raise DataError("magnetic bending needs a 'tip_angle' column", file=m.table.path)
    length = float(m.test.params["free_length"])
    x = np.asarray(m.table["tip_angle"], dtype=float) / length
    return x, bending_torque(m.table, m.test), length


def _per_length(xs, ys, lengths) -> tuple[dict[str, dict[str, float]], float | None]:
    """Slope per free length and the p-value of their agreement (chi-square on k - 1 dof)."""
    out: dict[str, dict[str, float]] = {}
    for length in sorted(set(lengths)):
        pick = [i for i, value in enumerate(lengths) if value == length]
        x = np.concatenate([xs[i] for i in pick])
        y = np.concatenate([ys[i] for i in pick])
        if x.size >= 3 and np.dot(x, x) > 0:
            slope, se, n = slope_through_origin(x, y)
            out[f"{length:.6g}"] = {"E_b": slope, "stderr": se, "n_points": n}
    slopes = np.array([v["E_b"] for v in out.values()])
    se = np.array([v["stderr"] for v in out.values()])
    if slopes.size < 2 or not np.all(se > 0):
        return out, None
    w = 1.0 / se**2
    mean = np.sum(w * slopes) / np.sum(w)
    chi2 = float(np.sum(w * (slopes - mean) ** 2))
    return out, float(stats.chi2.sf(chi2, slopes.size - 1))


def fit_bending(measurements: Sequence[Measurement], *, specimen: str) -> TestFit:
    """E_b: slope of torque against tip_angle / free_length, all lengths jointly, through 0."""
    if not measurements:
        raise FitError(f"specimen {specimen}: no magnetic bending tests to fit")
    data = [_bending_xy(m) for m in measurements]
    oks = [_finite(x, y, m.table.path) for (x, y, _), m in zip(data, measurements, strict=True)]
    xs = [x[ok] for (x, _, _), ok in zip(data, oks, strict=True)]
    ys = [y[ok] for (_, y, _), ok in zip(data, oks, strict=True)]
    lengths = [length for _, _, length in data]
    slope, se, n = _joint_slope(np.concatenate(xs), np.concatenate(ys), specimen)
    per_length, p = _per_length(xs, ys, lengths)
    warnings = ()
    if p is not None and p < SLOPES_ALPHA:
        warnings = (
            f"slopes at different free lengths disagree beyond their errors (p = {p:.2g}): "
            "E_b seems to depend on length; see the per-length slopes",
        )
    series = tuple(
        Series(
            f"{m.table.path.name} (L = {length * 1e3:.4g} mm)",
            x,
            y,
            slope * x,
            None if ok.all() else ok,
        )
        for m, (x, y, length), ok in zip(measurements, data, oks, strict=True)
    )
    return TestFit(
        kind="magnetic_bending",
        specimen=specimen,
        tests=tuple(m.test for m in measurements),
        estimates=(Estimate("E_b", slope, se, _ci95(slope, se, n), n, "linear", warnings),),
        series=series,
        x_label="tip angle / free length [rad/m]",
        y_label="torque [N m]",
        info={
            "free_lengths_m": sorted(set(lengths)),
            "r2": _r2(np.concatenate(xs), np.concatenate(ys), slope),
            "per_length_slopes": per_length,
        },
    )


# --------------------------------------------------------------------------- linear range


def _curvature_p(u: np.ndarray, y: np.ndarray) -> float:
    """p-value of the F-test of ``y = a u`` against ``y = a u + b u|u| + c u^3``."""
    design = np.column_stack([u, u * np.abs(u), u**3])
    rss0 = float(np.sum((y - u * (np.dot(u, y) / np.dot(u, u))) ** 2))
    coef, _, rank, _ = np.linalg.lstsq(design, y, rcond=None)
    rss1 = float(np.sum((y - design @ coef) ** 2))
    q, dof = rank - 1, u.size - rank
    if q < 1 or dof < 1:
        return 1.0
    if rss1 <= 0.0:
        return 0.0 if rss0 > 0.0 else 1.0
    f = max(rss0 - rss1, 0.0) / q / (rss1 / dof)
    return float(stats.f.sf(f, q, dof))


def _onset_rss(u: np.ndarray, y: np.ndarray, u0: float) -> float:
    """RSS of y = a u + b sgn(u) max(|u| - u0, 0)^2 (linear least squares in a, b)."""
    excess = np.maximum(np.abs(u) - u0, 0.0)
    design = np.column_stack([u, np.sign(u) * excess**2])
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
    """Mask of the points in the linear range from the origin of ``y = E x`` data.

    Two steps, with points ordered by |x| (twist in both directions alike):

    1. Is there curvature at all? An F-test of the line through the origin
       against the line plus the lowest odd terms u|u| and u^3 (u = x / max|x|;
       torque is odd in twist) over all points, at level ``alpha``. If not,
       every point is in the linear range.
    2. Where does it start? Segmented regression for the onset u0 of a C^1
       departure from the line (the generic first-order one: the tangent
       stiffness starts to change at u0),

           y = a u + b sgn(u) max(|u| - u0, 0)^2,

       with u0 scanned over the sorted |u| (at most ``max_windows`` candidates,
       at least ``min_points`` points below it); the linear range is |u| <= u0 of
       the least residual sum of squares. Unlike nested window tests, which
       only notice a departure once it is significant by itself and so admit
       points past the onset (measured: E_t biased by +1 % to +1.7 % on
       stiffening tubes at 0.5 % noise), the segmented fit uses the shape of
       the whole curve to place the onset.
    3. Check the window: if curvature is still significant inside |u| <= u0 (a
       curve bent from the origin, which no onset fits), the range is the
       largest nested window inside it that passes the F-test.
    The F-test is scale free. With fewer than ``min_points`` finite points all
    of them are returned.
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
    if _curvature_p(u, yy) >= alpha:
        return ok
    sizes = np.unique(
        np.linspace(min_points, n - 2, min(max(n - 1 - min_points, 1), max_windows)).astype(int)
    )
    rss = [_onset_rss(u, yy, abs(u[k - 1])) for k in sizes]
    k = int(sizes[int(np.argmin(rss))])
    if _curvature_p(u[:k], yy[:k]) < alpha:
        inner = sizes[sizes <= k]
        passing = [m for m in inner if _curvature_p(u[:m], yy[:m]) >= alpha]
        k = int(max(passing)) if passing else min_points
    return ok & (np.abs(x) <= np.abs(x[index[k - 1]]))


# --------------------------------------------------------------------------- torsion


def _torsion_xy(m: Measurement) -> tuple[np.ndarray, np.ndarray]:
    """x = twist_angle / length [rad/m], y = torque [N m] of one file."""
    for column in ("twist_angle", "torque"):
        if column not in m.table:
            raise DataError(f"torsion needs a '{column}' column", file=m.table.path)
    x = np.asarray(m.table["twist_angle"], dtype=float) / float(m.test.params["length"])
    return x, np.asarray(m.table["torque"], dtype=float)


def fit_torsion(measurements: Sequence[Measurement], *, specimen: str) -> TestFit:
    """E_t: slope of torque against twist_angle / length over each file's linear range, jointly."""
    if not measurements:
        raise FitError(f"specimen {specimen}: no torsion tests to fit")
    data = [_torsion_xy(m) for m in measurements]
    masks = [linear_range(x, y) for x, y in data]
    names = [m.table.path.name for m in measurements]
    xs = [x[mask] for (x, _), mask in zip(data, masks, strict=True)]
    ys = [y[mask] for (_, y), mask in zip(data, masks, strict=True)]
    x_used, y_used = np.concatenate(xs), np.concatenate(ys)
    try:
        slope, se, n = weighted_joint_slope(xs, ys)
    except FitError as exc:
        raise FitError(f"specimen {specimen}: {exc}") from exc
    n_all = sum(x.size for x, _ in data)
    warnings = tuple(
        f"{name}: only {int(mask.sum())} of {mask.size} points are in the linear range"
        for name, mask in zip(names, masks, strict=True)
        if mask.sum() < 0.5 * mask.size
    )
    series = tuple(
        Series(f"{name} (L = {m.test.params['length'] * 1e3:.4g} mm)", x, y, slope * x, mask)
        for name, m, (x, y), mask in zip(names, measurements, data, masks, strict=True)
    )
    return TestFit(
        kind="torsion",
        specimen=specimen,
        tests=tuple(m.test for m in measurements),
        estimates=(Estimate("E_t", slope, se, _ci95(slope, se, n), n, "linear", warnings),),
        series=series,
        x_label="twist angle / length [rad/m]",
        y_label="torque [N m]",
        info={
            "linear_range": {
                name: float(np.max(np.abs(x[mask]), initial=0.0))
                for name, (x, _), mask in zip(names, data, masks, strict=True)
            },
            "excluded_points": int(n_all - n),
            "r2": _r2(x_used, y_used, slope),
        },
    )
