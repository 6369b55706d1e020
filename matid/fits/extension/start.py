"""Where an extension run's loading starts: slack taken up, or a preload, before the ramp.

The SLS of :mod:`matid.fits.extension.fit` runs from rest: force zero at zero strain, its Maxwell
arm driven by every strain change of the record. A grip that takes up slack moves the strain
while the strip carries (almost) nothing, and a preload holds a force the model has no term for;
either way the fit bends its parameters to explain rows that are not the solid's response
(a hot tensile record with 12 s of slack: E_e collapsed to 1e-6 N).

The record shows its start in the force. From the first reading ``F_0`` a band of
``3 noise + BAND_SHARE x (peak - F_0)`` is drawn; loading begins at the first of ``RISE_ROWS``
rows in a row above the band (a rise, not a spike), and the rows before it, at least
``MIN_ROWS`` of them, are the run's start. The run has one when

- the strain moves over the start more than ``SLACK_RATIO`` x the strain the loading just after
  it takes to cross the band (``band / slope``, the slope over the rows up to ``SLOPE_SHARE`` of
  the rise): slack, the strip was not strained there; or
- ``|F_0|`` lies above the band: a preload (or a load cell not zeroed).

The strip becomes taut where the tangent just after the band (over the rows up to
``TAUT_BANDS`` bands above ``F_0``) meets the start's force; the run starts at the last row at or
before that strain, from rest, with a free force offset ``c``: ``F = c + k1 eps + f2``, f2 from
rest there (the force the strip holds and the strain it starts from are not known, only that
the response from there on is the solid's). The start is called **slack** when the strain moved
by more than ``SLACK_SHARE`` of its range before it, else **preload**.

A run that starts at rest from zero force (the force leaves the band at about the strain a line
through its start would), or whose first reading is already on the ramp (the force leaves the
band within ``MIN_ROWS`` rows: a fast ramp sampled slowly, whose first force may be a Maxwell arm
as well as a tare), has neither: nothing changes for it. A tare on a run that starts on its ramp
is therefore not found.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The band about the first force reading: this share of the force's rise to its peak ...
BAND_SHARE = 0.02
#: ... plus this many noise deviations.
BAND_NOISE = 3.0
#: Loading begins at the first of this many consecutive rows above the band.
RISE_ROWS = 3
#: A start holds at least this many rows.
MIN_ROWS = 2
#: Slack: the strain moves over the start more than this many times what the loading needs.
SLACK_RATIO = 3.0
#: The slope just after the start is the line over the rows up to this share of the force's rise.
SLOPE_SHARE = 0.2
#: The start is slack when the strain moved by more than this share of its range before the strip
#: became taut (else a preload).
SLACK_SHARE = 0.005
#: Where the strip became taut: the tangent over the rows up to this many bands above the start.
TAUT_BANDS = 4.0

SLACK = "slack"
PRELOAD = "preload"


@dataclass(frozen=True)
class Start:
    """What lies before the loading of a run: ``kind`` (SLACK or PRELOAD), the row where the strip
    becomes taut (``row``: the run starts there), the start's force and the strains it spans."""

    kind: str
    row: int
    force: float
    strain: tuple[float, float]

    def reason(self) -> str:
        """Why rows are left out or an offset is fitted, for the report."""
        lo, hi = self.strain
        if self.kind == SLACK:
            return (
                f"slack before loading (force about {self.force:.4g} N while the strain moved "
                f"{lo:.3g} to {hi:.3g}; the fit starts there from rest with a force offset)"
            )
        return (
            f"preload of {self.force:.4g} N at the start (the fit starts at strain {hi:.3g} from rest "
            "with a force offset)"
        )


def _taut(eps: np.ndarray, force: np.ndarray, row: int, near: int, level: float) -> int:
    """The last row at or before ``row`` where the tangent of the rows ``row..near`` meets the
    start's force ``level``: where the strip became taut (0 when the tangent cannot say)."""
    if near - row < 2 or np.ptp(eps[row : near + 1]) <= 0:
        return row
    slope, intercept = (float(v) for v in np.polyfit(eps[row : near + 1], force[row : near + 1], 1))
    if slope <= 0:
        return row
    before = np.flatnonzero(eps[: row + 1] <= (level - intercept) / slope)
    return int(before[-1]) if before.size else 0


def find(eps: np.ndarray, force: np.ndarray, noise: float) -> Start | None:
    """The :class:`Start` of a run (module docstring), or None when it starts at rest from zero."""
    peak = int(np.argmax(force))
    f0 = float(force[0])
    band = BAND_NOISE * noise + BAND_SHARE * (float(force[peak]) - f0)
    if peak < MIN_ROWS + RISE_ROWS or band <= 0:
        return None
    above = force[: peak + 1] > f0 + band
    run = np.convolve(above.astype(int), np.ones(RISE_ROWS, dtype=int), mode="valid") == RISE_ROWS
    if not run.any():
        return None
    begin = int(np.argmax(run))  # first row of the rise
    if begin < MIN_ROWS:
        return None  # on the ramp from the first reading
    row, level = begin - 1, float(np.median(force[:begin]))
    top = begin + int(np.argmax(force[begin : peak + 1] >= f0 + band + SLOPE_SHARE * (force[peak] - f0)))
    slack = False
    if top - row >= 3 and np.ptp(eps[row : top + 1]) > 0:
        slope = float(np.polyfit(eps[row : top + 1], force[row : top + 1], 1)[0])
        slack = slope > 0 and eps[row] - eps[0] > SLACK_RATIO * band / slope
    if not slack and abs(f0) <= band:
        return None
    near = begin + int(np.argmax(force[begin : peak + 1] > f0 + TAUT_BANDS * band))
    row = _taut(eps, force, row, near, level)
    moved = eps[row] - eps[0] > SLACK_SHARE * float(np.ptp(eps))  # the strain moved before it: slack
    return Start(SLACK if moved else PRELOAD, row, level, (float(eps[0]), float(eps[row])))
