r"""E_t from torsion, in the linear range (physics.md section 2).

Twisting one end of a tube of length L by phi takes a torque::

    tau = c + E_t phi / L            (c: the tare offset of the torque channel)

E_t is the slope of torque against twist_angle / length, fitted jointly over all files
with an offset per file (:func:`matid.fits.linear.fit_lines`), on the rows of the test's
``window`` when it has one, else on each file's loading branch's linear range
(:mod:`matid.fits.branch`: a record may start at an absolute angle or a tare, hold,
unload or go past its linear range), each row left out listed with its reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from matid.errors import DataError, FitError
from matid.fits import branch, linear
from matid.fits.shear.torsion import with_E_s_torsion
from matid.model.kind import Kind
from matid.model.results import TestFit

if TYPE_CHECKING:
    from matid.model.measurement import Measurement
    from matid.model.study import Specimen

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
    records, fit, _ = line = linear.fit_slope(
        [_record(m) for m in measurements],
        specimen=specimen,
        parameter="E_t",
        against="twist angle",
        model="the line torque = c + E_t phi / L",
        advice=_ADVICE,
    )
    info = {
        "linear_range": {r.name: float(np.max(np.abs(r.x[r.used]), initial=0.0)) for r in records},
        "fitted_x_range": branch.range_info(records),
        "excluded_points": int(sum(r.x.size for r in records) - fit.n),
        **branch.left_out_info(records),
        "r2": linear.r2(records, fit),
    }
    lengths = [m.test.params["length"] for m in measurements]
    x_label = "twist angle / length [rad/m]"
    return linear.slope_result(KIND.name, specimen, measurements, "E_t", line, lengths, x_label, info)


def _fit(measurements, *, specimen: Specimen, fixed, known) -> TestFit:
    return with_E_s_torsion(fit_torsion(measurements, specimen=specimen.id), specimen)


KIND = Kind(
    name="torsion",
    title="Torsion",
    columns={"twist_angle": "angle", "torque": "torque"},
    required=(("twist_angle",), ("torque",)),
    keys={"length": "length"},
    parameters=("E_t",),
    fit=_fit,
)
