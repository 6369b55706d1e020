"""The rows of a three-point-bend test that enter the E_s fit, and the Timoshenko start value.

:func:`bend_data` cuts each test to its loading branch (:mod:`matid.fits.shear.window`) and
checks it; :func:`timoshenko_start` reads E_s from the small-deflection compliance
C = d/F = S^3/(48 E_b) + S/(4 E_s) (physics.md section 5). The fit itself:
:mod:`matid.fits.shear.fit`; its least-squares problem: :mod:`matid.fits.shear.problem`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from matid.errors import DataError, FitError
from matid.fits.shear.window import Cut, check_plausible, cut
from matid.model.measurement import Measurement
from matid.model.study import Specimen
from matid.rod.bend import BendGeometry


@dataclass
class BendData:
    """One bend test: its geometry and the rows in the fit (loading branch, sorted by deflection).

    ``d`` is the nose travel, or with ``centreline`` the mid-span centreline
    deflection relative to the support sections (contract section 7,
    ``deflection_at``), in both cases after the toe compensation ``cut.d0``.
    """

    measurement: Measurement
    geometry: BendGeometry
    d: np.ndarray  # rows in the fit, increasing
    F: np.ndarray
    loading: np.ndarray  # mask over all rows of the file: the rows in the fit
    centreline: bool
    cut: Cut


def bend_data(m: Measurement, specimen: Specimen, E_b: float) -> BendData:
    """The rows of one bend file that enter the fit (:mod:`matid.fits.shear.window`), checked."""
    p = m.test.params
    try:
        geometry = BendGeometry(
            p["span"], p["specimen_length"], p["support_radius"], p["nose_radius"], specimen.section.depth
        )
    except ValueError as exc:
        raise DataError(str(exc), file=m.test.file) from exc
    d, F = np.asarray(m.table["deflection"], float), np.asarray(m.table["force"], float)
    window = m.in_window()
    if not np.any(F[window] > 0):
        check_plausible(d[window], F[window], span=geometry.span, E_b=E_b, file=m.test.file)
    c = cut(d, F, window, windowed=bool(m.test.window))
    dl, Fl = d[c.used] - c.d0, F[c.used]
    if dl.size < 3 or dl[-1] <= 0:
        raise FitError(f"{m.test.file.name}: fewer than 3 loading points with positive deflection")
    if np.any(dl < 0):
        raise DataError("negative deflection on the loading branch", file=m.test.file, column="deflection")
    check_plausible(dl, Fl, span=geometry.span, E_b=E_b, file=m.test.file)
    centreline = getattr(m.test, "deflection_at", "nose") == "centreline"
    return BendData(m, geometry, dl, Fl, c.used, centreline, c)


def timoshenko_force(d: np.ndarray, S: float, E_b: float, E_s: float) -> np.ndarray:
    """F = d / (S^3/(48 E_b) + S/(4 E_s)), physics.md section 5."""
    return d / (S**3 / (48 * E_b) + S / (4 * E_s))


def timoshenko_start(data: Sequence[BendData], E_b: float) -> float:
    """E_s from the compliance of the first fifth of each loading branch (linear regime)."""
    estimates = []
    for b in data:
        n = max(3, b.d.size // 5)
        d, F = b.d[:n], b.F[:n]
        C = float(np.dot(d, d) / np.dot(d, F))  # compliance d/F through the origin
        shear = C - b.geometry.span**3 / (48 * E_b)
        if shear > 0:
            estimates.append(b.geometry.span / (4 * shear))
    return float(np.median(estimates)) if estimates else 1e3 * E_b / min(b.geometry.span for b in data) ** 2
