"""Figures draw what the user's files name: control characters are shown escaped, never as a
missing-glyph box (matid.report.figures.printable)."""

from __future__ import annotations

import warnings

import pytest
from hypothesis import given
from hypothesis import strategies as st
from matplotlib.figure import Figure

from matid.report.figures import png_bytes, printable, quiet_legend


@given(st.text(max_size=40))
def test_printable_escapes_exactly_the_control_characters(text):
    """Character by character: a control character (tab, CR and newline included) becomes ``\\xNN``,
    any other character stays as it is."""
    control = lambda c: ord(c) < 0x20 or 0x7F <= ord(c) <= 0x9F  # noqa: E731
    expected = "".join(f"\\x{ord(c):02x}" if control(c) else c for c in text)
    assert printable(text) == expected
    assert not any(control(c) for c in printable(text))


@pytest.mark.parametrize("name", ["\t=1.csv", "run\r1.csv", "a\x1bb.csv"])
def test_a_legend_of_a_file_named_with_control_characters_draws_without_a_missing_glyph(name):
    """Seen in the hostile-text fuzz: a record file named '\\t=1' made matplotlib warn 'Glyph 9
    missing from font(s) DejaVu Sans' and draw a box in the fit plot's legend."""
    fig = Figure(figsize=(3, 2))
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1], label=name)
    legend = quiet_legend(ax)
    assert legend.get_texts()[0].get_text() == printable(name)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        png_bytes(fig)
