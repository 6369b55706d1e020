"""Shared fit statistics: noise, runs, AR(1) covariance and its coverage, lack of fit."""

from __future__ import annotations

import numpy as np
import pytest

from matid.fits import stats as st
from matid.fits.stats import ar1_noise


def line_fit(x, y):
    J = np.column_stack([x, np.ones_like(x)])
    coef, *_ = np.linalg.lstsq(J, y, rcond=None)
    return J, coef, y - J @ coef


def test_difference_noise_sees_noise_not_smooth_signal():
    rng = np.random.default_rng(0)
    x = np.linspace(0.0, 1.0, 2000)
    y = np.sin(6 * x) * 50 + np.where(x > 0.5, x - 0.5, 0.0) * 30 + rng.normal(0.0, 0.2, x.size)
    assert st.difference_noise(y) == pytest.approx(0.2, rel=0.05)
    # two segments: the jump between them is not a difference
    assert st.difference_noise(np.r_[y, y + 1e3], segments=[2000, 2000]) == pytest.approx(0.2, rel=0.05)
    quantised = np.round(np.linspace(0, 1, 100), 1)  # MAD of d2 is 0
    assert st.difference_noise(quantised) > 0
    with pytest.raises(ValueError, match="add up"):
        st.difference_noise(y, segments=[10, 10])


def test_lag1_and_runs_tell_iid_from_systematic():
    rng = np.random.default_rng(1)
    iid = rng.normal(size=500)
    assert abs(st.lag1(iid)) < 4 / np.sqrt(500)  # 4 sd of lag1 under i.i.d.
    assert st.runs(iid)[2] > 0.01
    assert st.lag1(ar1_noise(rng, 2000, 0.9)) == pytest.approx(0.9, abs=0.03)
    wave = np.sin(np.linspace(0, 6 * np.pi, 300)) + 0.1 * rng.normal(size=300)
    observed, expected, p = st.runs(wave)
    assert observed < 0.2 * expected and p < 1e-10


def test_iid_covariance_is_the_textbook_one():
    rng = np.random.default_rng(2)
    x = np.linspace(0.0, 1.0, 300)
    J, coef, r = line_fit(x, 3 * x + rng.normal(0.0, 0.1, x.size))
    cov = st.ar1_covariance(J, r)
    textbook = np.sum(r**2) / (300 - 2) * np.linalg.inv(J.T @ J)
    assert cov.rho == 0.0 and cov.dof == 298
    assert np.allclose(cov.cov, textbook)
    assert np.allclose(cov.inflation, 1.0)


def test_ar1_apply_equals_the_dense_matrix():
    rng = np.random.default_rng(3)
    M = rng.normal(size=(30, 2))
    rho = 0.7
    i = np.arange(20)
    R = rho ** np.abs(i[:, None] - i[None, :])
    dense = np.r_[R @ M[:20], rho ** np.abs(np.arange(10)[:, None] - np.arange(10)) @ M[20:]]
    assert np.allclose(st._ar1_apply(M, rho, st._bounds(30, [20, 10])), dense)


@pytest.mark.parametrize("phi, low, high", [(0.0, 90, 98), (0.95, 85, 100)])
def test_line_slope_interval_coverage(phi, low, high):
    """95 % intervals of a slope with intercept, 400 points, 100 seeded trials."""
    hits, n = 0, 400
    x = np.linspace(0.0, 1.0, n)
    for seed in range(100):
        rng = np.random.default_rng(seed)
        noise = ar1_noise(rng, n, phi) if phi else rng.normal(size=n)
        J, coef, r = line_fit(x, 2.0 * x + 0.3 + 0.01 * noise)
        cov = st.ar1_covariance(J, r)
        lo, hi = st.interval(coef[0], cov.stderr[0], cov.dof)
        hits += lo < 2.0 < hi
    assert low <= hits <= high


def test_effective_n():
    rng = np.random.default_rng(4)
    assert st.effective_n(rng.normal(size=400)) == 400
    n_eff = st.effective_n(ar1_noise(rng, 4000, 0.9))
    assert 4000 * 0.1 / 1.9 * 0.7 < n_eff < 4000 * 0.1 / 1.9 * 1.3


def test_lack_of_fit_flags_a_curve_fitted_by_a_line_only():
    rng = np.random.default_rng(5)
    x = np.linspace(0.0, 1.0, 200)
    _, _, r = line_fit(x, x + rng.normal(0.0, 0.01, x.size))
    good = st.lack_of_fit(r, 2)
    assert not good.misfit and good.warning("the line") is None
    assert good.reduced_chi2 == pytest.approx(1.0, abs=0.3)
    _, _, r = line_fit(x, x + 0.2 * x**2 + rng.normal(0.0, 0.01, x.size))
    bad = st.lack_of_fit(r, 2)
    assert bad.misfit and bad.reduced_chi2 > 5
    text = bad.warning("the line", inflation=3.0, advice="Narrow the window.")
    assert text.startswith("the line does not describe the data") and "widened 3.0x" in text
    assert text.endswith("Narrow the window.")
    assert set(bad.as_info()) >= {"reduced_chi2", "noise", "lag1_autocorrelation", "misfit"}
    few = st.lack_of_fit(r[:8], 2)
    assert not few.decided and not few.misfit


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.8, 0.97])
def test_mean_variance_factor_is_the_variance_of_a_block_mean(rho):
    """Against the dense AR(1) correlation matrix: Var(mean of m) = sd^2 / m * factor."""
    for m in (1, 2, 7, 60):
        i = np.arange(m)
        dense = float(np.sum(rho ** np.abs(i[:, None] - i[None, :]))) / m**2
        assert st.mean_variance_factor(np.array([m]), rho)[0] / m == pytest.approx(dense, rel=1e-12)


def test_lag1_test_flags_a_short_misfit_the_runs_test_misses():
    """30 rows of a smooth misfit: reduced chi2 above 2 and neighbours alike (lag-1 p < 1e-3), while the
    runs test, which sees only signs, stays above 1e-3 (the demo's T2 bend: runs p 0.0014, r 0.69)."""
    rng = np.random.default_rng(2)
    x = np.linspace(0.0, 1.0, 30)
    r = 0.5 * np.sin(2 * np.pi * 1.6 * x) + 0.3 * rng.standard_normal(30)
    lof = st.lack_of_fit(r, 2)
    assert lof.reduced_chi2 > st.MISFIT_CHI2 and lof.runs_p > st.MISFIT_RUNS_P
    assert lof.lag1_p < st.MISFIT_LAG1_P
    assert lof.misfit and lof.as_info()["misfit"] is True
    assert lof.warning("the line") is not None


def test_lag1_p_holds_its_false_alarm_rate_on_short_independent_records():
    """Under independence the lag-1 test at 1e-3 alarms at most at its nominal rate (30 rows, 20 000
    records), and at about 5 % for p < 0.05: the normal law is a fair approximation at this length."""
    rng = np.random.default_rng(1)
    p = np.array([st.lag1_p(st.lag1(rng.standard_normal(30)), 30) for _ in range(20_000)])
    assert np.mean(p < 1e-3) <= 1e-3
    assert 0.03 < np.mean(p < 0.05) < 0.06


def test_runs_are_counted_within_each_segment():
    """Signs + - - | - + + (two files): 2 runs in each, 4 in all, expected 1 + 2 n+ n- / n = 7/3
    per file; read as one sequence they would be 3 runs."""
    r = np.array([1.0, -1.0, -1.0, -1.0, 1.0, 1.0])
    observed, expected, _ = st.runs(r, [3, 3])
    assert observed == 4 and expected == pytest.approx(2 * 7 / 3)
    assert st.runs(r)[0] == 3


def test_runs_p_is_wald_wolfowitz_with_a_continuity_correction():
    """n+ = n- = 10 in 2 blocks: mean 11, variance 2 n+ n- (2 n+ n- - n) / (n^2 (n - 1)) = 180/38,
    p = Phi((2 - 11 + 0.5) / sqrt(var)) (the textbook normal approximation, its + 0.5 included)."""
    import math

    import scipy.stats

    r = np.r_[np.ones(10), -np.ones(10)]
    observed, expected, p = st.runs(r)
    var = 2 * 10 * 10 * (2 * 10 * 10 - 20) / (20 * 20 * 19)
    assert (observed, expected) == (2, 11.0)
    assert p == pytest.approx(scipy.stats.norm.cdf((2 - 11 + 0.5) / math.sqrt(var)), rel=1e-12)


def test_as_many_points_as_parameters_give_no_errors():
    with pytest.raises(ValueError, match="cannot give errors"):
        st.ar1_covariance(np.column_stack([np.arange(2.0), np.ones(2)]), np.array([0.1, -0.1]))


def test_a_misfit_warning_says_by_how_much_the_interval_was_widened():
    x = np.linspace(0.0, 1.0, 200)
    curve = (x**2 - np.polyval(np.polyfit(x, x**2, 1), x)) + 1e-4 * np.random.default_rng(0).normal(size=200)
    lof = st.lack_of_fit(curve, 2)
    assert lof.misfit
    assert "; the interval is widened 1.5x for it" in lof.warning("the line", 1.5)
    assert "widened" not in lof.warning("the line", 1.04)
