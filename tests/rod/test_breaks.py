"""Range boundaries inside an element (issue 31): the mesh has a vertex at every segment,
magnetisation and point-load boundary, its meshes nest under doubling, and the reported
discretisation error is conservative at such boundaries, checked against the independent
shooting reference (tests/rod/reference.py, no matid code)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from matid.rod.api import solve
from matid.rod.fem import graded_vertices
from matid.rod.scenes import scene_from_dict
from tests.rod import reference

L, E_B = 0.045, 6.5e-5
ROD = {"length": L, "E_b": E_B, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0}
FIELD = {"B": [0.04 * math.sin(math.radians(120)), 0.0, 0.04 * math.cos(math.radians(120))]}


def _magnetised(a: float, b: float = 1.0) -> dict:
    return {"rod": ROD, "magnetization": [{"from": a * L, "to": b * L, "per_length": 8.0}], "field": FIELD}


def _point_load(a: float) -> dict:
    load = {"at": a * L, "force": [2e-3, 0.0, 0.0], "moment": [0.0, 0.0, 0.0]}
    return {"rod": ROD, "point_load": [load], "tip": {"force": [0.0, 0.0, -1e-3]}}


def _segment(a: float, b: float, factor: float) -> dict:
    return {
        "rod": ROD,
        "segment": [{"from": a * L, "to": b * L, "E_b": factor * E_B}],
        "tip": {"force": [3e-3, 0, 0]},
    }


#: Measured on the mesh that snapped the nearest uniform vertex of each mesh (reported / true):
#: 0.55, 0.031, 2e-14 (the tip vertex moved to 0.95 L: the magnetised piece was cut off), 1e-10
#: (the clamp moved to 0.05 L), 0.0022, 2e-8 and 8e-8; on the nested meshes 0.98 to 1.01.
CASES = {
    "distal third magnetised (the issue's 45 mm tube)": _magnetised(2 / 3),
    "magnetised [0.85, 1] L": _magnetised(0.85),
    "magnetised [0.95, 1] L": _magnetised(0.95),
    "point load at 0.05 L": _point_load(0.05),
    "point load at 0.15 L": _point_load(0.15),
    "stiff segment [0.05, 1] L": _segment(0.05, 1.0, 4.0),
    "soft segment [0.6, 0.95] L": _segment(0.6, 0.95, 0.3),
}


@pytest.mark.parametrize("name", list(CASES))
def test_the_reported_error_is_not_more_than_3x_below_the_true_error(name):
    """The issue's target: discretization_error >= true error / 3, the truth from the shooting
    reference (its own error ~1e-11 L, far below the estimates here)."""
    scene = scene_from_dict(CASES[name])
    sol, ref = solve(scene), reference.solve(scene, steps=8)
    got = np.concatenate([np.asarray(sol.tip["position"]) / L, sol.tip["d3"]])
    true = float(np.max(np.abs(got - np.concatenate([ref["position"] / L, ref["d3"]]))))
    assert sol.discretization_error >= true / 3, (sol.discretization_error, true)
    assert true <= 3 * scene.tolerance  # and the answer is as accurate as asked


breaks_ = st.lists(st.floats(0.0, 1.0, allow_nan=False), max_size=4)


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 48), breaks_)
def test_every_break_is_a_vertex_and_the_ends_stay(elements, breaks):
    v = graded_vertices(1.0, elements, breaks=tuple(breaks))
    assert v[0] == 0.0 and v[-1] == 1.0 and np.all(np.diff(v) > 0)
    assert all(np.min(np.abs(v - b)) <= 1e-9 for b in breaks)  # fem.MERGE: closer breaks are one
    assert v.size - 1 >= elements


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 24), breaks_)
def test_the_mesh_of_2n_bisects_every_element_of_the_mesh_of_n(elements, breaks):
    """Nested meshes that halve every element: Richardson's C h^p has one C on all of them."""
    coarse = graded_vertices(1.0, elements, breaks=tuple(breaks))
    fine = graded_vertices(1.0, 2 * elements, breaks=tuple(breaks))
    if elements >= 4:  # the base mesh is shared from 4 elements up (fem.BASE_ELEMENTS)
        mid = 0.5 * (coarse[1:] + coarse[:-1])
        np.testing.assert_allclose(fine, np.sort(np.concatenate([coarse, mid])), rtol=0, atol=1e-15)


def test_without_breaks_the_mesh_is_uniform():
    np.testing.assert_array_equal(graded_vertices(1.0, 20), np.linspace(0, 1, 21))
    np.testing.assert_array_equal(graded_vertices(1.0, 20, breaks=(0.0, 0.4, 1.0)), np.linspace(0, 1, 21))
