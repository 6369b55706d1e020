"""A record of millions of rows is drawn as a reduced series (issue 21: plots draw a reduced series)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from matid.model.results import Series
from matid.report.figures import MAX_DRAWN, _draw_series


def test_a_long_record_draws_at_most_max_drawn_points_per_line_and_keeps_its_ends():
    n = 1_000_003
    x = np.linspace(0.0, 1.0, n)
    used = x < 0.8
    series = Series("long.csv", x, 2.0 * x, y_fit=2.0 * x + 1e-3, used=used)
    fig = Figure()
    ax, ax_res = fig.subplots(2)
    _draw_series(ax, ax_res, series, "C0", 1.0, 1.0)
    lines = [*ax.get_lines(), *ax_res.get_lines()]
    assert lines and max(line.get_xdata().size for line in lines) <= MAX_DRAWN
    drawn = np.concatenate([line.get_xdata() for line in ax.get_lines()[:2]])
    assert drawn.min() == 0.0 and drawn.max() > 0.999  # the whole record, not its start
    # the used / left-out split of the drawn rows is the record's
    assert ax.get_lines()[0].get_xdata().max() < 0.8 <= ax.get_lines()[1].get_xdata().min()


def test_a_short_record_draws_every_row():
    x = np.arange(500.0)
    fig = Figure()
    ax, ax_res = fig.subplots(2)
    _draw_series(ax, ax_res, Series("short.csv", x, x, y_fit=x), "C0", 1.0, 1.0)
    assert ax.get_lines()[0].get_xdata().size == 500
