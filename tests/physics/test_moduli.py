"""Material moduli from section stiffnesses: closed forms of a tube section and the E check."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from matid.physics.moduli import (
    Modulus,
    Section,
    agreement,
    area,
    modulus,
    open_tube_torsion_constant,
    polar_moment,
    rectangle_torsion_constant,
    second_moment,
)


def test_solid_rod_sections():
    r = 1e-3
    assert area(r) == pytest.approx(math.pi * 1e-6, rel=1e-15)
    assert second_moment(r) == pytest.approx(math.pi / 4 * 1e-12, rel=1e-15)
    assert polar_moment(r) == pytest.approx(math.pi / 2 * 1e-12, rel=1e-15)


def test_tube_section_is_outer_minus_inner():
    ro, ri = 1.2e-3, 0.8e-3
    assert area(ro, ri) == pytest.approx(area(ro) - area(ri), rel=1e-12)
    assert second_moment(ro, ri) == pytest.approx(second_moment(ro) - second_moment(ri), rel=1e-12)


def test_moduli_of_a_known_material():
    """A tube of E = 60 MPa, G = E / (2 (1 + 0.45)): stiffnesses built from the sections, moduli back."""
    ro, ri, E = 1.2e-3, 0.8e-3, 60e6
    G = E / 2.9
    A = math.pi * (ro**2 - ri**2)
    I = math.pi / 4 * (ro**4 - ri**4)  # noqa: E741 (the symbol of the formula)
    J = math.pi / 2 * (ro**4 - ri**4)
    ext = modulus("E_e", E * A, 0.01 * E * A, outer_radius=ro, inner_radius=ri)
    bend = modulus("E_b", E * I, 0.02 * E * I, outer_radius=ro, inner_radius=ri)
    tors = modulus("E_t", G * J, None, outer_radius=ro, inner_radius=ri)
    assert (ext.name, bend.name, tors.name) == ("E", "E", "G")
    assert ext.value == pytest.approx(E, rel=1e-12) and bend.value == pytest.approx(E, rel=1e-12)
    assert tors.value == pytest.approx(G, rel=1e-12) and tors.stderr is None
    assert ext.stderr == pytest.approx(0.01 * E) and bend.stderr == pytest.approx(0.02 * E)
    check = agreement(ext, bend)
    assert check.relative_difference == pytest.approx(0.0, abs=1e-12) and check.agree


def test_disagreement_is_measured_in_combined_standard_errors():
    ro = 1e-3
    a = modulus("E_e", 60e6 * area(ro), 1e6 * area(ro), outer_radius=ro)
    b = modulus("E_b", 66e6 * second_moment(ro), 1e6 * second_moment(ro), outer_radius=ro)
    check = agreement(a, b)
    assert check.relative_difference == pytest.approx(6 / 63, rel=1e-12)
    assert check.z == pytest.approx(6 / math.sqrt(2), rel=1e-12) and check.agree is False
    assert agreement(a, modulus("E_b", b.value * second_moment(ro), None, outer_radius=ro)).agree is None


@pytest.mark.parametrize(("ro", "ri"), [(1e-3, 1e-3), (1e-3, 2e-3), (0.0, 0.0), (1e-3, -1e-4), (math.inf, 0)])
def test_impossible_sections_are_refused(ro, ri):
    with pytest.raises(ValueError, match="outer radius > inner radius"):
        area(ro, ri)


def test_unknown_stiffness_is_refused():
    with pytest.raises(ValueError, match="no modulus from 'E_s'"):
        modulus("E_s", 1.0, None, outer_radius=1e-3)


@given(
    st.floats(1e-4, 1e-2),
    st.floats(0.0, 0.95),
    st.floats(1e5, 1e10),
)
def test_bending_and_extension_moduli_agree_for_one_material(ro, share, E):
    """For any tube and any E, E_e/A and E_b/I of stiffnesses built from E give E back and agree."""
    ri = share * ro
    a = modulus("E_e", E * area(ro, ri), 0.01 * E * area(ro, ri), outer_radius=ro, inner_radius=ri)
    b = modulus(
        "E_b", E * second_moment(ro, ri), 0.01 * E * second_moment(ro, ri), outer_radius=ro, inner_radius=ri
    )
    assert a.value == pytest.approx(E, rel=1e-9) and b.value == pytest.approx(E, rel=1e-9)
    assert agreement(a, b).agree


# --- sections other than a closed tube (contract section 10) --------------------------------------

#: Saint-Venant's torsion factor beta of J = beta a c^3 for a rectangle of sides a >= c, as tabulated
#: (Timoshenko & Goodier, Theory of Elasticity, 3rd ed., table 10; Roark table 10.1 case 4): 3 digits.
TORSION_BETA = {1.0: 0.141, 1.5: 0.196, 2.0: 0.229, 3.0: 0.263, 5.0: 0.291, 10.0: 0.312}


def prandtl_double_series(a: float, c: float, terms: int = 2000) -> float:
    """J of an a x c rectangle from the double sine series of Prandtl's stress function
    (laplacian phi = -2 on the section, J = 2 integral phi): J = 256 a^3 c^3 / pi^6
    sum_{m, n odd} 1 / (m^2 n^2 (m^2 c^2 + n^2 a^2)). Not matid's single tanh series; truncated
    at ``terms`` odd m and n, it is within 3e-10 of the limit for a / c <= 10."""
    odd = np.arange(1, 2 * terms, 2.0)
    m, n = odd[:, None], odd[None, :]
    return 256 * a**3 * c**3 / math.pi**6 * float(np.sum(1.0 / (m**2 * n**2 * (m**2 * c**2 + n**2 * a**2))))


@pytest.mark.parametrize(("ratio", "beta"), TORSION_BETA.items())
def test_rectangle_torsion_constant_against_the_tabulated_factor(ratio, beta):
    """To 1e-8 of the independent double series, which itself gives the tables' 3 digits."""
    c = 2e-3
    J = rectangle_torsion_constant(ratio * c, c)
    reference = prandtl_double_series(ratio * c, c)
    assert reference / (ratio * c * c**3) == pytest.approx(beta, abs=6e-4)
    assert J == pytest.approx(reference, rel=1e-8)
    assert rectangle_torsion_constant(c, ratio * c) == J  # the series takes the long side as a


def test_rectangular_coupon_gives_the_textbook_area_second_moment_and_modulus():
    """A PLA flexural coupon 10 x 4 mm, E = 2 GPa: E_b = E b h^3 / 12 and E_e = E b h give E back."""
    b, h, E = 10e-3, 4e-3, 2.0e9
    sec = Section("rectangle", width=b, height=h)
    assert sec.A == pytest.approx(b * h, rel=1e-15)
    assert sec.I == pytest.approx(b * h**3 / 12, rel=1e-15)
    assert sec.depth == h
    assert modulus("E_b", E * b * h**3 / 12, None, section=sec).value == pytest.approx(E, rel=1e-12)
    assert modulus("E_e", E * b * h, None, section=sec).value == pytest.approx(E, rel=1e-12)
    # A round stand-in of the same depth (the report had only diameters) is ~4x off for E_b.
    stand_in = modulus("E_b", E * b * h**3 / 12, None, outer_radius=h / 2)
    assert stand_in.value / E > 4


@given(
    ro=st.floats(min_value=0.5e-3, max_value=5e-3),
    wall=st.floats(min_value=0.005, max_value=0.1),
)
def test_slit_tube_is_the_thin_open_wall_of_its_unrolled_strip(ro, wall):
    """J of a slit tube, (1/3) s t^3 (s = 2 pi R_m), against Saint-Venant's series of the strip s x t
    it unrolls into, which is (1/3) s t^3 (1 - 0.630 t/s + ...): equal within 0.64 t/s."""
    ri = ro * (1 - wall)
    t, s = ro - ri, math.pi * (ro + ri)
    J_open = open_tube_torsion_constant(ro, ri)
    J_strip = rectangle_torsion_constant(s, t)
    assert J_open == pytest.approx(s * t**3 / 3, rel=1e-12)
    assert J_strip <= J_open and J_open == pytest.approx(J_strip, rel=0.64 * t / s)
    slit = Section("slit", 2 * ro, 2 * ri)
    closed = Section("tube", 2 * ro, 2 * ri)
    assert (slit.A, slit.I) == (closed.A, closed.I)
    # Closing the slit: J grows by ~3 (R_m / t)^2 for a thin wall (Roark table 10.1, cases 10 and 16).
    R_m = 0.5 * (ro + ri)
    assert closed.J / slit.J == pytest.approx(3 * (R_m / t) ** 2, rel=0.5 * wall + 0.01)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(shape="rectangle", width=1e-3, height=0.0), "width > 0 and height > 0"),
        (dict(shape="rectangle", width=1e-3, height=1e-3, outer_diameter=1e-3), "no diameters"),
        (dict(shape="slit", outer_diameter=2e-3), "needs an inner_diameter"),
        (dict(shape="tube", outer_diameter=2e-3, width=1e-3), "no width or height"),
        (dict(shape="hexagon", outer_diameter=2e-3), "one of tube, slit, rectangle"),
    ],
)
def test_impossible_sections_say_why(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Section(**kwargs)


# --- E_s_torsion by section ------------------------------------------------------------------------


def _torsion_estimate(value: float):
    from matid.model.results import Estimate

    return Estimate("E_t", value, 0.01 * value, (0.98 * value, 1.02 * value), 40, "linear")


def test_slit_tube_gives_the_reason_instead_of_E_s_torsion():
    from matid.fits.shear.torsion import e_s_torsion, reference_kGA
    from matid.model.study import Specimen

    slit = Specimen("S", 2.4e-3, 1.6e-3, slit=True)
    est = e_s_torsion(_torsion_estimate(1e-4), slit)
    assert est.withheld.startswith("E_s_torsion is not given for an open (slit) tube")
    assert math.isnan(est.value) and est.stderr is None and est.ci95 is None
    assert reference_kGA({"E_s_torsion": est}, slit) is None


def test_rectangle_E_s_torsion_is_cowper_k_A_times_G_of_the_series():
    from matid.fits.shear.torsion import e_s_torsion
    from matid.model.study import Specimen

    b, h, nu, G = 10e-3, 4e-3, 0.35, 0.75e9
    coupon = Specimen("C", width=b, height=h, poisson_ratio=nu)
    J = rectangle_torsion_constant(b, h)
    assert J / (b * h**3) == pytest.approx((0.229 + 0.263) / 2, abs=0.01)  # between a/c = 2 and 3
    est = e_s_torsion(_torsion_estimate(G * J), coupon)
    k = 10 * (1 + nu) / (12 + 11 * nu)  # Cowper (1966), rectangle
    assert est.value == pytest.approx(k * G * b * h, rel=1e-12)
    assert not est.withheld and est.extra["section"].startswith("rectangle")


def test_sections_describe_themselves_by_kind_and_size():
    assert Section("slit", 2.4e-3, 1.6e-3).describe() == "slit (open) tube 2.4/1.6 mm"
    assert Section("tube", 2.4e-3, 1.6e-3).describe() == "tube 2.4/1.6 mm"
    assert Section("tube", 2.4e-3, 0.0).describe() == "rod 2.4/0 mm"
    assert Section("rectangle", width=10e-3, height=4e-3).describe() == "rectangle 10 mm x 4 mm"


def test_a_modulus_needs_a_section():
    with pytest.raises(ValueError, match="^modulus needs a section or an outer radius$"):
        modulus("E_b", 1e-4, None)


def test_agreement_in_combined_standard_errors_below_one():
    """E 2.0 +- 0.3 and 2.8 +- 0.4 (combined 0.5): 0.8 apart is z = 1.6, 33 % of the mean 2.4."""
    a, b = Modulus("E", "E_e", 2.0, 0.3), Modulus("E", "E_b", 2.8, 0.4)
    result = agreement(a, b)
    assert result.z == pytest.approx(1.6, rel=1e-12)
    assert result.relative_difference == pytest.approx(0.8 / 2.4, rel=1e-12)
    assert result.agree


def test_agreement_of_two_zero_moduli_is_no_number_not_an_error():
    result = agreement(Modulus("E", "E_e", 0.0, 0.0), Modulus("E", "E_b", 0.0, 0.0))
    assert result.relative_difference == math.inf and result.z == 0.0


def test_a_slit_rod_is_no_section():
    message = r"^a slit \(open\) tube needs an inner_diameter > 0: a slit rod is not a section$"
    with pytest.raises(ValueError, match=message):
        Section("slit", 2e-3, 0.0)
