"""The fitting stack without lmfit and scipy.stats: distribution functions from scipy.special,
the SLS covariance and profile-likelihood interval checked against independent computations,
and the import of matid.app.pipeline kept free of lmfit, scipy.stats and pandas."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest
from scipy import optimize, signal, stats

from matid.fits import stats as mstats
from matid.fits.extension.lsq import _LOG_BOUND, _ORDER, _least_squares, _residual, _solve
from matid.fits.extension.profile import jacobian, profile_limits, uncertainty
from matid.fits.extension.runs import _run, _unique
from tests.fits.extension.test_viscoelastic import TAU, ramps

X = [-1.0, -1e-12, 0.0, 1e-8, 0.01, 0.3, 1.0, 2.5, 7.0, 30.0, 300.0, np.inf, np.nan]
DOF = [0.0, 0.5, 1.0, 2.0, 3.7, 10.0, 123.0, 1e5, np.inf]
Q = [1e-9, 0.025, 0.3, 0.5, 0.9, 0.95, 0.975, 0.999999]


def _same(a: float, b: float) -> bool:
    return (np.isnan(a) and np.isnan(b)) or a == pytest.approx(b, rel=1e-12, abs=1e-300)


@pytest.mark.parametrize("dof", DOF)
def test_chi2_and_t_match_scipy_stats(dof):
    for x in X:
        if not (np.isinf(x) and np.isinf(dof)):  # chi2 with infinite dof: never asked for
            assert _same(mstats.chi2_sf(x, dof), float(stats.chi2.sf(x, dof))), (x, dof)
    for q in Q:
        assert _same(mstats.t_ppf(q, dof), float(stats.t.ppf(q, dof))), (q, dof)


@pytest.mark.parametrize("dfn", [0.0, 1.0, 2.0, 3.5, 40.0])
@pytest.mark.parametrize("dfd", DOF[:-1])  # finite dfd: every caller's is
def test_f_matches_scipy_stats(dfn, dfd):
    for x in X:
        assert _same(mstats.f_sf(x, dfn, dfd), float(stats.f.sf(x, dfn, dfd))), (x, dfn, dfd)
        assert _same(mstats.f_cdf(x, dfn, dfd), float(stats.f.cdf(x, dfn, dfd))), (x, dfn, dfd)


def test_norm_cdf_matches_scipy_stats():
    for x in [-40.0, -8.0, -1.96, -0.1, 0.0, 0.4, 3.0, 40.0, np.inf, -np.inf, np.nan]:
        assert _same(mstats.norm_cdf(x), float(stats.norm.cdf(x))), x


@pytest.mark.parametrize("rho", [0.0, 0.3, 0.95, mstats.RHO_MAX])
def test_ar1_filter_is_lfilter(rho):
    block = np.random.default_rng(3).normal(size=(500, 3))
    expected = signal.lfilter([1.0], [1.0, -rho], block, axis=0)
    np.testing.assert_allclose(mstats._ar1_filter(block, rho), expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(mstats._ar1_filter(block[:, 0], rho), expected[:, 0], rtol=1e-12, atol=1e-12)


def test_import_of_the_pipeline_leaves_out_lmfit_scipy_stats_and_pandas():
    heavy = ["lmfit", "scipy.stats", "pandas"]
    code = (
        "import sys, json, matid.app.pipeline; "
        f"print(json.dumps([m for m in {heavy!r} if m in sys.modules]))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == []


@pytest.fixture(scope="module")
def sls_fit():
    runs = _unique([_run(m) for m in ramps([10 * TAU, TAU, 0.1 * TAU], np.random.default_rng(7))])
    runs, result, ref, sigma = _solve(runs, {})
    return runs, result, ref, sigma


def test_covariance_is_inverse_normal_matrix_times_reduced_chi2(sls_fit):
    runs, result, ref, sigma = sls_fit
    jac = jacobian(result, runs, sigma, ref)
    expected = np.linalg.inv(jac.T @ jac) * result.chisqr / result.nfree
    np.testing.assert_allclose(result.covar, expected, rtol=1e-4)
    unc = uncertainty(result)
    assert unc.errorbars
    se = np.sqrt(np.diag(expected))
    assert unc.stderr["k2"] == pytest.approx(se[1], rel=1e-4)
    assert unc.correl["k2"]["eta"] == pytest.approx(expected[1, 2] / (se[1] * se[2]), abs=1e-4)


def test_profile_limits_are_where_the_f_test_reaches_95_percent(sls_fit):
    """At each limit the others, refitted by a different optimiser (trust region), give
    chi2 / chi2_best - 1 = F_0.95(1, nfree) / nfree."""
    runs, result, ref, sigma = sls_fit
    limits = profile_limits(result, uncertainty(result), ["k2", "eta"], runs, sigma, ref)
    target = float(stats.f.ppf(0.95, 1, result.nfree)) / result.nfree
    for name, (low, high) in limits.items():
        i = ("k1", "k2", "eta").index(name)
        assert low < result.x[i] < high
        for value in (low, high):
            others = [j for j in range(3) if j != i]

            def fun(v, value=value, i=i, others=others):
                x = result.x.copy()
                x[i], x[others] = value, v
                return _residual(x, runs, sigma, ref)

            sol = optimize.least_squares(fun, result.x[others], method="trf", xtol=1e-14, ftol=1e-14)
            ratio = 2 * sol.cost / result.chisqr - 1.0
            assert ratio == pytest.approx(target, rel=1e-3), (name, value)


@pytest.mark.parametrize("budget", [5, 40, None])
def test_least_squares_keeps_lmfits_evaluation_budget_and_messages(sls_fit, budget):
    """lmfit's leastsq (the fit this replaces) evaluated the residuals at most max_nfev =
    2000 (nvarys + 1) times, then stopped the fit as failed, with its own messages."""
    lmfit = pytest.importorskip("lmfit")
    runs, _, ref, sigma = sls_fit
    x0 = np.array([0.3, -0.4, 0.5])  # away from the optimum: more than 5 evaluations

    calls = []

    def residual(params):
        x = np.array([params[name].value for name in _ORDER])
        calls.append(x)
        return _residual(x, runs, sigma, ref)

    params = lmfit.Parameters()
    for name, value in zip(_ORDER, x0, strict=True):
        params.add(name, value=value, min=-_LOG_BOUND, max=_LOG_BOUND)
    theirs = lmfit.Minimizer(residual, params, nan_policy="raise").minimize(method="leastsq", max_nfev=budget)
    ours = _least_squares(x0, _ORDER, runs, sigma, ref, **({} if budget is None else {"budget": budget}))
    assert (ours.success, ours.message) == (theirs.success, theirs.message)
    assert (ours.covar is None) == (theirs.covar is None)
    if theirs.success:
        np.testing.assert_array_equal(ours.x, [theirs.params[name].value for name in _ORDER])
    else:  # stopped where it was about to evaluate: lmfit reads that point from freed memory
        assert theirs.aborted and len(calls) == budget + 3


@pytest.mark.parametrize("offset", [5e-7, 3e-6])
def test_jacobian_at_a_bound_is_lmfits(sls_fit, offset):
    """The sandwich's Jacobian was taken on lmfit Parameters bounded at +-18, which clip a
    step past the bound: a log-parameter that ends within a step of it (k1 -> 0) keeps those
    numbers."""
    lmfit = pytest.importorskip("lmfit")
    runs, result, ref, sigma = sls_fit
    x = result.x.copy()
    x[0] = -_LOG_BOUND + offset
    fit = dataclasses.replace(result, x=x)
    params = lmfit.Parameters()
    for name, value in zip(_ORDER, x, strict=True):
        params.add(name, value=value, min=-_LOG_BOUND, max=_LOG_BOUND)
    columns = []
    for name in fit.free:  # as matid did with lmfit (74c4d56, extension_stats._sandwich)
        up, down = params.copy(), params.copy()
        up[name].value += 1e-6
        down[name].value -= 1e-6
        at = [np.array([p[n].value for n in _ORDER]) for p in (up, down)]
        columns.append((_residual(at[0], runs, sigma, ref) - _residual(at[1], runs, sigma, ref)) / 2e-6)
    np.testing.assert_array_equal(jacobian(fit, runs, sigma, ref), np.column_stack(columns))
