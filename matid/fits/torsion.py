r"""E_t from torsion, in the linear range (physics.md section 2).

Twisting one end of a tube of length L by phi takes a torque::

    tau = c + E_t phi / L            (c: the tare offset of the torque channel)

E_t is the slope of torque against twist_angle / length, fitted jointly over all files
with an offset per file (:func:`matid.fits.linear.fit_lines`), on the rows of the test's
``window`` when it has one, else on each file's loading branch's linear range
(:mod:`matid.fits.branch`): a record may start at an absolute angle or a tare, hold,
unload or go past its linear range. The sign check runs on the rows fitted. Rows left
out are marked in the series and listed by reason in ``info["left_out"]`` (counts) and
``info["left_out_rows"]`` (row ranges).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from matid.errors import DataError, FitError
from matid.fits import branch, linear
from matid.io.results import Estimate, Series, TestFit

if TYPE_CHECKING:
    from matid.io.ingest.read import Measurement

_ADVICE = (
    "Check the fit plot; set a window on twist_angle to the part the line follows, or check "
    "the tare and the angle channel"
)


def _record(m: Measurement) -> branch.Record:
    """The file's fitted rows of x = twist_angle / length [rad/m], y = torque [N m]."""
    for column in ("twist_angle", "torque"):
        if column not in m.table:
            raise DataError(f"torsion needs a '{column}' column", file=m.table.path)
    x = np.asarray(m.table["twist_angle"], dtype=float) / float(m.test.params["length"])
    y = m.table["torque"]
    return branch.select(m.table.path.name, x, y, m.in_window(), m.test.window, file=m.table.path)


def fit_torsion(measurements: Sequence[Measurement], *, specimen: str) -> TestFit:
    """E_t: slope of torque against twist_angle / length over each file's fitted rows, jointly."""
    if not measurements:
        raise FitError(f"specimen {specimen}: no torsion tests to fit")
    records, warnings = linear.orient([_record(m) for m in measurements], "torque", "twist angle")
    try:
        fit = linear.fit_lines(records)
        warnings += linear.check_sign(fit, "E_t", "torque", "twist angle")
    except FitError as exc:
        raise FitError(f"specimen {specimen}: {exc}") from exc
    warnings += linear.share_warnings(records)
    warnings += linear.misfit_warning(fit, "the line torque = c + E_t phi / L", _ADVICE)
    series = tuple(
        Series(f"{r.name} (L = {m.test.params['length'] * 1e3:.4g} mm)", r.x, r.y, fit.model(r), r.used)
        for r, m in zip(records, measurements, strict=True)
    )
    texts, kinds = linear.warning_fields(warnings, records)
    extra = {"ci_method": "t-ar1" if fit.covariance.rho else "t", "tare_offset_N_m": fit.intercepts, **kinds}
    n_all = sum(r.x.size for r in records)
    return TestFit(
        kind="torsion",
        specimen=specimen,
        tests=tuple(m.test for m in measurements),
        estimates=(Estimate("E_t", *fit.value, "linear", texts, extra),),
        series=series,
        x_label="twist angle / length [rad/m]",
        y_label="torque [N m]",
        info={
            "linear_range": {r.name: float(np.max(np.abs(r.x[r.used]), initial=0.0)) for r in records},
            "fitted_x_range": branch.range_info(records),
            "excluded_points": int(n_all - fit.n),
            "left_out": branch.left_out_info(records),
            "left_out_rows": branch.rows_info(records),
            "sign_flipped": [r.name for r in records if r.flipped],
            "r2": linear.r2(records, fit),
            **fit.info(),
        },
    )
