"""Solution.terms names the precurvature when only a segment has one (RodSystem._labels passes the
per-point precurvature to term_labels; the mutation run's survivor system._labels__mutmut_4)."""

import numpy as np

from matid.rod.api import solve
from matid.rod.scenes import scene_from_dict

ROD = {"length": 0.03, "E_b": 9e-5, "E_t": 9e-5, "E_s": 1e4, "E_e": 1e4}


def test_a_precurved_segment_is_listed_among_the_terms():
    bent = solve(
        scene_from_dict({"rod": ROD, "segment": [{"from": 0.0, "to": 0.01, "precurvature": [0, 50.0, 0]}]})
    )
    straight = solve(scene_from_dict({"rod": ROD, "segment": [{"from": 0.0, "to": 0.01, "E_b": 1e-4}]}))
    assert "precurvature" in bent.terms and "precurvature" not in straight.terms
    # and it ran: the unloaded tip is turned by 50 1/m x 10 mm = 0.5 rad about the plane normal
    assert np.isclose(np.arctan2(bent.d3[-1][0], bent.d3[-1][2]), 0.5, atol=1e-6)
