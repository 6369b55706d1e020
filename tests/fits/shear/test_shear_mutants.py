"""The three-point-bend fit's rules against hand-made cases, for what the mutation sample
(benchmarks/mutation.sh, seed 29) showed no other test sees."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from matid.fits.shear.fit import _bias_explains


@pytest.mark.parametrize(
    ("widen", "ratio", "explained"),
    [
        (1.5, 0.8, True),  # the bias warned of (E_s at 0.6-0.9 of its value) spans the ratio
        (1.5, 0.5, False),  # farther than the bias: a second fact, its own warning
        (1.5, 1.2, False),  # on the other side of the bias
        (1.0, 0.8, False),  # no bias warned of: nothing explains the disagreement
    ],
)
def test_a_torsion_disagreement_is_explained_only_within_the_warned_bias(widen, ratio, explained) -> None:
    check = SimpleNamespace(widen=widen, info={"nose_bias_ratio": [0.6, 0.9]} if widen > 1 else {})
    assert _bias_explains(check, ratio) is explained


# --- one bend fit on data of the shooting model (matid.example.forward), with E_s_torsion known ---


def _torsion_fit(ratio: float, progress=None):
    """The 10 mm bend of tests/fits/shear/test_fit (shooting model, 0.3 % noise, seed 12) fitted with
    E_s_torsion at ``ratio`` x the true E_s (+-2 %)."""
    from matid.model.results import Estimate
    from tests.fits.shear.test_fit import SPECIMEN, fit_rod, known, measurement, noisy, rig, rod_curve

    d, force = rod_curve(0.010)
    data = [measurement(d, noisy(force, 12), rig(0.010))]
    held = {**known(), "E_s_torsion": Estimate("E_s", ratio * 21.0, 0.02 * ratio * 21.0, None, 0, "torsion")}
    return fit_rod(data, specimen=SPECIMEN, known=held, progress=progress)


@pytest.fixture(scope="module")
def torsion_fits():
    """The bend fitted with E_s_torsion at 3 x the true E_s and at the true E_s."""
    return {ratio: _torsion_fit(ratio) for ratio in (3.0, 1.0)}


def test_a_torsion_value_three_times_the_bend_s_is_one_warning_and_an_agreeing_one_none(torsion_fits):
    fits = torsion_fits  # ratio -> fit
    (warning,) = fits[3.0].estimate("E_s").warnings
    assert "disagree" in warning and "E_s_torsion = 63 N" in warning
    assert fits[3.0].info["torsion_check"] == warning
    assert fits[1.0].estimate("E_s").warnings == ()
    assert " agree:" in fits[1.0].info["torsion_check"]


def test_the_bend_fit_reports_its_progress_and_its_lack_of_fit():
    """Its own fit, not the module fixture's: mutmut's per-test selection counts a module fixture's
    calls for the first test that uses it only, and the seed-29 sample's progress=None and
    lack_of_fit=None mutants survived for that reason."""
    said: list[str] = []
    fit = _torsion_fit(3.0, progress=said.append)
    assert said and all(s.startswith("E_s fit at ") and " elements: E_s = " in s for s in said)
    assert set(fit.info["lack_of_fit"]) >= {"misfit"}


@pytest.mark.parametrize(("name", "source"), [("E_b", "a magnetic_bending test"), ("E_e", "extension tests")])
def test_a_missing_held_stiffness_names_the_test_that_gives_it(name, source) -> None:
    from matid.errors import FitError
    from matid.fits.shear.fit import _held

    with pytest.raises(
        FitError, match=f"E_s of specimen T1 needs {name}: add {source} or a \\[\\[fixed\\]\\]"
    ):
        _held({}, name, "T1")


def test_the_richardson_estimate_of_the_mesh_error_is_the_error_against_the_shooting_model():
    """Noise-free data of the shooting model (E_s = 21 N exactly) fitted on 8 P2 elements: the fit's
    FE error estimate (from the solve at half the elements, order 4) is within a factor 1.5 of the
    actual error of its E_s (measured: 7.9e-5 for 9.2e-5, ratio 0.86)."""
    from tests.fits.shear.test_fit import E_S, SPECIMEN, fit_rod, known, measurement, rig, rod_curve

    d, force = rod_curve(0.010)
    est = fit_rod([measurement(d, force, rig(0.010))], specimen=SPECIMEN, known=known(), elements=8).estimate(
        "E_s"
    )
    actual = abs(est.value / E_S - 1.0)
    assert est.extra["fe"]["elements"] == 8 and actual > 1e-5  # an error the estimate must see
    assert 1 / 1.5 <= est.extra["fe"]["discretization_error"] / actual <= 1.5


def test_the_coarse_forces_of_the_fe_error_are_solved_at_every_picked_row_of_a_long_curve():
    """100 rows (a line with 3 % noise: the data only set the rows and the interpolation tolerance;
    the forces of both meshes are the model's), every row a knot of the 16-element fit: fe_error's
    coarse solve (8 elements) at every third knot and the last, 34 rows, more than the
    2 START_KNOTS - 1 that a Problem left to choose its knots solves each. Its Richardson estimate
    equals the one from BendModel solved at those rows directly (the same model at the same rows:
    equal to rounding). Forces interpolated from START_KNOTS coarse knots instead moved it by
    2.7e-4 of itself (measured)."""
    import numpy as np

    from matid.fits.shear import fit as shear
    from matid.fits.shear.problem import ORDER, START_KNOTS, Problem, fe_error
    from matid.rod.bend import BendModel
    from tests.fits.shear.test_fit import E_B, E_E, E_S, SPECIMEN, measurement, rig

    d = np.linspace(0.0, 1e-3, 100)
    F = 200.0 * d + np.random.default_rng(3).normal(0.0, 0.03 * 0.2, d.size)
    data = [shear.bend_data(measurement(d, F, rig(0.010)), SPECIMEN, E_B)]
    (b,) = data
    every = np.unique(b.d, return_index=True)[1]
    problem = Problem(data, E_B, E_E, fit_E_b=False, elements=16, knots=[every])
    x = np.log([E_S])
    error, levels = fe_error(problem, x, data, E_E, False)

    picked = every[np.unique(np.r_[np.arange(0, every.size, 3), every.size - 1])]
    assert picked.size > 2 * START_KNOTS - 1  # the coarse Problem would not solve every row itself
    r, J = problem.evaluate(x)
    coarse = BendModel(b.geometry, elements=8).solve(E_B, E_S, E_E, b.d[picked]).force - b.F[picked]
    shift = np.linalg.lstsq(J[picked], (r[picked] - coarse) / (2.0**ORDER - 1.0), rcond=None)[0]
    assert error > 0 and error == pytest.approx(abs(shift[0]), rel=1e-9)
    assert [lvl["elements"] for lvl in levels] == [8, 16]
    assert levels[0]["discretization_error"] == pytest.approx(2.0**ORDER * error, rel=1e-12)


# --- the bend record's cut (matid/fits/shear/window.py) on hand-made records ---


def test_rows_past_yield_are_those_beyond_the_last_row_on_the_line():
    """A line of 100 N/m to 1 mm, then the force holds at 0.1 N (a yield plateau), 81 rows with
    1 mN noise (seed 0): the rows left out past yield are exactly those beyond the deflection the
    reason names; the row at it stays."""
    import numpy as np

    from matid.fits.shear import window

    d = np.linspace(0.0, 2e-3, 81)
    F = np.minimum(100.0 * d, 0.1) + np.random.default_rng(0).normal(0.0, 1e-3, d.size)
    cut = window.cut(d, F, np.ones(d.size, bool))
    (reason,) = [r for r in cut.reasons if r.startswith("past yield")]
    top = float(reason.split("beyond ")[1].split(" mm")[0]) * 1e-3
    assert np.isclose(d[cut.used].max(), top, rtol=1e-3)
    assert cut.reasons[reason] == int(np.sum(d[: int(np.argmax(F)) + 1] > d[cut.used].max()))


def test_the_toe_of_an_ever_stiffening_curve_is_cut_at_its_last_tangent():
    """F = exp(k d) - 1 (k = 8000 /m, 60 rows to 1 mm): a toe (the first slope a sixth of the
    median) whose slope rises 2.6x per window to the end, so the tangent is the last window's. Its
    zero lies between the zeros of the exponential's tangents at that window's ends (convexity)."""
    import numpy as np

    from matid.fits.shear import window

    k, d = 8000.0, np.linspace(0.0, 1e-3, 60)
    d0 = window.toe_offset(d, np.exp(k * d) - 1.0)
    width = max(4, d.size // 8)
    a, b = d[-width], d[-1]
    assert a - (1 - np.exp(-k * a)) / k <= d0 <= b - (1 - np.exp(-k * b)) / k


def test_an_all_zero_force_column_is_named_as_having_no_positive_value():
    import numpy as np

    from matid.errors import FitError
    from matid.fits.shear import window

    with pytest.raises(FitError, match="the force column has no positive value"):
        window.check_plausible(
            np.linspace(0, 1e-3, 10), np.zeros(10), span=0.01, E_b=6.5e-5, file=SimpleNamespace(name="z.csv")
        )


@pytest.mark.parametrize(("share", "absurd"), [(0.99, True), (1.01, False)])
def test_data_stiffer_than_half_of_pure_bending_are_refused(share, absurd):
    """The rule (window.py's docstring): an initial compliance d/F below ABSURD_COMPLIANCE_RATIO of
    the simply supported beam's S^3/(48 E_b) (closed form) is a wrong unit. Straight data at 1 %
    below that bound are refused, at 1 % above it pass."""
    import numpy as np

    from matid.errors import DataError
    from matid.fits.shear import window

    span, E_b = 0.01, 6.5e-5
    compliance = share * window.ABSURD_COMPLIANCE_RATIO * span**3 / (48.0 * E_b)
    d = np.linspace(1e-5, 1e-3, 20)
    args = (d, d / compliance)
    kwargs = {"span": span, "E_b": E_b, "file": SimpleNamespace(name="b.csv")}
    if absurd:
        with pytest.raises(DataError, match="negative shear compliance") as info:
            window.check_plausible(*args, **kwargs)
        # the data's slope F/d (1 / compliance), and what to do
        assert f"the initial slope F/d = {1 / compliance:.4g} N/m" in info.value.detail
        assert info.value.detail.endswith(": check the units of the force and deflection columns")
    else:
        window.check_plausible(*args, **kwargs)


def test_the_design_note_of_a_fit_uses_a_known_E_t():
    """With E_t known (1e-5 N m^2) the reference shear stiffness comes from torsion as well: the
    note is the design for the tube given E_t (sd 1.8 % at 6 mm), not the one from E_e alone."""
    from matid.fits.design import design, summary
    from matid.fits.shear.fit import _design_note
    from matid.model.results import Estimate
    from tests.fits.shear.test_fit import E_B, E_E, SPECIMEN, known

    held = {**known(), "E_t": Estimate("E_t", 1e-5, 0.0, None, 0, "linear")}
    with_t = summary(design(SPECIMEN, E_b=E_B, E_e=E_E, E_t=1e-5, precision=0.05), 0.05).splitlines()[-1]
    alone = summary(design(SPECIMEN, E_b=E_B, E_e=E_E, precision=0.05), 0.05).splitlines()[-1]
    assert with_t != alone
    assert _design_note(SPECIMEN, held, E_B) == "E_s to 5 %: " + with_t


def test_crosshead_scatter_below_zero_deflection_is_left_out_as_before_contact():
    """Three rows at -30, -20, -10 um with only noise (1 mN, seed 3) on the force, then a line of
    100 N/m from zero: exactly the rows below zero deflection are left out, as before contact."""
    import numpy as np

    from matid.fits.shear import window

    d = np.r_[-3e-5, -2e-5, -1e-5, np.linspace(0.0, 1e-3, 57)]
    F = np.where(d > 0, 100.0 * d, 0.0) + np.random.default_rng(3).normal(0.0, 1e-3, d.size)
    cut = window.cut(d, F, np.ones(d.size, bool))
    assert cut.d0 == 0.0
    assert np.array_equal(cut.used, d >= 0)
    assert cut.reasons == {"before contact (deflection below zero, force within the noise)": 3}


# --- the least squares (matid/fits/shear/lsq.py) on stand-in problems with closed-form minima ---


class _Stand:
    """A stand-in for :class:`matid.fits.shear.problem.Problem`: residuals and Jacobian of a
    closed-form function of the log stiffnesses, and a count of the evaluations (path solves)."""

    def __init__(self, residual, rows: int):
        from types import SimpleNamespace

        import numpy as np

        self.residual, self.evaluations = residual, 0
        self.data = [SimpleNamespace(F=np.ones(rows), d=np.ones(rows))]

    def evaluate(self, x):
        self.evaluations += 1
        return self.residual(x)


def test_a_fit_whose_errors_cannot_be_had_ends_where_scipy_finds_the_minimum():
    """One row for one stiffness (no degree of freedom left for an error): the stop on a step below
    CONVERGED_STEP standard errors cannot apply, and scipy's minimum of r = e^x - 5 is x = ln 5."""
    import numpy as np

    from matid.fits.shear.lsq import least_squares

    stand = _Stand(lambda x: (np.array([np.exp(x[0]) - 5.0]), np.array([[np.exp(x[0])]])), rows=1)
    assert least_squares(stand, np.zeros(1))[0] == pytest.approx(np.log(5.0), rel=1e-6)


def test_a_linear_residual_stops_at_the_jacobian_of_its_minimum():
    """r = a (x - 1) + c, c orthogonal to a (noise the model cannot take up): Gauss-Newton is exact, so
    the first Jacobian evaluated at the minimum stops the fit there (its step is zero, below
    CONVERGED_STEP standard errors) instead of a further solve at x + step."""
    import numpy as np

    from matid.fits.shear.lsq import CONVERGED_STEP, least_squares

    a, c = np.array([1.0, 2.0, 3.0]), 1e-3 * np.array([1.0, -2.0, 1.0])
    stand = _Stand(lambda x: (a * (x[0] - 1.0) + c, a[:, None]), rows=3)
    x = least_squares(stand, np.zeros(1))
    se = np.linalg.norm(c) / np.linalg.norm(a)  # the textbook error, sqrt(2) x its iid value
    assert x[0] == pytest.approx(1.0, abs=CONVERGED_STEP * se)
    scipy_alone = _Stand(stand.residual, rows=3)
    from scipy.optimize import least_squares as scipy_least_squares

    scipy_least_squares(
        lambda x: scipy_alone.evaluate(x)[0], np.zeros(1), jac=lambda x: scipy_alone.evaluate(x)[1],
        bounds=(-18.0, 18.0), method="trf",
    )  # fmt: skip
    assert stand.evaluations < scipy_alone.evaluations


def test_a_minimum_beyond_the_log_bound_is_refused_as_not_determined():
    """r = a (x - m) + c with m 18.5 above the start, beyond LOG_BOUND = 18: the fit ends at the bound."""
    import numpy as np

    from matid.errors import FitError
    from matid.fits.shear.lsq import LOG_BOUND, least_squares

    a, c = np.array([1.0, 2.0, 3.0]), 1e-3 * np.array([1.0, -2.0, 1.0])
    stand = _Stand(lambda x: (a * (x[0] - LOG_BOUND - 0.5) + c, a[:, None]), rows=3)
    with pytest.raises(FitError, match="ended at a bound: the bend data do not determine the stiffness"):
        least_squares(stand, np.zeros(1))


def test_a_fit_that_needs_more_than_its_evaluations_gives_up():
    """r = (x - 1)^26 on three rows from x = 10: Gauss-Newton shortens the distance by 1/26 a step
    (and the stop on small steps never applies: step / error = sqrt 2), more than MAX_EVALUATIONS
    residual evaluations; the fit gives up with a FitError after at most that many (and as many
    Jacobians)."""
    import numpy as np

    from matid.errors import FitError
    from matid.fits.shear.lsq import MAX_EVALUATIONS, least_squares

    k = 26
    stand = _Stand(
        lambda x: (np.full(3, (x[0] - 1) ** k), np.full((3, 1), k * (x[0] - 1) ** (k - 1))), rows=3
    )
    with pytest.raises(FitError, match=f"did not converge in {MAX_EVALUATIONS} evaluations"):
        least_squares(stand, np.array([10.0]))
    assert stand.evaluations <= 2 * MAX_EVALUATIONS


def test_a_solver_failure_during_the_fit_is_a_fit_error_with_the_solver_s_reason():
    import numpy as np

    from matid.errors import ConvergenceError, FitError
    from matid.fits.shear.lsq import least_squares

    def fails(x):
        raise ConvergenceError("Newton stalled", load_factor=0.5)

    with pytest.raises(FitError, match=r"the bend model did not converge during the fit: Newton stalled"):
        least_squares(_Stand(fails, rows=3), np.zeros(1))


def test_the_centreline_rate_along_a_unit_direction_is_the_closed_form_gradient_entry():
    """rate (the central-difference oracle of Centreline) along the unit vector of one free dof,
    a direction whose largest entry is exactly 1, equals that entry of the closed-form gradient
    (c is linear in the nodal x at fixed sigma), for the largest entries of the gradient."""
    import numpy as np

    from matid.fits.shear.centreline import Centreline, rate
    from matid.rod.bend import BendGeometry, BendModel
    from tests.fits.shear.test_fit import E_B, E_E, E_S, OUTER, ROLLERS

    model = BendModel(BendGeometry(0.01, 0.03, ROLLERS, ROLLERS, OUTER), elements=8)
    X = model.solve(E_B, E_S, E_E, np.array([2e-4])).states[-1]
    _, grad = Centreline(model).value_and_gradient(X)
    for k in np.argsort(-np.abs(grad[:-1]))[:2]:
        e = np.zeros(X.size)
        e[k] = 1.0
        assert rate(model, X, e) == pytest.approx(grad[k], rel=1e-6)
