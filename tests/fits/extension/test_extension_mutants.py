"""The extension fit's summary against hand-made records, for what the mutation sample
(benchmarks/mutation.sh, seed 29) showed no other test sees."""

from __future__ import annotations

import numpy as np
import pytest

from matid.fits.extension.fit import fit_extension
from tests.fits.extension.test_viscoelastic import ETA, K1, K2, TAU, measurement, ode_force, piecewise, ramps


def test_the_time_window_is_the_finest_sampling_step_and_the_longest_run() -> None:
    """Three ramps of 400 evenly spaced samples over 10 tau, tau and tau/10: the window the data
    resolve runs from the fastest ramp's step (tau/10/399) to the slowest ramp's length (10 tau)."""
    fit = fit_extension(ramps([10 * TAU, TAU, 0.1 * TAU], np.random.default_rng(11)), specimen="T1")
    assert np.allclose(fit.info["time_window_s"], [0.1 * TAU / 399, 10 * TAU], rtol=1e-9, atol=0)


def test_two_rates_part_relaxation_from_an_elastic_curve() -> None:
    """Two ramps of a linear solid at rates 4:3 apart (force from the ODE of the SLS, not from
    matid): each bends as it relaxes, but a second rate tells relaxation from an elastic curve, so
    E_e keeps its own narrow interval around K1 and no nonlinearity is reported."""
    rng = np.random.default_rng(5)
    runs = []
    for i, duration in enumerate([3 * TAU, 4 * TAU]):
        knots_t, knots_eps = np.array([0.0, duration]), np.array([0.0, 0.05])
        t, eps = piecewise(knots_t, knots_eps, 400)
        force = ode_force(knots_t, knots_eps, t, K1, K2, ETA)
        runs.append(measurement(f"r{i}.csv", t, eps, force + rng.normal(0, 0.002 * force.max(), t.size)))
    e_e = fit_extension(runs, specimen="T1").estimate("E_e")
    assert not any("not linear in strain" in w for w in e_e.warnings), e_e.warnings
    low, high = e_e.ci95
    assert low < K1 < high and high - low < 0.02 * K1, e_e.ci95


def test_each_runs_noise_is_its_residual_deviation_with_its_share_of_the_dof() -> None:
    """Two short ramps (20 rows each, 3 parameters fitted jointly on 40 rows): each run's noise is
    sqrt(RSS_run / (m_run (1 - 3/40))), its residuals against the fitted model read off the fit's
    plot data (the unbiased variance, the 3 parameters shared pro rata; 7.5 % above RSS/m here)."""
    runs = ramps([10 * TAU, 0.3 * TAU], np.random.default_rng(4), n=20, noise=0.01)
    fit = fit_extension(runs, specimen="T1")
    curves = fit.info["plot_data"]["force_time"]
    used = [np.asarray(c["used"], bool) for c in curves.values()]
    total = sum(int(u.sum()) for u in used)
    assert total == 40
    for (name, c), u in zip(curves.items(), used, strict=True):
        r = (np.asarray(c["force_N"]) - np.asarray(c["model_N"]))[u]
        expected = np.sqrt(r @ r / (r.size * (1.0 - 3 / total)))
        assert fit.info["noise_N"][name] == pytest.approx(expected, rel=1e-4)


def test_a_slow_unloading_that_never_pushes_keeps_all_its_rows() -> None:
    """Loading and unloading over 100 tau each (force from the SLS ODE, not from matid): at zero
    strain the relaxing part is only -k2 tau rate = -0.015 N, within the noise, so the strip never
    pushes; the rows near zero force at the end (first taken for slack) are all fitted again."""
    rng = np.random.default_rng(8)
    knots_t, knots_eps = np.array([0.0, 100 * TAU, 200 * TAU]), np.array([0.0, 0.05, 0.0])
    t, eps = piecewise(knots_t, knots_eps, 200)
    force = ode_force(knots_t, knots_eps, t, K1, K2, ETA)
    slow = measurement("slow.csv", t, eps, force + rng.normal(0, 0.003 * force.max(), t.size))
    fit = fit_extension([slow, *ramps([10 * TAU, TAU, 0.1 * TAU], rng)], specimen="T1")
    assert fit.series[0].used.all()
    assert "slow.csv" not in fit.info["left_out"]


def test_the_plotted_bin_means_are_the_means_of_the_used_rows_of_each_bin() -> None:
    """Reduction.means (what a long record's plot draws): each bin's plain mean, by hand here."""
    from matid.fits.extension.reduce import Reduction

    used = np.ones(12, dtype=bool)
    used[[0, 5]] = False  # rows not used are in no bin
    starts = np.array([0, 1, 4])  # bins of the used rows: [0], [1, 2, 3], [4 .. 9]
    values = np.arange(12.0) ** 2
    kept = values[used]
    want = [kept[0], kept[1:4].mean(), kept[4:].mean()]
    assert Reduction(used, starts).means(values) == pytest.approx(want, rel=1e-15)


def test_the_preferred_prony_estimates_carry_their_interval_method_and_the_slow_arm_warning() -> None:
    """Two arms (tau 0.5 s and 30 s) fitted on runs of at most 500 s: told the longest run was 5 s,
    the 30 s arm is slower than 5 x 5 s, and only prony_k0 warns of it; every interval is t-log."""
    from matid.fits.extension import prony
    from tests.fits.extension.test_prony import data

    rng = np.random.default_rng(3)
    choice = prony.choose(data(lambda t, e: prony.prony_force(t, e, 50.0, [30.0, 40.0], [0.5, 30.0]), rng))
    estimates = prony.preferred(choice, sls_k1=61.0, longest_run=5.0)[0]
    by_name = {e.parameter: e for e in estimates}
    (warning,) = by_name["prony_k0"].warnings
    assert "tau = 30" in warning and "longer than 5x the longest run (5 s)" in warning
    assert all(e.warnings == () for name, e in by_name.items() if name != "prony_k0")
    assert all(e.extra["ci_method"] == "t-log" and e.ci95 is not None for e in estimates)


def test_a_run_with_too_few_used_rows_does_not_hide_the_cycles_of_the_next() -> None:
    """checks.cycled asks whether *some* run unloads or holds: a run left with two used rows (after
    its slack rows are dropped, lsq._slack keeps no minimum) says nothing, the next one still counts."""
    from types import SimpleNamespace

    from matid.fits.extension.checks import cycled

    def run(eps, force):
        eps, force = np.asarray(eps, float), np.asarray(force, float)
        return SimpleNamespace(eps=eps, force=force, used=np.ones(eps.size, bool))

    up = np.linspace(0.0, 0.05, 20)
    eps = np.concatenate([up, up[::-1][1:]])  # a load and an unload of equal length
    unloading = run(eps, 40.0 * eps + 0.2 * np.sin(30 * eps))
    short = run([0.0, 0.01], [0.0, 0.4])
    assert cycled([unloading])
    assert cycled([short, unloading])


def _e_e(t, eps, force):
    from tests.fits.extension.test_no_relaxation import measurement

    return fit_extension([measurement(t, eps, force)], specimen="T1").estimate("E_e")


def _ramp(force_of):
    """A ramp at 2e-5 /s over 20 s, force_of(t, eps) plus noise of 5 N."""
    t = np.arange(0.0, 20.0, 0.02)
    eps = 2e-5 * t
    return t, eps, force_of(t, eps) + np.random.default_rng(7).normal(0.0, 5.0, t.size)


def test_a_single_elastic_ramp_that_stiffens_widens_its_line_s_e_e_over_the_tangents() -> None:
    """A ramp of F = K eps (1 + eps / 2 eps_max), no relaxation: E_e is the ramp's line, and the
    tangent K (1 + eps / eps_max) runs from K to 2 K: the warning names the force's own tangent and
    the interval spans the tangents at the 2nd and 98th percentile of strain."""
    K = 1.1e7
    t, eps, force = _ramp(lambda t, e: K * e * (1.0 + 0.5 * e / 4e-4))
    e_e = _e_e(t, eps, force)
    assert e_e.method == "ramp-line"
    assert any(
        "the force is not linear in strain" in w and "the force's own tangent" in w for w in e_e.warnings
    )
    lo, hi = np.percentile(eps, [2.0, 98.0])
    assert e_e.ci95[0] <= 1.01 * K * (1 + lo / 4e-4) and e_e.ci95[1] >= 0.99 * K * (1 + hi / 4e-4), e_e.ci95


def test_an_elastic_line_that_stiffens_is_judged_on_the_force_less_its_dashpot_and_drift() -> None:
    """The cycles of test_no_relaxation with F = tare + K eps (1 + 0.3 eps / eps_max): E_e is the
    elastic line, and the warning says what its tangent is the tangent of."""
    from tests.fits.extension.test_no_relaxation import EPS_MAX, F_TARE, wavematrix_strain

    K = 1.13e7
    t, eps = wavematrix_strain()
    force = F_TARE * (eps > 0) + K * eps * (1 + 0.3 * eps / EPS_MAX)
    e_e = _e_e(t, eps, force + np.random.default_rng(1).normal(0.0, 28.0, t.size))
    assert e_e.method == "elastic-line"
    (warning,) = [w for w in e_e.warnings if "the force is not linear in strain" in w]
    assert "the force less the line's dashpot and drift is" in warning


def test_a_single_ramp_of_a_relaxing_solid_is_checked_on_its_own_tangent_too() -> None:
    """A ramp of a standard linear solid (k1 1.1e7 N, k2 5e6 N, tau 2 s over 20 s): the SLS gives
    E_e = k1, and the force's own tangent falls from k1 + k2 to k1, which a single ramp cannot
    tell from an elastic curve: the warning says so."""
    k1, k2, tau, rate = 1.1e7, 5e6, 2.0, 2e-5
    t, eps, force = _ramp(lambda t, e: k1 * e + k2 * rate * tau * (1.0 - np.exp(-t / tau)))
    e_e = _e_e(t, eps, force)
    assert e_e.method == "sls" and e_e.value == pytest.approx(k1, rel=0.01)
    assert any(
        "a single ramp at one rate cannot tell relaxation from an elastic curve" in w for w in e_e.warnings
    )


@pytest.mark.parametrize(("fixed", "free"), [("sls_k2", "sls_eta"), ("sls_eta", "sls_k2")])
def test_with_one_of_k2_and_eta_fixed_the_other_is_still_judged(fixed: str, free: str) -> None:
    """One ramp 1000 tau long (an SLS of tau 10 s): its relaxation is over within the first 0.1 %
    of the ramp, so whichever of k2 and eta is left free is not determined by it (its relative
    standard error above 50 %), though the other is given."""
    runs = ramps([1000 * TAU], np.random.default_rng(3), noise=0.01)
    fit = fit_extension(runs, specimen="T1", fixed={fixed: {"sls_k2": K2, "sls_eta": ETA}[fixed]})
    (why,) = [w for w in fit.estimate(free).warnings if "not identifiable" in w]
    assert f"{free} relative standard error above 50%" in why
    assert fit.estimate(fixed).method == "fixed"


def test_a_relaxation_slower_than_the_runs_tells_the_reader_what_e_e_includes_and_what_to_add() -> None:
    """Ramps of 0.1 s and 0.2 s of an SLS of tau 10 s: no relaxation within them, and E_e's
    warning says it is the stiffness on that time scale and what would confirm it."""
    fit = fit_extension(ramps([0.1, 0.2], np.random.default_rng(3), noise=0.01), specimen="T1")
    (caution,) = [w for w in fit.estimate("E_e").warnings if w.startswith("no relaxation is resolved")]
    assert "E_e is the stiffness on that time scale and includes any slower-relaxing part" in caution
    assert caution.endswith("add a slower run or a hold to confirm it")


def test_the_end_of_hold_warning_states_the_hold_s_length_to_a_sample() -> None:
    """A ramp to strain 0.5 at 0.1 /s (it arrives at 5.0 s), held to 9.9 s, sampled every 0.1 s:
    E_e = 10 N lies above force / strain at the end, and the warning says after how long a hold,
    4.9 s, to the sample interval (the hold began between the last row that moved and the next)."""
    import re

    from matid.fits.extension.checks import end_of_hold
    from matid.fits.extension.runs import _run
    from tests.fits.extension.test_no_relaxation import measurement as strain_measurement
    from tests.fits.extension.test_reduced_misfit import power_law_record

    t, eps, force = power_law_record(100, 0.1)
    run = _run(strain_measurement(t, eps, force + np.random.default_rng(3).normal(0.0, 0.002, t.size)))
    warning, _ = end_of_hold([run], 10.0, 0.01)
    after = float(re.search(r"after ([0-9.]+) s", warning).group(1))
    assert abs(after - 4.9) <= 0.1 + 1e-9, warning


def test_the_end_of_hold_warning_states_the_fall_per_decade_of_a_logarithmic_relaxation() -> None:
    """A ramp to 0.01 in 1 s, then a hold to 101 s whose force / strain is A - beta ln(s), s the
    time since the hold began: it falls by beta ln 10 per decade of time, as the warning says."""
    import re

    from matid.fits.extension.checks import end_of_hold
    from matid.fits.extension.runs import _run
    from tests.fits.extension.test_no_relaxation import measurement as strain_measurement

    A, beta, eps0, dt = 100.0, 4.0, 0.01, 0.1
    t = np.arange(0.0, 101.0 + dt / 2, dt)
    eps = np.minimum(t, 1.0) * eps0
    s = np.maximum(t - 1.0, dt)
    force = np.where(t < 1.0, A * eps, eps0 * (A - beta * np.log(s)))
    run = _run(strain_measurement(t, eps, force + np.random.default_rng(2).normal(0.0, 1e-4, t.size)))
    warning, _ = end_of_hold([run], 1e3, 0.01)
    fall = float(re.search(r"still falls by ([0-9.]+) N per decade", warning).group(1))
    assert fall == pytest.approx(beta * np.log(10.0), rel=0.01), warning


def _line_plus_square(q: float, seed: int):
    """200 rows of strain 0 to 1e-3 and force 1e4 eps + q u^2 + noise of 0.05 N (u: strain scaled
    to 0..1 between its 2nd and 98th percentiles); the t-statistics of a cubic's u^2 and u^3 terms
    by numpy.polyfit's covariance."""
    from types import SimpleNamespace

    eps = np.linspace(0.0, 1e-3, 200)
    lo, hi = np.percentile(eps, [2.0, 98.0])
    u = (eps - lo) / (hi - lo)
    force = 1e4 * eps + q * u**2 + np.random.default_rng(seed).normal(0.0, 0.05, eps.size)
    coef, cov = np.polyfit(u, force, 3, cov=True)
    t = np.abs(coef[:2]) / np.sqrt(np.diag(cov)[:2])  # cubic, square
    run = SimpleNamespace(eps=eps, force=force, used=np.ones(eps.size, bool), t=np.arange(eps.size) * 1.0)
    return run, t, lo


@pytest.mark.parametrize(("q", "significant"), [(0.3, False), (1.0, True)])
def test_the_tangents_differ_only_where_a_curvature_term_is_three_of_its_own_standard_errors(q, significant):
    """checks.nonlinear judges the u^2 and u^3 terms each by its own standard error: a square term
    of 2.6 (the cubic 1.4) of them is no finding, one of 3 or more is, and the warning gives the
    tangents at the 2nd and 98th percentile of strain."""
    from matid.fits.extension.checks import nonlinear

    run, t, lo = _line_plus_square(q, seed=13)
    found = nonlinear([run], [np.zeros(run.eps.size)], 1e4)
    assert (found is not None) == significant == bool(np.any(t > 3.0)), t
    if significant:
        assert f"at strain {lo:.3g} and" in found[0]


def test_a_long_hold_is_fitted_on_log_spaced_bins() -> None:
    """A ramp of 10 s and a hold to 2000 s sampled every 0.1 s (20 001 rows): the residuals are bin
    means on a logarithmic time axis after each kink (module docstring of reduce): about
    ln(1 + span / w0) / ln(1 + c) bins per stretch (w0 = dt / c), a few hundred, not a row each."""
    from matid.fits.extension import reduce

    dt, c = 0.1, reduce.GROWTH
    t = np.arange(20001) * dt
    eps = 0.05 * np.minimum(t / 10.0, 1.0)
    red = reduce.reduction(t, eps, np.ones(t.size, bool), 0.005)
    w0 = dt / c
    expected = sum(np.log1p(span / w0) / np.log1p(c) for span in (10.0, 1990.0))
    assert abs(red.size - expected) < 10, (red.size, expected)
    means = red.means(t)
    assert np.all(np.diff(means) > 0)  # bins in time order, none crossing another


def test_an_sls_fit_the_optimiser_did_not_finish_is_refused(monkeypatch) -> None:
    """When lmfit reports no success (its evaluations ran out) the fit says it did not converge,
    though the residuals it stopped at are finite numbers."""
    import lmfit

    from matid.errors import FitError

    minimize = lmfit.Minimizer.minimize

    def unfinished(self, *args, **kwargs):
        result = minimize(self, *args, **kwargs)
        result.success, result.message = False, "too many function evaluations (the test's stand-in)"
        return result

    monkeypatch.setattr(lmfit.Minimizer, "minimize", unfinished)
    with pytest.raises(FitError, match="did not converge: too many function evaluations"):
        fit_extension(ramps([TAU, 3 * TAU], np.random.default_rng(2)), specimen="T1")


def _prony_data(seed: int, noise: float = 0.02, arms: tuple = ([30.0], [5.0])):
    from matid.fits.extension import prony
    from tests.fits.extension.test_prony import data

    return data(lambda t, e: prony.prony_force(t, e, 50.0, *arms), np.random.default_rng(seed), noise=noise)


def test_the_prony_errors_do_not_depend_on_the_order_of_the_runs() -> None:
    """Runs are a set: the same three runs in reverse order give the same standard errors (the
    AR(1) sandwich's noise correlation does not run across from one run into the next). Two arms
    (tau 0.5 s and 30 s): the one-arm fit misses them, and its residuals run in long stretches."""
    from matid.fits.extension import prony

    runs = _prony_data(1, arms=([30.0, 40.0], [0.5, 30.0]))
    for n, fit in prony.choose(runs).fits.items():
        again = prony.choose(runs[::-1]).fits[n].stderr()
        for name, se in fit.stderr().items():
            assert again[name] == pytest.approx(se, rel=1e-6), (n, name)


def test_runs_ten_times_noisier_do_not_widen_the_prony_errors() -> None:
    """Three runs at noise 0.02 N, then the same three shapes at 0.2 N added (each run weighted
    by its own noise): they carry 1/100 of the weight, so the errors shrink a little, never grow."""
    from matid.fits.extension import prony

    quiet = _prony_data(2)
    alone = prony.choose(quiet).fits[1].stderr()
    both = prony.choose(quiet + _prony_data(4, noise=0.2)).fits[1].stderr()
    for name, se in alone.items():
        assert both[name] <= 1.001 * se, (name, both[name], se)


def _table_run(columns: dict, window: dict | None = None):
    """An extension Measurement of hand-made columns (SI), as ingest would deliver it."""
    from pathlib import Path

    from matid.model import study
    from matid.model.measurement import Measurement, Table

    test = study.Test("extension", "T1", Path("r.csv"), {"gauge_length": 0.05}, window=window or {})
    return Measurement(test, Table(Path("r.csv"), columns, {}, {}, ""))


def _ramp_columns(n: int = 20) -> dict:
    t = np.arange(n, dtype=float)
    return {"time": t, "strain": 1e-3 * t, "force": 2.0 * t + 0.1 * np.sin(t)}


@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        ({"force": None}, "DataError", "extension test needs a 'force' column"),
        ({"force": np.r_[0.0, np.nan, np.arange(2.0, 20.0)]}, "DataError", "must be finite in every row"),
        (
            {"time": np.arange(3.0), "strain": [0.0, 1e-3, 2e-3], "force": [0.0, 1.0, 2.0]},
            "FitError",
            "only 3 samples",
        ),
    ],
)
def test_a_run_that_cannot_be_fitted_says_why(change: dict, error: str, message: str) -> None:
    """Runs refused by extension.runs, each with its reason: a column missing, a NaN force (with
    finite time and strain), three samples."""
    from matid import errors
    from matid.fits.extension.runs import _run

    columns = {k: v for k, v in {**_ramp_columns(), **change}.items() if v is not None}
    columns = {k: np.asarray(v, float) for k, v in columns.items()}
    with pytest.raises(getattr(errors, error), match=message):
        _run(_table_run(columns))


def test_a_window_with_too_few_rows_says_how_many_it_holds() -> None:
    from matid.errors import DataError
    from matid.fits.extension.runs import _run

    with pytest.raises(DataError, match="only 3 rows inside the window; a fit needs 5"):
        _run(_table_run(_ramp_columns(), window={"strain": (0.0, 2e-3)}))


def test_a_record_of_five_rows_whose_time_repeats_is_refused_for_its_time() -> None:
    """Times 0, 1, 1, 2 and a last row 0, 0, 0: not a test stage's end-of-test row (time did not
    increase strictly before it), so the record keeps five rows and is refused where time repeats."""
    from matid.errors import DataError
    from matid.fits.extension.runs import _run

    columns = {
        "time": [0.0, 1.0, 1.0, 2.0, 0.0],
        "strain": [1e-3, 2e-3, 3e-3, 4e-3, 0.0],
        "force": [1.0, 2, 3, 4, 0],
    }
    with pytest.raises(DataError, match="time must increase strictly"):
        _run(_table_run({k: np.asarray(v, float) for k, v in columns.items()}))


def test_a_noise_free_ramp_keeps_every_row() -> None:
    """A ramp whose force is exactly linear (0.5 N per s, 100 rows): its second differences, the
    noise estimate, are 0, and no row is near zero force but the first ones, so none is left out
    as slack."""
    from matid.fits.extension.runs import _run

    t = np.arange(100.0)
    run = _run(_table_run({"time": t, "strain": 1e-4 * t, "force": 0.5 * t}))
    assert run.left_out == {} and int(run.used.sum()) == 100
