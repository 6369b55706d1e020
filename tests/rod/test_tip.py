"""Equilibrium.tip (the quantity of the error estimate, in floats) is the Solution's last row."""

import numpy as np
import pytest

from matid.bench import peers
from matid.bench import scenes as S
from matid.rod.cantilever import equilibrium
from matid.rod.scenes import scene_from_dict


def _scenes():
    scale = S.E_B / S.L**2
    rod = {"length": S.L, "E_b": S.E_B, "E_t": S.E_B, "E_s": 1e4 * scale, "E_e": 1e4 * scale}
    oblique = scene_from_dict({"rod": rod, "tip": {"force": [2.0 * scale, -3.0 * scale, 0.0]}})
    return {
        "planar, plane off the x axis": oblique,
        "planar, magnetic": peers.problems()[0]["scene"],
        "full": peers.problems()[2]["scene"],
    }


@pytest.mark.parametrize("name", sorted(_scenes()))
def test_tip_is_the_solutions_last_row(name):
    scene = _scenes()[name]
    eq = equilibrium(scene, elements=4)
    solution = eq.solution()
    expected = np.concatenate([solution.position[-1] / scene.rod.length, solution.d3[-1]])
    assert eq.model == ("full" if name == "full" else "planar")
    np.testing.assert_allclose(eq.tip(), expected, rtol=0, atol=1e-14)
