r"""Long records: the residuals of a run as means over bins that grow with time since a kink.

A relaxation record sampled at 20 Hz for an hour holds ~10^5 rows, but the force after a
change of strain rate (a kink: the start, the end of a ramp) varies on the scale of the
time since that kink: the information lies on a logarithmic time axis. A run with more
than :data:`REDUCE_ABOVE` used rows is therefore fitted on bin means::

    bin of row i:  floor( ln(1 + (t_i - t_k) / w0) / ln(1 + c) ),   w0 = dt / c

with t_k the last kink at or before row i, dt the sampling step and c = :data:`GROWTH`:
single rows up to ~dt / c after each kink, then bins of width ~c (t - t_k). Bins never
cross a kink, a gap in the used rows, or the window. The model still runs over every row
(the solid has a memory); only its residuals are averaged, model and data alike, so the
reduced residual is exact, and little information is lost (the Jacobian changes by a
fraction ~c across a bin).

Weights: a bin of m rows enters as ``sqrt(m) x`` its mean residual, so its square is the sum
of the squared residuals of its rows less their spread about the mean (which the model barely
moves): the least squares on bin means is the least squares on every row, and gives the full
record's values (issue 28 item 6). The bins are not weighted by an AR(1) model of the noise:
residuals of a model that misses part of the record (a Prony series on an elastomer that still
relaxes) look like noise of correlation ~1, which would weigh every bin as one row, shift the
misfit's compromise towards the rows just after a kink, and so move the values (VHB4910, 90 104
rows: E_e 0.659 N on bins weighted so, 0.618 N on every row and on these bins). The intervals
are the AR(1) sandwich on every row (:mod:`matid.fits.extension.stats`), as before.

A run with fewer rows keeps one residual per used row (bit-identical to no reduction).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

#: Used rows of a run above which its residuals are bin means.
REDUCE_ABOVE = 5000
#: Relative growth of a bin with time since the last kink.
GROWTH = 0.02
#: A change of strain rate between samples larger than this fraction of the run's typical
#: rate is a kink.
KINK = 0.25


@dataclass(frozen=True, eq=False)
class Reduction:
    """Rows of one run -> its residuals: the used rows, averaged over bins (``starts`` into the
    used rows; None: one residual per used row), each mean times sqrt(rows in the bin)."""

    used: np.ndarray
    starts: np.ndarray | None = None

    @functools.cached_property
    def count(self) -> np.ndarray:
        n = int(self.used.sum())
        if self.starts is None:
            return np.ones(n, dtype=int)
        return np.diff(np.append(self.starts, n))

    @functools.cached_property
    def _scale(self) -> np.ndarray:
        """Bin sum -> sqrt(count) x mean = sum / sqrt(count) (module docstring)."""
        return np.sqrt(self.count)

    @property
    def size(self) -> int:
        """Residuals of the run."""
        return int(self.used.sum()) if self.starts is None else int(self.starts.size)

    def __call__(self, values: np.ndarray) -> np.ndarray:
        """``values`` over all rows (1-D, or rows x columns) -> one value per residual."""
        picked = values[self.used]
        if self.starts is None:
            return picked
        sums = np.add.reduceat(picked, self.starts, axis=0)
        return sums / (self._scale if sums.ndim == 1 else self._scale[:, None])

    def means(self, values: np.ndarray) -> np.ndarray:
        """Plain bin means of ``values`` over the used rows (for plots)."""
        picked = values[self.used]
        if self.starts is None:
            return picked
        return np.add.reduceat(picked, self.starts, axis=0) / self.count


def reduction(t: np.ndarray, eps: np.ndarray, used: np.ndarray, rate: float) -> Reduction:
    """The :class:`Reduction` of a run (see the module docstring)."""
    if used.sum() <= REDUCE_ABOVE:
        return Reduction(used)
    dt = float(np.median(np.diff(t)))
    w0 = dt / GROWTH
    r = np.diff(eps) / np.diff(t)
    kink = np.zeros(t.size, dtype=bool)
    kink[0] = True
    kink[1:-1] = np.abs(np.diff(r)) > KINK * rate
    t_kink = np.maximum.accumulate(np.where(kink, t, -np.inf))
    since = np.floor(np.log1p((t - t_kink) / w0) / math.log1p(GROWTH))
    rows = np.flatnonzero(used)
    epoch = np.cumsum(kink)[rows]  # bins restart at each kink
    new = np.ones(rows.size, dtype=bool)
    new[1:] = (np.diff(rows) > 1) | (np.diff(epoch) != 0) | (np.diff(since[rows]) != 0)
    return Reduction(used, np.flatnonzero(new))
