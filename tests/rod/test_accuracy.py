"""The discretisation error estimator brackets the true error; automatic meshing meets its tolerance."""

import numpy as np
import pytest

from matid.rod.accuracy import ROUNDOFF, refine, richardson
from matid.rod.cantilever import solve_cantilever
from matid.rod.scenes import scene_from_dict

L, EB = 0.03, 6.5e-5


def _end_moment(theta: float):
    stiff = 1e8 * EB / L**2  # scaled E_s = E_e = 1e8: the inextensible circle is the answer
    return scene_from_dict(
        {
            "rod": {"length": L, "E_b": EB, "E_t": 4e-5, "E_s": stiff, "E_e": stiff},
            "tip": {"moment": [0.0, theta * EB / L, 0.0]},
        }
    )


def _tip_error(theta: float, position: np.ndarray) -> float:
    exact = np.array([(1 - np.cos(theta)) / theta, 0.0, np.sin(theta) / theta])
    return float(np.max(np.abs(position / L - exact)))


@pytest.mark.parametrize("theta", [1.0, 3.0])
@pytest.mark.parametrize("tolerance", [1e-5, 1e-8])
def test_automatic_mesh_meets_tolerance_and_estimate_brackets_truth(theta, tolerance):
    scene = _end_moment(theta)

    def at(n):
        sol = solve_cantilever(scene, elements=n)
        return sol, sol.position[-1] / L, sol.runtime_s

    sol, est = refine(at, tolerance=tolerance)
    true = _tip_error(theta, sol.position[-1])
    assert true <= tolerance  # the mesh chosen meets the tolerance
    assert est.error <= tolerance
    # the estimate is neither optimistic nor uselessly pessimistic on the closed form
    assert 0.8 * true <= est.error <= 3.0 * true + ROUNDOFF
    assert est.history[-1][0] == est.elements


def test_fixed_mesh_reports_its_error():
    scene = _end_moment(2.0)

    def at(n):
        sol = solve_cantilever(scene, elements=n)
        return sol, sol.position[-1] / L, sol.runtime_s

    sol, est = refine(at, tolerance=1.0, fixed=6)
    assert sol.elements == 6 and est.elements == 6
    assert est.error >= 0.8 * _tip_error(2.0, sol.position[-1])


def test_richardson_order_is_capped_and_pessimistic_when_not_monotone():
    q = [np.array([1.0]), np.array([1.0 + 1e-3]), np.array([1.0 + 1e-3 + 1e-7])]
    error, order = richardson(q)  # observed order log2(1e-3/1e-7) = 13 is capped
    assert order == 4.0 and error == pytest.approx(1e-7 / 15)
    error, order = richardson([np.array([1.0]), np.array([1.1]), np.array([1.3])])  # growing
    assert order == 1.0 and error == pytest.approx(0.2)
