"""Extension runs in SI for the SLS fit (:mod:`matid.fits.extension.fit`): reading, noise, slack rows.

Each run keeps its time, strain and force, a model-free noise level (second differences,
:func:`matid.fits.stats.difference_noise`), and the rows whose residuals enter the fit:
inside the test's window and not slack (a strip near zero force after loading carries no
compression). A run that takes up slack or starts at a preload before it loads
(:mod:`matid.fits.extension.start`) begins at its loading (slack rows are dropped, history and
all; ``before`` keeps them for the plots) and carries a free force offset (``offset``).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from matid.errors import DataError, FitError
from matid.fits import stats
from matid.fits.extension import start as start_
from matid.fits.extension.reduce import Reduction, reduction
from matid.physics.sls import History

if TYPE_CHECKING:
    from matid.model.measurement import Measurement

#: Why slack rows are left out (a key of ``_Run.left_out`` and ``info["left_out"]``).
SLACK = "slack strip (force about 0 while the model would push)"


@dataclass(frozen=True)
class _Run:
    """One extension run in SI: time, strain, force, and a model-free noise level."""

    name: str
    t: np.ndarray
    eps: np.ndarray
    force: np.ndarray
    noise: float  # from second differences, before any fit
    rate: float  # typical |strain rate| while straining [1/s]
    window: np.ndarray  # rows inside the test's window
    used: np.ndarray  # rows whose residuals enter the fit (the model runs over all rows)
    left_out: Mapping[str, int] = field(default_factory=dict)  # reason -> rows
    start: start_.Start | None = None  # slack or preload before loading: a free force offset
    #: The rows before the strip becomes taut (time, strain, force), for plots only: not in the fit
    before: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    #: What was dropped from the record before the fit and why (a warning of E_e each)
    said: tuple[str, ...] = ()

    @property
    def offset(self) -> bool:
        """Whether the model carries a free force offset (the run starts at slack or a preload)."""
        return self.start is not None

    @functools.cached_property
    def history(self) -> History:
        return History(self.t, self.eps)

    @functools.cached_property
    def reduce(self) -> Reduction:
        """Rows -> residuals: the used rows, as bin means on a long record (:mod:`.reduce`)."""
        return reduction(self.t, self.eps, self.used, self.rate)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def dt(self) -> float:
        return float(np.median(np.diff(self.t)))


def _unique(runs: list[_Run]) -> list[_Run]:
    """Runs with distinct names (files of the same name in different folders get #2, #3)."""
    seen: dict[str, int] = {}
    out = []
    for run in runs:
        seen[run.name] = seen.get(run.name, 0) + 1
        name = run.name if seen[run.name] == 1 else f"{run.name} #{seen[run.name]}"
        out.append(replace(run, name=name))
    return out


def _run(m: Measurement) -> _Run:
    table, test = m.table, m.test
    name = Path(table.path).name
    for column in ("time", "force"):
        if column not in table:
            raise DataError(f"extension test needs a '{column}' column", file=table.path)
    if "strain" in table:
        eps = np.asarray(table["strain"], dtype=float)
    elif "elongation" in table:
        eps = np.asarray(table["elongation"], dtype=float) / test.params["gauge_length"]
    else:
        raise DataError("extension test needs a 'strain' or 'elongation' column", file=table.path)
    t = np.asarray(table["time"], dtype=float)
    force = np.asarray(table["force"], dtype=float)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(eps)) and np.all(np.isfinite(force))):
        raise DataError("time, strain and force must be finite in every row", file=table.path)
    used = np.asarray(m.in_window(), dtype=bool)
    said: tuple[str, ...] = ()
    if _end_of_test(t, eps, force):
        said = (
            f"{name}: the last row (file line {table.line(-1)}) has time, strain and force all 0 where "
            f"time had reached {t[-2]:.6g} s: the test stage's end-of-test row, not a sample; it is not read",
        )
        t, eps, force, used = t[:-1], eps[:-1], force[:-1], used[:-1]
    if t.size < 5:
        raise FitError(f"{name}: only {t.size} samples; an extension run needs at least 5")
    if np.any(np.diff(t) <= 0):
        row = table.line(int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1)
        raise DataError("time must increase strictly", file=table.path, row=row, column="time")
    if np.ptp(eps) <= 0 or np.ptp(force) <= 0:
        raise FitError(f"{name}: strain or force does not change; nothing to fit")
    noise = stats.difference_noise(force) or 1e-9 * float(np.max(np.abs(force)))
    outside: dict[str, int] = {}
    begin, before = start_.find(eps, force, noise), None
    if begin is not None and begin.row > 0:  # the strip is not taut (or at rest) before: no history
        outside[begin.reason()] = begin.row
        before = (t[: begin.row], eps[: begin.row], force[: begin.row])
        t, eps, force, used = t[begin.row :], eps[begin.row :], force[begin.row :], used[begin.row :]
    r = np.abs(np.diff(eps) / np.diff(t))
    rate = float(np.median(r[r > 0.1 * r.max()]))
    if used.sum() < 5:
        raise DataError(f"only {int(used.sum())} rows inside the window; a fit needs 5", file=table.path)
    if not used.all():
        outside["outside the window"] = int((~used).sum())
    # provisionally slack: near zero after the strip was loaded; the fit then decides
    loaded = np.cumsum(force > 0.1 * float(np.max(force))) > 0
    provisional = used & loaded & _near_zero(force, noise)
    fitted = used
    if provisional.any() and (used & ~provisional).sum() >= 5:
        outside[SLACK] = int(provisional.sum())
        fitted = used & ~provisional
    if said:
        outside[END_OF_TEST] = 1
    return _Run(name, t, eps, force, noise, rate, used, fitted, outside, begin, before, said)


#: Why the last row of a record is left out (a key of ``info["left_out"]``): the row a test stage
#: writes when the test ends (a Deben Microtest .MTR ends with ``0,0,0,0,1,0,"0"``, Code 1).
END_OF_TEST = "end-of-test row (time, strain and force all 0 after the last sample)"


def _end_of_test(t: np.ndarray, eps: np.ndarray, force: np.ndarray) -> bool:
    """Whether the last row is an end-of-test row: time falls back to 0 there and its strain and
    force are 0 too, after rows whose time increases strictly. Only such a record, which a strictly
    increasing time would refuse, loses a row: every record read before is read as before."""
    if t.size < 3 or t[-1] != 0 or eps[-1] != 0 or force[-1] != 0 or t[-2] <= 0:
        return False
    return bool(np.all(np.diff(t[:-1]) > 0))


def _near_zero(force: np.ndarray, noise: float) -> np.ndarray:
    """Rows whose force is within 3 noise plus 2 % of the run's peak of zero, or below."""
    return force < 3.0 * noise + 0.02 * float(np.max(np.abs(force)))
