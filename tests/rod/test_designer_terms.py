"""The new closed-form terms (off-axis magnetisation, per-segment precurvature) against the jets,
and the new scene keys' validation."""

from __future__ import annotations

import numpy as np
import pytest

from matid.errors import DataError
from matid.rod.fem import Discretisation, graded_vertices
from matid.rod.models import FULL, ScaledRod, Segment
from matid.rod.scenes import scene_from_dict
from matid.rod.system import RodSystem
from matid.rod.terms import Magnetisation

ROD = ScaledRod(
    E_t=0.7,
    E_s=50.0,
    E_e=80.0,
    segments=(Segment(0.6, 1.0, 1.0, 0.7, 50.0, 80.0, kappa_ref=(0.3, -1.1, 0.4)),),
    kappa_ref=(0.1, 0.2, 0.0),
)
LOADS = (Magnetisation((0.3, -0.5, 0.8), (), ((0.2, 0.9, 1.5, (0.6, 0.0, 0.8)),)),)


def test_directed_magnetisation_and_segment_precurvature_match_the_jets() -> None:
    disc = Discretisation(graded_vertices(1.0, 6), 7, element="P2", intorder=2)
    closed, jets = (RodSystem(disc, ROD, LOADS, model=FULL, analytic=a) for a in (True, False))
    rng = np.random.default_rng(3)
    U = closed.reference() + 0.05 * rng.standard_normal(disc.n)
    X = closed.reduce(U)
    R1, K1 = closed.evaluate(X, 0.7)
    R2, K2 = jets.evaluate(X, 0.7)
    assert np.max(np.abs(R1 - R2)) < 1e-11 * max(1.0, np.max(np.abs(R2)))
    assert abs(K1.tocsr() - K2.tocsr()).max() < 1e-10 * max(1.0, abs(K2.tocsr()).max())


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"magnet": [{"at": "30 mm", "moment": "1 A m^2", "direction": [0, 0, 0]}]}, "not zero"),
        ({"magnet": [{"at": "30 mm", "moment": "1 A m^2", "direction": ["1 m", 0, 0]}]}, "plain numbers"),
        ({"point_load": [{"at": "40 mm", "force": ["1 N", "0 N", "0 N"]}]}, "not on the rod"),
        ({"point_load": [{"at": "10 mm"}]}, "a force, a moment"),
        ({"aim": {"tip_direction": [1, 0, 0], "field_magnitude": "1 T"}}, "needs a magnet"),
    ],
)
def test_bad_designer_keys_are_named(table: dict, message: str) -> None:
    raw = {"rod": {"length": "30 mm", "E_b": 1e-4, "E_t": 1e-4, "E_s": 10, "E_e": 10}, **table}
    with pytest.raises(DataError, match=message):
        scene_from_dict(raw)
