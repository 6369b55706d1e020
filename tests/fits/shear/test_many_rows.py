"""E_s from a long bend record: the bend solved on knots, interpolated to the rows (issue 19.7).

The 3000-row record comes from the rod model on a finer mesh than the fit uses
(48 P2 elements, every row solved by continuation: no interpolation; the centreline
record from ``matid.example.forward.bend_centreline``, the shooting model), with seeded
noise of 0.3 % of the largest force as in :mod:`tests.fits.shear.test_fit`. The fit
solves 16-32 elements on a few knots.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from matid.errors import FitError
from matid.example.forward import bend_centreline
from matid.fits.shear import fit as shear
from matid.fits.shear import problem as shear_problem
from matid.fits.shear.problem import Problem, interpolate, least_squares, refine, start_knots
from matid.rod.bend import BendGeometry, BendModel
from tests.fits.shear.test_fit import (
    E_B,
    E_E,
    E_S,
    NOISE,
    OUTER,
    ROLLERS,
    SPECIMEN,
    fit_rod,
    known,
    rig,
    rod_curve,
)
from tests.fits.shear.test_fit import measurement as nose_measurement
from tests.fits.shear.test_tube import bend

ROWS = 3000
SPAN = 0.010


@pytest.fixture(scope="module")
def record():
    """3000 rows to 10 % of the span (48 elements), noise seed 31; and its 30 evenly spread rows."""
    d = np.linspace(0.0, 0.1 * SPAN, ROWS)
    geometry = BendGeometry(SPAN, 0.03, ROLLERS, ROLLERS, OUTER)
    force = BendModel(geometry, elements=48).solve(E_B, E_S, E_E, d).force
    F = force + np.random.default_rng(31).normal(0.0, NOISE * force.max(), ROWS)
    few = np.round(np.linspace(0, ROWS - 1, 30)).astype(int)
    return d, F, few


def fitted(d, F, *, every_row=False, elements=16):
    """(problem, x) of the nose-travel fit at a fixed mesh, the knots refined as the fit does
    (``every_row``: each distinct row a knot, the per-row solve)."""
    data = [shear.bend_data(nose_measurement(d, F, rig(SPAN)), SPECIMEN, E_B)]
    knots = [np.unique(b.d, return_index=True)[1] for b in data] if every_row else None
    problem = Problem(data, E_B, E_E, fit_E_b=False, elements=elements, knots=knots)
    x = least_squares(problem, np.log([shear.timoshenko_start(data, E_B)]))
    while problem.refine(x):
        x = least_squares(problem, x)
    return problem, x


def test_3000_rows_give_E_s_of_30_rows_and_the_truth(record):
    """Same values within their standard errors; the long record's is ~10x smaller (sqrt(100)).

    Measured over seeds 31-40: (E_3000 - E_S) / se_3000 from -1.44 to 1.12, (E_3000 - E_30) /
    hypot(se_3000, se_30) from -2.26 to 0.94, se_30 / se_3000 from 8.5 to 12.4.
    """
    d, F, few = record
    many = fit_rod([nose_measurement(d, F, rig(SPAN))], specimen=SPECIMEN, known=known())
    some = fit_rod([nose_measurement(d[few], F[few], rig(SPAN))], specimen=SPECIMEN, known=known())
    e, e30 = many.estimate("E_s"), some.estimate("E_s")
    assert e.n_points > 0.99 * ROWS and e30.n_points >= 29  # the cut may drop rows of the toe
    assert abs(e.value - E_S) < 2 * e.stderr
    assert abs(e.value - e30.value) < 3 * np.hypot(e.stderr, e30.stderr)
    assert 5 < e30.stderr / e.stderr < 20
    assert e.ci95[0] < E_S < e.ci95[1]
    (interp,) = many.info["fe"]["interpolation"]
    assert interp["knots"] < 100 and interp["error_N"] <= interp["tolerance_N"]
    (every,) = some.info["fe"]["interpolation"]
    assert every["knots"] == every["rows"] and every["error_N"] == 0.0  # 30 rows: each one solved


def test_interpolation_error_is_below_the_noise(record):
    """At the fitted E_s, every 10th row (~19 per knot interval) solved by continuation against
    the interpolated force."""
    d, F, _ = record
    problem, x = fitted(d, F)
    (b,) = problem.data
    rows = np.arange(0, b.d.size, 10)
    exact = BendModel(b.geometry, elements=16).solve(E_B, float(np.exp(x[0])), E_E, b.d[rows])
    error = np.max(np.abs(problem.force[0][rows] - exact.force))
    sigma = shear_problem.difference_noise(b.F)
    assert sigma == pytest.approx(NOISE * F.max(), rel=0.1)
    assert error <= np.max(problem.error[0]) <= problem.tolerance[0]  # the estimate bounds it
    assert error < 1e-3 * sigma
    assert problem.knots[0].size < 100


def test_interpolated_fit_matches_the_fit_solving_every_row(record):
    """The same 300 rows fitted both ways: E_s within 1 % of its standard error, and the cost in
    Newton iterations a fraction of the per-row solve's."""
    d, F, _ = record
    rows = np.arange(0, ROWS, 10)
    fast, x = fitted(d[rows], F[rows])
    slow, x_every = fitted(d[rows], F[rows], every_row=True)
    r, J = fast.evaluate(x)
    sd_log = np.sqrt(float(r @ r) / (r.size - 1) / float(J[:, 0] @ J[:, 0]))
    assert abs(x[0] - x_every[0]) < 0.01 * sd_log
    assert slow.knots[0].size == slow.data[0].d.size and fast.knots[0].size < 100
    assert fast.newton_iterations < 0.25 * slow.newton_iterations


def test_jacobian_of_the_interpolated_residual():
    """The Jacobian (splines of dF/dE_s at the knots) against central differences of the residual
    (Hermite interpolation of F): both O(h^4), so they agree to the interpolation's accuracy."""
    d, force = rod_curve(SPAN, n=400)
    F = force + np.random.default_rng(7).normal(0.0, NOISE * force.max(), d.size)
    data = [shear.bend_data(nose_measurement(d, F, rig(SPAN)), SPECIMEN, E_B)]
    problem = Problem(data, E_B, E_E, fit_E_b=False, elements=16)
    x = np.log([23.0])
    _, J = problem.evaluate(x)
    assert problem.knots[0].size < 100
    h = 1e-4
    fd = (problem.evaluate(x + h)[0] - problem.evaluate(x - h)[0]) / (2 * h)
    assert np.max(np.abs(fd - J[:, 0])) < 1e-4 * np.max(np.abs(J[:, 0]))


def test_refine_at_the_solution_meets_a_tighter_tolerance():
    """Knots chosen at one x, the tolerance then cut 1000-fold: refine adds knots (and drops the
    kept evaluations) until the estimated error at x is below it again."""
    d, force = rod_curve(SPAN, n=400)
    F = force + np.random.default_rng(8).normal(0.0, NOISE * force.max(), d.size)
    data = [shear.bend_data(nose_measurement(d, F, rig(SPAN)), SPECIMEN, E_B)]
    problem = Problem(data, E_B, E_E, fit_E_b=False, elements=16)
    x = np.log([E_S])
    problem.evaluate(np.log([30.0]))
    before = problem.knots[0].copy()
    assert np.max(problem.error[0]) <= problem.tolerance[0]
    problem.tolerance[0] *= 1e-3
    rounds = 0
    while problem.refine(x):
        rounds += 1
        assert len(problem.evaluations) == 0
    assert rounds >= 1 and set(before) < set(problem.knots[0])
    problem.evaluate(x)
    assert np.max(problem.error[0]) <= problem.tolerance[0]
    assert not problem.refine(x)


def test_centreline_record():
    """1000 rows of centreline deflection (knots in the measured coordinate, dF/dc = dF/dn / dc/dn)."""
    n = np.linspace(0.0, 0.05 * SPAN, 1000)
    c, force = bend_centreline(n, E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=OUTER, **rig(SPAN))
    F = force + np.random.default_rng(32).normal(0.0, NOISE * force.max(), n.size)
    fit = fit_rod([bend(c, F, SPAN, at="centreline", length=0.03)], specimen=SPECIMEN, known=known())
    e = fit.estimate("E_s")
    assert fit.info["measurement"] == "centreline deflection"
    assert abs(e.value - E_S) < 2 * e.stderr
    (interp,) = fit.info["fe"]["interpolation"]
    assert interp["knots"] < 100 and interp["error_N"] <= interp["tolerance_N"]


# --------------------------------------------------------------------------- the knots and the interpolant


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(0, 400), min_size=3, max_size=300),
    st.floats(1e-3, 1e3),
)
@example(steps=[0] * 10, scale=1.0)  # one distinct row
def test_knots_are_distinct_rows_spanning_the_record(steps, scale):
    q = scale * np.cumsum(steps) / 400.0  # non-decreasing, repeated values allowed
    knots = start_knots(q)
    distinct = np.unique(q)
    assert np.all(np.diff(q[knots]) > 0)
    assert q[knots[0]] == distinct[0] and q[knots[-1]] == distinct[-1]
    if distinct.size <= 2 * shear_problem.START_KNOTS - 1:
        assert knots.size == distinct.size  # every distinct row
    else:
        assert knots.size <= shear_problem.START_KNOTS
    error = np.where(np.arange(q.size) % 7 == 3, 1.0, 0.0)
    finer = refine(q, knots, error, 0.5)
    if distinct.size == 1:
        assert finer is None
    if finer is not None:
        assert np.all(np.diff(q[finer]) > 0) and set(knots) < set(finer)
        failing = {int(np.searchsorted(q[knots], q[i], side="right")) - 1 for i in np.nonzero(error > 0.5)[0]}
        for new in set(finer) - set(knots):
            j = int(np.searchsorted(q[knots], q[new])) - 1
            assert j in failing and q[knots[j]] < q[new] < q[knots[j + 1]]


def test_interpolant_reproduces_cubics_and_bounds_its_error():
    """Hermite and not-a-knot splines are exact on cubics (estimate 0); on sin, the Hermite error
    is below h^4/384 max|F''''| and below the estimate."""
    qk = np.array([0.0, 0.3, 0.5, 1.1, 1.6, 2.0])
    q = np.linspace(0.0, 2.0, 201)
    cubic = lambda t: 1.0 - 2.0 * t + 0.5 * t**2 + 0.7 * t**3  # noqa: E731
    slope = lambda t: -2.0 + t + 2.1 * t**2  # noqa: E731
    force, rows, error = interpolate(qk, cubic(qk), slope(qk), {"E_s": 3.0 * cubic(qk)}, q)
    assert np.max(np.abs(force - cubic(q))) < 1e-13 and np.max(error) < 1e-13
    assert np.max(np.abs(rows["E_s"] - 3.0 * cubic(q))) < 1e-12
    k = np.linspace(0.0, 2.0, 9)
    force, rows, error = interpolate(k, np.sin(k), np.cos(k), {"E_s": np.sin(k)}, q)
    bound = (k[1] - k[0]) ** 4 / 384.0
    assert np.max(np.abs(force - np.sin(q))) <= bound
    assert np.max(np.abs(force - np.sin(q))) <= np.max(error)
    on = np.isin(q, k)
    assert np.array_equal(force[on], np.sin(q[on])) and np.all(error[on] == 0.0)


# --------------------------------------------------------------------------- parameter conventions


def test_fixed_E_b_is_held_and_fixed_E_s_leaves_nothing_to_fit():
    """[[fixed]] values as the lmfit fits treat vary=False parameters."""
    d, force = rod_curve(SPAN)
    m = nose_measurement(d, force * (1.0 + 1e-3 * np.sin(np.arange(d.size))), rig(SPAN))
    held = fit_rod([m], specimen=SPECIMEN, known=known(), fixed={"E_b": E_B}, fit_E_b=True)
    alone = fit_rod([m], specimen=SPECIMEN, known=known())
    assert [e.parameter for e in held.estimates] == ["E_s"]  # one span: fit_E_b alone would fail
    assert held.estimate("E_s").value == alone.estimate("E_s").value
    with pytest.raises(FitError, match="E_s is fixed"):
        fit_rod([m], specimen=SPECIMEN, known=known(), fixed={"E_s": E_S})
