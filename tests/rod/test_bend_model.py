"""The bend half model's meshes nest, so its Richardson estimate holds (issue 29: the shipped
three_point_bend scene's meshes 4, 8, 16 put the support at vertices 1, 3, 5 and its estimate was
2.3x below its error)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matid.rod.bend import BASE, support_vertex


@given(st.integers(2, 600), st.floats(0.01, 0.99))
def test_the_support_vertex_is_inside_and_near_its_fraction(n, fraction):
    k = support_vertex(n, fraction)
    assert 1 <= k <= n - 1
    m = n
    while m % 2 == 0 and m // 2 >= BASE:
        m //= 2
    assert abs(k / n - fraction) <= 1 / m  # no further than one element of the base mesh


@given(st.integers(BASE, 300), st.floats(0.01, 0.99))
def test_meshes_of_n_and_2n_elements_nest(n, fraction):
    """Every element of n is two of 2n: the support vertex of 2n is twice that of n."""
    assert support_vertex(2 * n, fraction) == 2 * support_vertex(n, fraction)


def _bent():
    from matid.rod.bend import BendGeometry, BendModel

    geometry = BendGeometry(span=0.01, specimen_length=0.03, support_radius=0.002, nose_radius=0.003,
                            outer_diameter=0.0024)  # fmt: skip
    model = BendModel(geometry, elements=12)
    return model, model.solve(6.5e-5, 21.0, 120.0, [2e-4, 5e-4, 1e-3]), geometry


def test_the_half_model_has_its_elements_and_the_support_section_on_a_vertex():
    """Mutation survivor (seed 29): a mesh of 50 points in place of elements - k + 1 gave the same
    forces (finer), unseen; the mesh has exactly ``elements`` and the contact section is a vertex."""
    model, _, _ = _bent()
    vertices = model.vertices(0.5)
    assert vertices.size == model.elements + 1 and np.all(np.diff(vertices) > 0)
    assert vertices[model.support_vertex] == 0.5 and vertices[-1] == model.half


def test_the_drawn_bend_touches_its_rollers_and_nose_at_the_outer_radius():
    """BendModel.shape (the report's drawing) against the rig's geometry, not the code's: the
    whole tube is mirror symmetric about mid-span, ordered along the span, and its centreline
    passes the outer radius from each support roller and from the nose (rolling contact),
    with the rollers at +-span/2. Kills the shape survivors of seed 29 (z order, outer radius,
    support side)."""
    model, path, g = _bent()
    shape = model.shape(path)
    z, x = shape["z"], shape["x"]
    assert np.all(np.diff(z) > 0) and np.allclose(z, -z[::-1], atol=1e-15) and np.allclose(x, x[::-1])
    assert shape["outer_radius"] == g.outer_diameter / 2 and shape["deflection"] == 1e-3
    points = np.c_[z, x]  # the model's nodes: the contact sections are among them
    for (centre, radius), side in zip(shape["supports"], (-1, 1), strict=True):
        assert centre[0] == side * g.span / 2 and radius == g.support_radius
        gap = np.hypot(*(points - np.asarray(centre)).T).min() - radius - g.outer_diameter / 2
        assert abs(gap) < 1e-6 * g.outer_diameter, (side, gap)  # touches, never through
    # the nose touches at mid-span (the half model's point contact; with shear, the nodes beside it
    # come 15 um inside the nose's offset circle at d = 1 mm: left as noticed, see the session note)
    (centre, radius), middle = shape["nose"], np.argmin(np.abs(z))
    assert abs(np.hypot(*(points[middle] - np.asarray(centre))) - radius - g.outer_diameter / 2) < 1e-9


def test_a_half_model_of_one_element_is_refused_with_the_reason():
    import pytest

    from matid.rod.bend import BendGeometry, BendModel

    geometry = BendGeometry(span=0.01, specimen_length=0.03, support_radius=0.002, nose_radius=0.003,
                            outer_diameter=2.4e-3)  # fmt: skip
    with pytest.raises(ValueError, match=r"^the bend half model needs at least 2 elements$"):
        BendModel(geometry, elements=1)
