"""The arguments of the Python API of the rod (matid.rod.solve and the scene's dataclasses), issue 30
item 6: a wrong argument is an error naming it, never an AttributeError or IndexError from inside."""

from __future__ import annotations

import numpy as np
import pytest

from matid.errors import DataError
from matid.rod import load_scene, solve
from matid.rod.scenes import Aim, Loads, Rod
from tests import ROOT

SCENE = ROOT / "examples" / "scenes" / "tip_force.toml"
VECTORS = ("B", "distributed_force", "tip_force", "tip_moment")


def test_solve_takes_a_scene_file_path_as_load_scene_reads_it():
    """Before: ``solve("x.toml")`` raised AttributeError ('str' object has no attribute 'aim'). After:
    a path (str or Path) is read by load_scene; the solution is the one of the loaded Scene."""
    expected = solve(load_scene(SCENE), elements=4).tip["position"]
    for given in (SCENE, str(SCENE)):
        assert np.array_equal(solve(given, elements=4).tip["position"], expected)


def test_solve_refuses_what_is_neither_a_scene_nor_a_path(tmp_path):
    with pytest.raises(TypeError, match=r"scene must be a matid\.rod\.Scene or the path .* got int"):
        solve(42)
    with pytest.raises(DataError, match="scene file not found"):
        solve(tmp_path / "missing.toml")


@pytest.mark.parametrize("key", VECTORS)
@pytest.mark.parametrize("n", [0, 2, 4, 5])
def test_a_load_vector_of_the_wrong_length_names_the_key_and_the_length(key, n):
    """Before: a 2-vector tip force raised IndexError in the solve, a 5-vector was accepted (its last
    two components ignored). After: a DataError naming the key and the length expected."""
    with pytest.raises(DataError, match=rf"{key}: expected 3 components \(x, y, z\), got {n}"):
        Loads(**{key: tuple(1.0 for _ in range(n))})


def test_other_vectors_of_a_scene_are_checked_too():
    with pytest.raises(DataError, match=r"point_loads\[0\] force: expected 3 components"):
        Loads(point_loads=((0.01, (1.0, 0.0), (0.0, 0.0, 0.0)),))
    with pytest.raises(DataError, match=r"magnet_directions\[0\]: expected 3 components"):
        Loads(magnets=((0.01, 1e-3),), magnet_directions=((1.0, 0.0),))
    with pytest.raises(DataError, match=r"precurvature: expected 3 components"):
        Rod(0.05, 1e-4, 1e-4, 10.0, 100.0, precurvature=(1.0, 0.0, 0.0, 0.0, 0.0))
    with pytest.raises(DataError, match=r"tip_direction: expected 3 components"):
        Aim((1.0, 0.0), 0.01)
    with pytest.raises(DataError, match=r"tip_force: expected 3 components .* got 'abc'"):
        Loads(tip_force="abc")


def test_vectors_of_three_numbers_in_any_sequence_are_accepted():
    loads = Loads(tip_force=np.array([0.0, 0.1, 0.0]), B=[0.0, 0.0, 0.01])
    assert tuple(loads.tip_force) == (0.0, 0.1, 0.0)
