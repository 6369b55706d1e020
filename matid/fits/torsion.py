r"""E_t from torsion, in the linear range (physics.md section 2).

Twisting one end of a tube of length L by phi takes a torque::

    tau = c + E_t phi / L            (c: the tare offset of the torque channel)

E_t is the slope of torque against twist_angle / length, fitted jointly over all files
with an offset per file (:func:`matid.fits.linear.fit_lines`), on the rows inside the
test's ``window`` and inside each file's linear range (:func:`matid.fits.linear.linear_range`).
Rows left out are marked in the series and counted by reason in ``info["left_out"]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from matid.errors import DataError, FitError
from matid.fits import linear
from matid.io.results import Estimate, Series, TestFit

if TYPE_CHECKING:
    from matid.io.ingest.read import Measurement

#: Below this share of a file's rows in the linear range, the estimate carries a warning.
MIN_LINEAR_SHARE = 0.5
_ADVICE = (
    "Check the fit plot; set a window on twist_angle to the part the line follows, or check "
    "the tare and the angle channel"
)


def _record(m: Measurement) -> linear.Record:
    """The file as a record x = twist_angle / length [rad/m], y = torque [N m]."""
    for column in ("twist_angle", "torque"):
        if column not in m.table:
            raise DataError(f"torsion needs a '{column}' column", file=m.table.path)
    x = np.asarray(m.table["twist_angle"], dtype=float) / float(m.test.params["length"])
    rec = linear.record(m.table.path.name, x, m.table["torque"], m.in_window())
    if not rec.used.any():
        raise DataError("no row with finite values inside the window", file=m.table.path)
    return rec


def _in_linear_range(rec: linear.Record) -> linear.Record:
    inside = np.zeros(rec.x.size, dtype=bool)
    inside[rec.used] = linear.linear_range(rec.x[rec.used], rec.y[rec.used])
    return rec.leave_out(inside, "beyond the linear range")


def fit_torsion(measurements: Sequence[Measurement], *, specimen: str) -> TestFit:
    """E_t: slope of torque against twist_angle / length over each file's linear range, jointly."""
    if not measurements:
        raise FitError(f"specimen {specimen}: no torsion tests to fit")
    records, warnings = linear.orient([_record(m) for m in measurements], "torque", "twist angle")
    candidates = [r.used.sum() for r in records]
    records = [_in_linear_range(r) for r in records]
    try:
        fit = linear.fit_lines(records)
        warnings += linear.check_sign(fit, "E_t", "torque", "twist angle")
    except FitError as exc:
        raise FitError(f"specimen {specimen}: {exc}") from exc
    warnings += [
        f"{r.name}: only {int(r.used.sum())} of {r.used.size} points are in the linear range"
        for r, m in zip(records, candidates, strict=True)
        if r.used.sum() < MIN_LINEAR_SHARE * m
    ]
    misfit = fit.lof.warning("the line torque = c + E_t phi / L", fit.inflation, _ADVICE)
    warnings += [misfit] if misfit else []
    series = tuple(
        Series(f"{r.name} (L = {m.test.params['length'] * 1e3:.4g} mm)", r.x, r.y, fit.model(r), r.used)
        for r, m in zip(records, measurements, strict=True)
    )
    extra = {"ci_method": "t-ar1" if fit.covariance.rho else "t", "tare_offset_N_m": fit.intercepts}
    n_all = sum(r.x.size for r in records)
    return TestFit(
        kind="torsion",
        specimen=specimen,
        tests=tuple(m.test for m in measurements),
        estimates=(Estimate("E_t", *fit.value, "linear", tuple(warnings), extra),),
        series=series,
        x_label="twist angle / length [rad/m]",
        y_label="torque [N m]",
        info={
            "linear_range": {r.name: float(np.max(np.abs(r.x[r.used]), initial=0.0)) for r in records},
            "excluded_points": int(n_all - fit.n),
            "left_out": linear.left_out_info(records),
            "sign_flipped": [r.name for r in records if r.flipped],
            "r2": linear.r2(records, fit),
            **fit.info(),
        },
    )
