r"""E_b from magnetic bending (physics.md section 2).

A tip magnet of moment m in a uniform field B at angle psi applies a pure end torque,
and a pure end moment bends an inextensible rod into a circular arc, so at any
deflection::

    tau = m B sin(psi - theta) = E_b theta / L          (theta tip angle, L free length)

E_b is the slope of torque against theta / L, fitted jointly over all files (lengths)
of one specimen with a tare offset per file (:func:`matid.fits.linear.fit_lines`), on
the rows of the test's ``window`` when it has one, else on each file's loading branch's
linear range (:mod:`matid.fits.branch`: holds of the field, returns and a departure from
the line are left out with their reason). Per-length slopes are compared: a
disagreement beyond their errors says E_b depends on length (clamp compliance, shear).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import scipy.stats

from matid.errors import DataError, FitError
from matid.fits import branch, linear
from matid.model.kind import Kind
from matid.model.results import TestFit

if TYPE_CHECKING:
    from matid.model.measurement import Measurement, Table
    from matid.model.study import Specimen, Test

#: p-value below which per-length bending slopes are said to disagree.
SLOPES_ALPHA = 0.01
_ADVICE = (
    "Check the fit plot; set a window on tip_angle to the part the line follows, or check "
    "the field and angle channels"
)


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


def _record(m: Measurement) -> tuple[branch.Record, float]:
    """The file's fitted rows of x = tip_angle / free_length [rad/m], y = torque [N m], and L."""
    if "tip_angle" not in m.table:
        raise DataError("magnetic bending needs a 'tip_angle' column", file=m.table.path)
    length = float(m.test.params["free_length"])
    x = np.asarray(m.table["tip_angle"], dtype=float) / length
    y = bending_torque(m.table, m.test)
    record = branch.select(m.table.path.name, x, y, m.in_window(), m.test.window, file=m.table.path)
    return replace(record, computed="torque" not in m.table), length


def _per_length(records, lengths) -> tuple[dict[str, dict[str, float]], float | None]:
    """Slope per free length and the p-value of their agreement (chi-square on k - 1 dof)."""
    out: dict[str, dict[str, float]] = {}
    for length in sorted(set(lengths)):
        pick = [r for r, value in zip(records, lengths, strict=True) if value == length]
        try:
            fit = linear.fit_lines(pick)
        except FitError:
            continue
        out[f"{length:.6g}"] = {"E_b": fit.slope, "stderr": fit.stderr, "n_points": fit.n}
    slopes = np.array([v["E_b"] for v in out.values()])
    se = np.array([v["stderr"] for v in out.values()])
    if slopes.size < 2 or not np.all(se > 0):
        return out, None
    w = 1.0 / se**2
    mean = np.sum(w * slopes) / np.sum(w)
    chi2 = float(np.sum(w * (slopes - mean) ** 2))
    return out, float(scipy.stats.chi2.sf(chi2, slopes.size - 1))


def fit_bending(measurements: Sequence[Measurement], *, specimen: str) -> TestFit:
    """E_b: slope of torque against tip_angle / free_length, all lengths jointly, with offsets."""
    if not measurements:
        raise FitError(f"specimen {specimen}: no magnetic bending tests to fit")
    pairs = [_record(m) for m in measurements]
    lengths = [length for _, length in pairs]
    records, fit, warnings = linear.fit_slope(
        [r for r, _ in pairs],
        specimen=specimen,
        parameter="E_b",
        against="tip angle",
        model="the line torque = c + E_b theta / L",
        advice=_ADVICE,
    )
    per_length, p = _per_length(records, lengths)
    if p is not None and p < SLOPES_ALPHA:
        text = (
            f"slopes at different free lengths disagree beyond their errors (p = {p:.2g}): "
            "E_b seems to depend on length; see the per-length slopes"
        )
        warnings.append(linear.Warning("slopes_disagree", text))
    info = {
        "free_lengths_m": sorted(set(lengths)),
        "r2": linear.r2(records, fit),
        "per_length_slopes": per_length,
        "fitted_x_range": branch.range_info(records),
        **branch.left_out_info(records),
    }
    line, x_label = (records, fit, warnings), "tip angle / free length [rad/m]"
    return linear.slope_result(KIND.name, specimen, measurements, "E_b", line, lengths, x_label, info)


def _fit(measurements, *, specimen: Specimen, fixed, known) -> TestFit:
    return fit_bending(measurements, specimen=specimen.id)


KIND = Kind(
    name="magnetic_bending",
    title="Magnetic bending",
    columns={"tip_angle": "angle", "torque": "torque", "field": "field", "field_angle": "angle"},
    required=(("tip_angle",), ("torque", "field"), ("torque", "field_angle")),
    keys={"free_length": "length"},
    optional={"magnet_moment": "moment"},
    parameters=("E_b",),
    fit=_fit,
)
