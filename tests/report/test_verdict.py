"""The words of a status and the units inside warnings (matid.report.verdict): presentation only."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from matid.report.verdict import in_units, one_line, reason_line, status_words
from matid.units import from_si

WARNING = (
    "E_s is likely too low: the nose travel includes a local contact compliance (about 0.063-0.17 mm/N) "
    "that is 1.2-3.3 times the shear compliance (k G A 46.6-49.2 N from E_s_torsion = 47.85 N); E_b held "
    "at 9.036e-05 N m^2, eta 450.5 N s"
)


def test_cgs_converts_every_stiffness_in_a_warning_and_nothing_else():
    text = in_units(WARNING, "cgs")
    assert "4.66e+06-4.92e+06 dyn" in text and "= 4.785e+06 dyn" in text
    assert f"{from_si(9.036e-05, 'bending_stiffness', 'cgs')[0]:.4g} dyn cm^2" in text
    assert f"{from_si(450.5, 'viscosity', 'cgs')[0]:.4g} dyn s" in text
    assert "6.3e-08-1.7e-07 cm/dyn" in text and "1.2-3.3 times" in text  # 1 mm/N = 1e-6 cm/dyn; a ratio stays
    assert " N" not in text and "mm/N" not in text
    assert in_units(WARNING, "SI") == WARNING


@given(
    st.floats(1e-9, 1e9),
    st.sampled_from([("N", "force"), ("N m^2", "bending_stiffness"), ("N s", "viscosity")]),
)
def test_a_converted_number_is_the_unit_systems(value, unit):
    symbol, kind = unit
    text = in_units(f"value {value:.6g} {symbol}.", "cgs")
    number, shown = text.split(" ")[1], text.split(" ", 2)[2].rstrip(".")
    assert shown == from_si(1.0, kind, "cgs")[1]
    assert float(number) == pytest.approx(from_si(float(f"{value:.6g}"), kind, "cgs")[0], rel=1e-3)


def test_reason_in_one_line_and_what_to_measure_instead():
    assert one_line(WARNING) == "E_s is likely too low"
    short = "E_e is strongly correlated with sls_eta (r = -0.984): read the two together"
    assert one_line(short) == short
    item = {"status": "not_identifiable", "status_reason": "its 95 % interval reaches zero",
            "measure_instead": "a torsion record with a longer linear range"}  # fmt: skip
    assert reason_line(item) == (
        "its 95 % interval reaches zero. Measure instead: a torsion record with a longer linear range"
    )
    assert reason_line({"status": "ok"}) == ""
    withheld = {
        "status": "not_identifiable",
        "measure_instead": "a longer record",
        "status_reason": "its 95 % interval (-3.1e-05 to 4.2e-05) reaches zero: the data do not bound it",
    }
    assert reason_line(withheld) == (
        "its 95 % interval reaches zero: the data do not bound it. Measure instead: a longer record"
    )
    assert [status_words(s) for s in ("ok", "check", "not_identifiable")] == [
        "use it",
        "check it",
        "not identifiable",
    ]


def test_legend_draws_a_series_left_out_whole_as_it_is_plotted():
    """A record left out of the fit is plotted hollow grey: its legend entry is too, not its colour."""
    import numpy as np

    from matid.model.results import Estimate, Series
    from matid.model.results import TestFit as Fit
    from matid.report.figures import EXCLUDED, fit_figure
    from tests.report.test_report import make_result

    test = make_result(kinds=("torsion",)).study.tests[0]
    x = np.linspace(0.0, 1.0, 20)
    series = (
        Series("kept.csv", x, 2 * x, 2 * x, np.ones(20, bool)),
        Series("out.csv", x, 3 * x, 3 * x, np.zeros(20, bool)),
    )
    fit = Fit("torsion", "T1", (test,), (Estimate("E_t", 4e-5, 1e-7, None, 20, "linear"),), series,
              "twist [rad]", "torque [N m]")  # fmt: skip
    legend = fit_figure(fit).axes[0].get_legend()
    entries = dict(zip([t.get_text() for t in legend.get_texts()], legend.legend_handles, strict=True))
    assert entries["out.csv (left out)"].get_markerfacecolor() == "none"
    assert entries["out.csv (left out)"].get_markeredgecolor() == EXCLUDED
    assert entries["kept.csv"].get_markerfacecolor() != "none"


@pytest.mark.parametrize("units", ["SI", "cgs"])
def test_caption_names_the_units_the_axes_show(units):
    """The caption of a fit plot names the axis labels as drawn (with their prefixed units)."""
    from matid.report.figures import caption, fit_figure
    from tests.report.test_report import make_result

    for fit in make_result().fits:
        if not any(len(s.x) for s in fit.series):
            continue
        axes = fit_figure(fit, units).axes
        text = caption(fit, units)
        assert axes[0].get_ylabel() in text and axes[-1].get_xlabel() in text, (text, axes[0].get_ylabel())
