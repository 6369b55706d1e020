"""Material moduli from section stiffnesses: closed forms of a tube section and the E check."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from matid.physics.moduli import agreement, area, modulus, polar_moment, second_moment


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
