"""The shear fit's side formulas (E_s from torsion, the reference k G A checks, the start value) against
closed forms written out here, for what the mutation sample (benchmarks/mutation.sh, seed 29) showed
no other test sees."""

from __future__ import annotations

import math

import numpy as np
import pytest

from matid.fits.shear import checks, torsion
from matid.model.results import Estimate
from matid.model.study import Specimen

COUPON = Specimen("R", width=4e-3, height=1e-3)  # a rectangle: Cowper's k, no Poisson ratio given


def cowper(nu: float) -> float:
    return 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)  # rises with nu: the range's ends are nu = 0.3, 0.5


def e_t(value=2e-5, stderr=None, ci95=None, n=17) -> Estimate:
    return Estimate("E_t", value, stderr, ci95, n, "linear")


@pytest.mark.parametrize(
    ("stderr", "ci95"),
    [(None, None), (1e-6, None), (1e-6, (1.8e-5, 2.3e-5))],
    ids=["no error", "stderr only", "own interval"],
)
def test_e_s_torsion_of_a_coupon_carries_the_poisson_range_and_e_t_s_error(stderr, ci95):
    """k at the geometric mean of Cowper's k over nu in [0.3, 0.5], the half range h = ln(k_hi/k_lo)/2
    taken as uniform: stderr = E (sd_t (+) h/sqrt3), interval exp(+-(ci_t (+) 0.95 h)), where
    ci_t is E_t's own upper interval in log, else 1.96 sd_t (0 without an error)."""
    E_t = e_t(stderr=stderr, ci95=ci95)
    est = torsion.e_s_torsion(E_t, COUPON)

    lo, hi = cowper(0.3), cowper(0.5)
    h = 0.5 * math.log(hi / lo)
    value = math.sqrt(lo * hi) * COUPON.section.A * 2e-5 / COUPON.section.J
    sd_t = (stderr or 0.0) / 2e-5
    ci_t = math.log(ci95[1] / 2e-5) if ci95 else 1.96 * sd_t
    half = math.sqrt(ci_t**2 + (0.95 * h) ** 2)
    assert est.value == pytest.approx(value, rel=1e-12)
    assert est.stderr == pytest.approx(value * math.sqrt(sd_t**2 + h**2 / 3.0), rel=1e-12)
    assert est.ci95 == pytest.approx((value * math.exp(-half), value * math.exp(half)), rel=1e-12)
    assert est.n_points == 17 and est.extra["k_range"] == pytest.approx([lo, hi], rel=1e-12)
    assert "Cowper" in est.extra["formula"]


def test_the_local_compliance_of_a_coupon_is_that_of_the_solid_rod_of_its_height():
    """half depths (h/2, 0): R_m = h/4, t = h/2, c = kappa R_m^1.5 / (E t^2.5) (torsion's docstring)."""
    E, h = 50e6, COUPON.height
    base = (h / 4) ** 1.5 / (E * (h / 2) ** 2.5)
    low, high = torsion.local_compliance(COUPON, E)
    assert (low, high) == pytest.approx((0.95 * base, 1.58 * base), rel=1e-12)


def test_the_wall_modulus_without_an_extension_test_comes_from_e_t_and_the_mean_poisson_ratio():
    """E = 2 (1 + nu) G, G = E_t / J, nu the middle of the default range 0.3-0.5."""
    E = torsion.young_modulus({"E_t": e_t()}, COUPON)
    assert E == pytest.approx(2.0 * 1.4 * 2e-5 / COUPON.section.J, rel=1e-12)


@pytest.mark.parametrize(("ratio", "verdict"), [(1.05, "agree"), (1.5, "disagree")])
def test_the_torsion_comparison_states_the_combined_error_and_the_verdict(ratio, verdict):
    """Relative errors 3 % and 4 %: combined 5.0 %; a ratio within 2 x 5 % agrees, 1.5 does not
    (and the disagreement lists the usual causes, the Poisson's ratio among them)."""
    bend = Estimate("E_s", 21.0 * ratio, 0.03 * 21.0 * ratio, None, 30, "cosserat-fe")
    tors = Estimate("E_s_torsion", 21.0, 0.04 * 21.0, None, 17, "shear-coefficient")
    text = torsion.agreement(bend, tors)
    assert f" {verdict}: " in text
    assert f"the bend gives {ratio:.2g} times the torsion value" in text
    assert text.split("natural log of the ratio ")[1].startswith(f"{math.log(ratio):+.2f})")
    assert "combined relative standard error of 5.0 %" in text
    assert ("a wrong Poisson's ratio" in text) is (verdict == "disagree")


# --- checks.py: the reference k G A and what it says about a fit ---


def test_the_shear_share_is_one_half_where_shear_and_bending_compliances_are_equal():
    """S/(4 E_s) = S^3/(48 E_b) at E_s = 12 E_b / S^2; a tenth of that E_s gives 10/11."""
    S, E_b = 0.01, 6.5e-5
    assert checks.shear_share(S, E_b, 12 * E_b / S**2) == pytest.approx(0.5, rel=1e-12)
    assert checks.shear_share(S, E_b, 1.2 * E_b / S**2) == pytest.approx(10 / 11, rel=1e-12)


TUBE = Specimen("T1", 2.4e-3, 1.6e-3, poisson_ratio=0.4)  # nu given: the reference is one value


def reference(kGA: float) -> dict[str, Estimate]:
    """E_s_torsion with a +-1 % interval: the reference k G A range (lo, hi)."""
    return {
        "E_b": Estimate("E_b", 6.5e-5, 0.0, None, 0, "linear"),
        "E_s_torsion": Estimate(
            "E_s_torsion", kGA, 0.005 * kGA, (0.99 * kGA, 1.01 * kGA), 9, "shear-coefficient"
        ),
    }


def test_the_assessment_reports_each_span_s_shear_share_at_the_reference():
    S = [0.006, 0.01]
    out = checks.assess(S, 6.5e-5, TUBE, reference(21.0), nose=False, local=None)
    assert out.info["reference_kGA_N"] == pytest.approx([0.99 * 21.0, 1.01 * 21.0])
    shares = [(s / (4 * 1.01 * 21.0)) / (s / (4 * 1.01 * 21.0) + s**3 / (48 * 6.5e-5)) for s in S]
    assert out.info["reference_shear_share"] == pytest.approx(shares, rel=1e-12)


@pytest.mark.parametrize(("bias", "warned"), [(0.05, False), (0.2, True)])
def test_nose_travel_is_warned_of_only_beyond_a_ten_percent_bias_and_the_message_has_its_ratios(bias, warned):
    """A local compliance chosen so that the least favourable ratio c_s/(c_s + c_loc) is 1 - bias at
    the upper reference (hi): 5 % bias passes silently, 20 % warns and widens the interval by
    1/0.8; the message's compliance ratios are c_loc/c_s at (lo, hi)."""
    S, kGA = 0.01, 21.0
    lo, hi = 0.99 * kGA, 1.01 * kGA
    c_hi = (S / (4 * hi)) * bias / (1 - bias)  # c_s/(c_s + c) = 1 - bias
    local = (0.5 * c_hi, c_hi)
    out = checks.assess([S], 6.5e-5, TUBE, reference(kGA), nose=True, local=local)
    worst = (S / (4 * hi)) / (S / (4 * hi) + c_hi)
    assert out.info["nose_bias_ratio"][0] == pytest.approx(1 - bias, rel=1e-12) == pytest.approx(worst)
    assert out.withhold is None
    if not warned:
        assert out.warnings == [] and out.widen == 1.0
        return
    (warning,) = out.warnings
    assert out.widen == pytest.approx(1 / (1 - bias), rel=1e-12)
    odds = bias / (1 - bias)  # c_loc / c_s at hi; at lo the low end is half as large, c_s lo/hi as large
    assert f"{0.5 * odds * lo / hi:.2g}-{odds:.2g} times the shear compliance" in warning
    assert warning.startswith("E_s is likely too low")


def test_the_model_form_share_without_a_reference_is_that_of_the_fitted_e_s():
    """No reference k G A (info without it): the shear share of the model-form variance is that of
    E_s_fit; delta/share squared is the variance of ln E_s."""
    from types import SimpleNamespace

    S, E_b, E_s = 0.01, 6.5e-5, 12 * 6.5e-5 / 0.01**2  # share 1/2
    b = SimpleNamespace(d=np.array([0.0, 1e-4]), geometry=SimpleNamespace(span=S))
    mf = checks.model_form_variance([b], E_b, {}, E_s, None)
    delta = 0.01 + 0.2 * 1e-4 / S
    assert mf["relative_compliance"] == pytest.approx(delta, rel=1e-12)
    assert mf["shear_share"] == pytest.approx(0.5, rel=1e-12)
    assert mf["var_log"] == pytest.approx((2 * delta) ** 2, rel=1e-12)


# --- data.py: the rows of a bend file and the start value ---


def test_a_rig_whose_span_exceeds_the_specimen_is_a_data_error_naming_the_file_and_why():
    from matid.errors import DataError
    from matid.fits.shear.data import bend_data
    from tests.fits.shear.test_fit import SPECIMEN, measurement, rig

    d = np.linspace(0.0, 1e-3, 20)
    m = measurement(d, 200.0 * d, rig(0.04, specimen_length=0.03), name="long.csv")
    with pytest.raises(DataError) as info:
        bend_data(m, SPECIMEN, 6.5e-5)
    assert info.value.file == "long.csv"
    assert info.value.detail == "three-point bend needs specimen_length > span > 0"


def test_rows_below_zero_deflection_that_carry_force_are_refused_naming_the_deflection_column():
    """A line of 200 N/m through d = -0.1 mm (no toe: the force rises from the first row): the rows
    below zero carry force beyond the noise, so they are not crosshead scatter before contact."""
    from matid.errors import DataError
    from matid.fits.shear.data import bend_data
    from tests.fits.shear.test_fit import SPECIMEN, measurement, rig

    d = np.linspace(-1e-4, 1e-3, 23)
    m = measurement(d, 200.0 * (d + 1e-4), rig(0.01), name="neg.csv")
    with pytest.raises(DataError, match="negative deflection on the loading branch") as info:
        bend_data(m, SPECIMEN, 6.5e-5)
    assert info.value.column == "deflection" and info.value.file == "neg.csv"


def test_data_without_a_visible_shear_compliance_start_from_a_small_shear_share():
    """Straight data at 0.9 of the pure-bending compliance S^3/(48 E_b) (allowed: above
    ABSURD_COMPLIANCE_RATIO) show no shear compliance: the start E_s is then a stiff one, whose shear
    compliance S/(4 E_s) is a small part (below 5 %) of bending, from the shortest span."""
    from matid.fits.shear.data import bend_data, timoshenko_start
    from tests.fits.shear.test_fit import SPECIMEN, measurement, rig

    E_b = 6.5e-5
    data = []
    for S in (0.01, 0.02):
        d = np.linspace(0.0, 1e-3, 20)
        data.append(bend_data(measurement(d, d / (0.9 * S**3 / (48 * E_b)), rig(S)), SPECIMEN, E_b))
    E_s = timoshenko_start(data, E_b)
    share = checks.shear_share(0.01, E_b, E_s)
    assert 0.0 < share < 0.05
