"""E_s of a real tube (physics.md section 7): centreline, nose travel, torsion, windows, spans.

Continuum data: ``tests/data/tube3d/T8.json`` and ``T20.json`` are copies of
``shared/reference/tube3d`` (CalculiX C3D20, NLGEOM, frictionless contact; tube
E 50 MPa, nu 0.45, R_o 1.2, R_i 0.8 mm). Its true k G A with Hutchinson's
coefficient is 27.17 N; E_b = 6.5345e-5 N m^2, E_e = 125.66 N.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from matid.errors import DataError, FitError
from matid.example.forward import bend_force
from matid.fits.shear import fit as shear
from matid.fits.shear import torsion as shear_torsion
from matid.fits.shear import window as bend_window
from matid.fits.torsion import fit_torsion
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.model.results import Estimate
from tests import TESTS

DATA = TESTS / "data" / "tube3d"
KGA = 27.17  # k G A of the continuum tube, Hutchinson
TUBE = study.Specimen("T", 2.4e-3, 1.6e-3)
TUBE_KNOWN = {
    "E_b": Estimate("E_b", 6.5345e-5, 0.0, None, 0, "linear"),
    "E_e": Estimate("E_e", 125.66, 0.0, None, 0, "sls"),
}


def bend(d, F, span, *, at="nose", length=None, name="3pb.csv", window=None) -> Measurement:
    params = {
        "span": span,
        "specimen_length": length or span + 8e-3,
        "support_radius": 2e-3,
        "nose_radius": 2e-3,
    }
    test = study.Test("three_point_bend", "T", Path(name), params, window=window or {}, deflection_at=at)
    return Measurement(
        test, Table(Path(name), {"deflection": np.asarray(d), "force": np.asarray(F)}, {}, {}, "")
    )


def tube3d(span_mm: int, column: str, name: str = "T{}.json") -> tuple[np.ndarray, np.ndarray]:
    rows = json.loads((DATA / name.format(span_mm)).read_text())["rows"]
    return np.r_[0.0, [r[column] for r in rows]] * 1e-3, np.r_[0.0, [r["F"] for r in rows]]


# --------------------------------------------------------------------------- continuum tube


@pytest.mark.parametrize("span_mm", [8, 20])
def test_centreline_of_the_continuum_tube(span_mm):
    """8 mm: within 3 % of k G A (measured 27.55 N, +1.4 %). 20 mm (shear 6 % of the compliance):
    the rod's form error against the continuum is carried into the interval, which covers k G A."""
    d, F = tube3d(span_mm, "delta_centroid")
    fit = shear.fit_three_point_bend(
        [bend(d, F, span_mm * 1e-3, at="centreline")], specimen=TUBE, known=TUBE_KNOWN
    )
    est = fit.estimate("E_s")
    assert est.ci95[0] < KGA < est.ci95[1]
    assert fit.info["measurement"] == "centreline deflection"
    if span_mm == 8:
        assert est.value == pytest.approx(KGA, rel=0.03)
        assert est.warnings == ()
    else:
        assert est.value == pytest.approx(KGA, rel=0.15)
        assert any("poorly determined" in w for w in est.warnings)


@pytest.mark.parametrize("span_mm", [10, 15])
def test_nose_travel_of_the_continuum_tube_is_never_a_confident_wrong_number(span_mm):
    """Fitted on nose travel the rod model gives 0.23-0.62 of k G A. Here: a warning first, naming the
    local compliance and what to measure instead, and an interval widened by the predicted bias.
    On spans the contact-compliance constant was not calibrated on (8 and 20 mm: see
    matid.fits.shear.torsion): our continuum's 10 and 15 mm."""
    d, F = tube3d(span_mm, "delta", "S{}_bench.json")
    est = shear.fit_three_point_bend([bend(d, F, span_mm * 1e-3)], specimen=TUBE, known=TUBE_KNOWN).estimate(
        "E_s"
    )
    assert est.value < 0.7 * KGA  # the bias is there ...
    first = est.warnings[0]  # ... and said first, with what to measure instead
    assert first.startswith("E_s is likely too low") and "local contact compliance" in first
    assert 'deflection_at = "centreline"' in first and "E_s_torsion" in first
    assert est.ci95[0] < KGA < est.ci95[1]


def test_nose_travel_at_a_very_short_span_is_withheld():
    """4 mm on the continuum tube: even the most favourable prediction gives E_s at < 1/4 of its value."""
    d = np.linspace(0.0, 0.04e-3, 6)
    F = d / (4e-3**3 / (48 * 6.5345e-5) + 4e-3 / (4 * KGA) + 0.23e-3)
    with pytest.raises(FitError, match="withheld.*centreline.*E_s_torsion"):
        shear.fit_three_point_bend([bend(d, F, 4e-3)], specimen=TUBE, known=TUBE_KNOWN)


def test_stated_nose_bias_holds_at_high_load():
    """Nose travel to d/S = 10 % of a tube with the continuum's contact travel (the demo's T2 law,
    forward.bend_force_nose): the local compliance falls with load, so the fit returns E_s at ~0.4 of
    its value, above the band calibrated at d/S <= 1 %; the stated range must still hold it."""
    from matid.example.forward import bend_force_nose

    E_b, E_s, E_e, outer, inner = 9.0e-5, 47.9, 190.0, 2.2e-3, 1.4e-3
    E = E_e / (math.pi / 4 * (outer**2 - inner**2))
    rig = {"span": 0.010, "specimen_length": 0.030, "support_radius": 2e-3, "nose_radius": 2e-3}
    d = np.linspace(0.0, 1e-3, 30)
    F = bend_force_nose(d, E_b=E_b, E_s=E_s, E_e=E_e, outer_diameter=outer, inner_diameter=inner, E=E, **rig)
    known = {
        "E_b": Estimate("E_b", E_b, 0.0, None, 0, "linear"),
        "E_e": Estimate("E_e", E_e, 0.0, None, 0, "sls"),
    }
    fit = shear.fit_three_point_bend(
        [bend(d, F, 0.010, length=0.030)], specimen=study.Specimen("T", outer, inner), known=known
    )
    est = fit.estimate("E_s")
    worst, best = fit.info["assessment"]["nose_bias_ratio"]
    assert worst < est.value / E_s < best < 0.7
    assert est.warnings[0].startswith("E_s is likely too low") and est.ci95[0] < E_s < est.ci95[1]


@pytest.mark.parametrize("name", ["S6_bench.json", "S10_bench.json", "S15_bench.json", "S30_bench.json"])
def test_local_compliance_law_holds_on_spans_it_was_not_calibrated_on(name):
    """The band is calibrated on spans 8 and 20 mm (matid.fits.shear.torsion); the local compliance
    (nose travel minus centreline deflection, over F) of the continuum at the held-out spans
    must lie in it (measured 0.206-0.312 mm/N against the band 0.188-0.312 mm/N)."""
    low, high = shear_torsion.local_compliance(TUBE, 50e6)
    rows = json.loads((DATA / name).read_text())["rows"]
    measured = np.array([(r["delta"] - r["delta_centroid"]) / r["F"] for r in rows]) * 1e-3  # m/N
    assert np.all((low <= measured) & (measured <= high)), (name, measured, (low, high))


# --------------------------------------------------------------------------- E_s from torsion


def torsion(E_t: float, length: float = 0.06) -> Measurement:
    phi = np.linspace(0.0, 0.5, 40)
    test = study.Test("torsion", "T", Path("torsion.csv"), {"length": length})
    table = Table(Path("torsion.csv"), {"twist_angle": phi, "torque": E_t * phi / length}, {}, {}, "")
    return Measurement(test, table)


def test_hutchinson_coefficient_closed_form():
    assert shear_torsion.hutchinson_k(0.45, 1.2, 0.8) == pytest.approx(0.6271, abs=1e-4)
    # solid circle: 6 (1 + nu)^2 / (7 + 12 nu + 4 nu^2) (Hutchinson 2001)
    assert shear_torsion.hutchinson_k(0.3, 1.0) == pytest.approx(6 * 1.3**2 / (7 + 3.6 + 0.36), rel=1e-12)


def test_E_s_torsion_on_exact_data():
    """E_t = G J of the continuum tube through the torsion fit: E_s_torsion within 1 % of k G A."""
    a, b = 1.2e-3, 0.8e-3
    G = 50e6 / (2 * 1.45)
    E_t = G * math.pi / 2 * (a**4 - b**4)
    fit = fit_torsion([torsion(E_t)], specimen="T")
    given_nu = shear_torsion.with_E_s_torsion(fit, study.Specimen("T", 2 * a, 2 * b, poisson_ratio=0.45))
    est = given_nu.estimate("E_s_torsion")
    assert est.method == "shear-coefficient" and est.kind == "force"
    exact = shear_torsion.hutchinson_k(0.45, a, b) * G * math.pi * (a**2 - b**2)
    assert exact == pytest.approx(KGA, abs=0.005)
    assert est.value == pytest.approx(exact, rel=0.01)
    assert est.ci95[0] <= exact <= est.ci95[1]
    # nu not given: 0.3-0.5 carried into the interval, which still covers k G A and is wider
    wide = shear_torsion.with_E_s_torsion(fit, TUBE).estimate("E_s_torsion")
    assert wide.ci95[0] < KGA < wide.ci95[1]
    assert wide.ci95[1] / wide.ci95[0] > est.ci95[1] / est.ci95[0]
    assert wide.extra["nu_range"] == [0.3, 0.5]


def test_bend_and_torsion_agreement_is_stated():
    es = Estimate("E_s", 27.5, 0.5, None, 10, "cosserat-fe")
    tor = Estimate("E_s_torsion", 27.0, 0.4, None, 10, "shear-coefficient")
    assert " agree:" in shear_torsion.agreement(es, tor)
    far = Estimate("E_s", 12.0, 0.3, None, 10, "cosserat-fe")
    assert "disagree" in shear_torsion.agreement(far, tor)


# --------------------------------------------------------------------------- windows and bad data

E_B, E_S, E_E = 6.5e-5, 21.0, 120.0
SPEC = study.Specimen("T", 2.4e-3, 1.6e-3)
KNOWN = {
    "E_b": Estimate("E_b", E_B, 0.0, None, 0, "linear"),
    "E_e": Estimate("E_e", E_E, 0.0, None, 0, "sls"),
}


def rod(span: float, n: int = 24, frac: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    d = np.linspace(0.0, frac * span, n)
    rig = {"span": span, "specimen_length": span + 8e-3, "support_radius": 2e-3, "nose_radius": 2e-3}
    return d, bend_force(d, E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=2.4e-3, **rig)


def fit_rod(tests, **kw):
    """Rod data (the shooting model): no contact compliance, no model-form error."""
    return shear.fit_three_point_bend(
        tests, specimen=SPEC, known=KNOWN, local_compliance=(0.0, 0.0), model_form=0.0, **kw
    )


def test_slack_toe_and_break_after_the_peak():
    """A 0.08 mm slack toe (force rising quadratically) and a fracture after the peak, noise 0.3 %:
    E_s within 5 % from the rows before the peak, the rest shown and counted with the reason."""
    span = 0.010
    d, F = rod(span)
    slack = 0.08e-3
    toe_d = np.linspace(0.0, slack, 6)[:-1]
    toe_F = 0.02 * F[3] * (toe_d / slack) ** 2
    brk_d = d[-1] + np.linspace(0.02e-3, 0.2e-3, 6)
    brk_F = F[-1] * np.linspace(0.3, 0.05, 6)
    dd = np.r_[toe_d, d + slack, brk_d + slack]
    FF = np.r_[toe_F, F, brk_F]
    FF = FF + np.random.default_rng(7).normal(0.0, 0.003 * F.max(), FF.size)
    fit = fit_rod([bend(dd, FF, span, length=0.03, name="toe.csv")])
    est = fit.estimate("E_s")
    assert est.value == pytest.approx(E_S, rel=0.05)
    reasons = fit.info["rows_left_out"]["toe.csv"]
    assert any("peak" in r for r in reasons) and any("toe" in r for r in reasons)
    assert fit.info["toe_offset_m"]["toe.csv"] == pytest.approx(slack, abs=0.03e-3)
    assert not fit.series[0].used[-6:].any()


def test_window_rows_are_left_out():
    span = 0.010
    d, F = rod(span)
    m = bend(d, F, span, length=0.03, window={"deflection": (0.0, 0.6 * d[-1])})
    fit = fit_rod([m])
    assert fit.series[0].used.sum() == int((d <= 0.6 * d[-1]).sum())
    assert fit.estimate("E_s").value == pytest.approx(E_S, rel=0.01)


def test_force_in_a_wrong_unit_is_a_data_error_naming_file_and_column():
    span = 0.010
    d, F = rod(span)
    with pytest.raises(DataError) as info:
        fit_rod([bend(d, 1000 * F, span, length=0.03, name="mN_as_N.csv")])
    assert info.value.column == "force" and "mN_as_N.csv" in str(info.value)


def test_all_zero_force_is_a_fit_error():
    d = np.linspace(0.0, 1e-3, 20)
    with pytest.raises(FitError, match="zero.csv"):
        fit_rod([bend(d, np.zeros_like(d), 0.010, length=0.03, name="zero.csv")])


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-1.0, 5.0), min_size=1, max_size=40),
    st.lists(st.floats(-1.0, 10.0), min_size=1, max_size=40),
)
def test_cut_keeps_an_increasing_branch_ending_at_the_peak(ds, fs):
    n = min(len(ds), len(fs))
    d, F = np.array(ds[:n]), np.array(fs[:n])
    c = bend_window.cut(d, F, np.ones(n, dtype=bool))
    kept = np.nonzero(c.used)[0]
    assert np.all(np.diff(d[kept]) > 0)
    assert kept.size == 0 or kept[-1] <= int(np.argmax(F))
    assert c.d0 >= 0 and sum(c.reasons.values()) == n - kept.size


# --------------------------------------------------------------------------- several spans


def test_spans_that_disagree_are_flagged():
    """Nose travel with a local compliance of 0.25 mm/N added at 6 and 20 mm: per-span E_s differ
    far beyond their noise, and the consistency test says so; without it the spans agree."""
    tests, clean = [], []
    for span, seed in ((0.006, 1), (0.020, 2)):
        d, F = rod(span, n=10, frac=0.01)
        F = F + np.random.default_rng(seed).normal(0.0, 0.002 * F.max(), F.size)
        clean.append(bend(d, F, span, name=f"S{span}.csv"))
        tests.append(bend(d + 0.25e-3 * F, F, span, name=f"S{span}.csv"))
    fit = fit_rod(tests)
    per = fit.info["per_span"]
    assert [round(p["span_mm"]) for p in per] == [6, 20]
    assert per[0]["E_s"] < 0.7 * per[1]["E_s"]
    assert fit.info["span_consistency"]["p"] < 0.01
    assert any("spans disagree" in w for w in fit.estimate("E_s").warnings)
    ok = fit_rod(clean)
    assert ok.info["span_consistency"]["p"] > 0.01
    assert not any("spans disagree" in w for w in ok.estimate("E_s").warnings)
