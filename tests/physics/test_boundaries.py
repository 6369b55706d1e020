"""Gaps to a lumen around a rounded polyline (matid.physics.boundaries) against closed forms written
here: the distance to a circle of the plane and to a straight line, and their finite differences."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from matid.physics.boundaries import Centreline, lumen_gap

RHO = 0.1  # lumen radius; the tube's outer radius is 0 here (the gap is then rho - d)


def _gap(points: np.ndarray, line: Centreline) -> tuple:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no division by a piece of zero length
        return lumen_gap(np.atleast_2d(points), line, RHO, np.zeros(len(np.atleast_2d(points))))


def _fd_hessian(f, r: np.ndarray, h: float = 1e-5) -> np.ndarray:
    """Central second differences of a scalar function of a point."""
    H = np.zeros((3, 3))
    E = np.eye(3) * h
    for i in range(3):
        for j in range(3):
            up, down = f(r + E[i] + E[j]) - f(r + E[i] - E[j]), f(r - E[i] + E[j]) - f(r - E[i] - E[j])
            H[i, j] = (up - down) / (4 * h * h)
    return H


def _semicircle_gap(r: np.ndarray) -> float:
    """rho minus the distance to the circle of radius 0.5 about (0.5, 0.5) in the plane z = 0."""
    w = r[:2] - 0.5
    return RHO - float(np.hypot(np.hypot(*w) - 0.5, r[2]))


def test_arcs_that_meet_exactly_make_a_smooth_u_turn() -> None:
    # two 90-degree corners of radius 0.5 on a middle leg of length 1: a semicircle, no straight piece
    # between (their tangent lengths add up to the leg to round-off, on either side of it)
    line = Centreline.rounded([(0.0, 0, 0), (1.0, 0, 0), (1.0, 1, 0), (0.0, 1, 0)], 0.5)
    for r in ([1.1, 0.5, 0.04], [1.05, 0.5, -0.03], [0.9, 0.3, 0.02], [0.95, 0.75, 0.0]):
        r = np.array(r)
        g, grad, H = _gap(r, line)
        assert g[0] == pytest.approx(_semicircle_gap(r), abs=1e-12)
        assert np.abs(H[0] - _fd_hessian(_semicircle_gap, r)).max() < 1e-4, r


def test_an_open_end_whose_leg_the_arc_takes_whole_still_continues_straight() -> None:
    # the first and last legs are exactly as long as their corner's tangent length (0.5): the vessel
    # still continues straight beyond both ends of the polyline (the lines y = 0 and y = 1)
    line = Centreline.rounded([(0.5, 0, 0), (1.0, 0, 0), (1.0, 1, 0), (0.5, 1, 0)], 0.5)
    r = np.array([[0.2, 0.03, 0.0], [-3.0, 0.98, 0.01], [0.45, -0.02, 0.0]])
    g, grad, H = _gap(r, line)
    d = np.hypot([0.03, 0.02, 0.02], [0.0, 0.01, 0.0])
    assert g == pytest.approx(RHO - d, abs=1e-12)
    assert grad[0] == pytest.approx([0.0, -1.0, 0.0], abs=1e-12)


def test_the_hessian_on_the_border_of_an_arc_and_a_straight_piece_is_one_side_s() -> None:
    # the closest point is the arc's end B exactly (u = 0 on the straight piece): the gap's second
    # derivative jumps there, and its value must be the one of the arc's side or of the line's side
    line = Centreline.rounded([(0.0, 0, 0), (1.0, 0, 0), (1.0, 1, 0)], 0.5)
    B = line.lines[1][0]  # where the arc ends and the second straight piece starts
    t = np.array([0.0, 1.0, 0.0])
    r = np.array([1.2, B[1], 0.3])
    H = _gap(r, line)[2][0]
    sides = [_gap(r + s * 1e-6 * t, line)[2][0] for s in (-1.0, 1.0)]
    assert min(np.abs(H - side).max() for side in sides) < 1e-4
    assert np.abs(sides[0] - sides[1]).max() > 0.1  # the two sides differ: the test can tell


def test_corners_that_overlap_are_refused_by_name() -> None:
    with pytest.raises(ValueError, match="corner_radius too large"):
        Centreline.rounded([(0.0, 0, 0), (1.0, 0, 0), (1.0, 0.5, 0), (0.0, 0.5, 0)], 0.5)
