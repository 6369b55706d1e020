"""Checks that the data of a test can describe it, at input (docs/contract.md section 7).

A value beyond the physical bound of its quantity (:data:`matid.units.PHYSICAL_BOUND`,
after SI conversion), or a column whose values all vanish against it (:data:`DYNAMIC_RANGE`),
is a unit or export mistake; loads recorded with the
machine's sign convention (compression negative) would otherwise fail deep in a
solver. Each check raises a DataError naming the file, the column and, where one
row is at fault, the row, and says what to change.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from matid.errors import DataError
from matid.fits.kinds import BY_NAME
from matid.units import PHYSICAL_BOUND, SI_UNITS

#: A column the kind wants positive (:attr:`~matid.model.kind.Kind.positive`) whose positive
#: side never reaches this fraction of its largest magnitude has the wrong sign.
WRONG_SIGN_FRACTION = 0.1
#: A column whose largest magnitude is not 0 but below its quantity's physical bound divided by this
#: (1e-24 N, 1e-25 rad, 1e-29 m) holds no measurement: a unit or export mistake. The fits' sums of
#: squares and their inverses overflow or divide by zero on such values (torsion angles of 1e-200 rad:
#: ZeroDivisionError); 1e30 leaves every real instrument's range far inside.
DYNAMIC_RANGE = 1e30


def check(
    values: Mapping[str, np.ndarray],
    kind: str,
    rows: Sequence[int],
    written: Mapping[str, str],
    path: Path,
    negate: Sequence[str] = (),
) -> None:
    """Bounds, then signs. The torsion sign and the bend's loading branch are checked by the
    fits on the rows they fit (a window or the automatic range; docs/contract.md section 10)."""
    used = BY_NAME[kind].columns
    for name, quantity in used.items():
        if name in values:
            _bounded(values[name], quantity, rows, written[name], path)
            _not_vanishing(values[name], quantity, written[name], path)
    for name in BY_NAME[kind].positive:
        if name in values:
            _positive(values[name], name, written[name], path, negate)


def _bounded(v: np.ndarray, quantity: str, rows: Sequence[int], column: str, path: Path) -> None:
    bound = PHYSICAL_BOUND[quantity]
    bad = np.flatnonzero(~(np.abs(v) <= bound))
    if bad.size:
        k = int(bad[0])
        raise DataError(
            f"value {v[k]:.6g} {SI_UNITS[quantity]} (after unit conversion) is beyond the physical "
            f"bound {bound:g} {SI_UNITS[quantity]} for a {quantity}; check the unit of the column",
            file=path,
            row=rows[k],
            column=column,
        )


def _not_vanishing(v: np.ndarray, quantity: str, column: str, path: Path) -> None:
    peak = float(np.max(np.abs(v))) if v.size else 0.0
    floor = PHYSICAL_BOUND[quantity] / DYNAMIC_RANGE
    if 0.0 < peak < floor:
        unit = SI_UNITS[quantity]
        raise DataError(
            f"the largest magnitude of the column is {peak:.6g} {unit} (after unit conversion), below "
            f"{floor:g} {unit}: no {quantity} measured on a catheter bench is that small; check the unit "
            "of the column",
            file=path,
            column=column,
        )


def _positive(v: np.ndarray, name: str, column: str, path: Path, negate: Sequence[str]) -> None:
    peak = float(np.max(np.abs(v))) if v.size else 0.0
    if peak > 0 and float(np.max(v)) < WRONG_SIGN_FRACTION * peak:
        if name in negate:
            fix = f'remove "{name}" from negate: after negation it is negative'
        else:
            fix = f'if the machine records it as negative, add negate = ["{name}"] to the [[test]]'
        raise DataError(
            f"all values of {name} are negative (largest magnitude {-peak:.6g} in SI); matid expects "
            f"{name} positive in this test; {fix}",
            file=path,
            column=column,
        )
