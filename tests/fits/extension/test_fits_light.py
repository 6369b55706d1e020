"""The SLS fit on lmfit: its covariance and profile interval checked against independent
computations, the joint Minimizer fit against an lmfit ``Model`` of the same runs, the
sandwich Jacobian at a bound, and the CLI's import kept free of lmfit, scipy.stats and pandas."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import lmfit
import numpy as np
import pytest
from scipy import optimize, stats

from matid.fits.extension.lsq import _LOG_BOUND, _ORDER, _models, _solve, _values, residual
from matid.fits.extension.runs import _run, _unique
from matid.fits.extension.stats import _profile, jacobian
from tests.fits.extension.test_viscoelastic import TAU, ramps


def test_import_of_the_cli_leaves_out_lmfit_scipy_stats_and_pandas():
    heavy = ["lmfit", "scipy.stats", "pandas", "matid.fits"]
    code = f"import sys, json, matid.app.cli; print(json.dumps([m for m in {heavy!r} if m in sys.modules]))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == []


@pytest.fixture(scope="module")
def sls_fit():
    runs = _unique([_run(m) for m in ramps([10 * TAU, TAU, 0.1 * TAU], np.random.default_rng(7))])
    return _solve(runs, {})


def _x(params: lmfit.Parameters) -> np.ndarray:
    return np.array([params[name].value for name in _ORDER])


def _residual_at(x, runs, sigma, ref) -> np.ndarray:
    """The weighted residuals at log-parameters x, written out without lmfit."""
    k = {name: ref[name] * math.exp(v) for name, v in zip(_ORDER, x, strict=True)}
    models = _models(runs, k)
    return np.concatenate([(f - r.force)[r.used] / s for f, r, s in zip(models, runs, sigma, strict=True)])


def test_covariance_is_inverse_normal_matrix_times_reduced_chi2(sls_fit):
    runs, _, result, ref, sigma = sls_fit
    h = 1e-6
    jac = np.column_stack(
        [
            (
                _residual_at(_x(result.params) + h * e, runs, sigma, ref)
                - _residual_at(_x(result.params) - h * e, runs, sigma, ref)
            )
            / (2 * h)
            for e in np.eye(3)
        ]
    )
    expected = np.linalg.inv(jac.T @ jac) * result.chisqr / result.nfree
    np.testing.assert_allclose(result.covar, expected, rtol=1e-4)
    assert result.errorbars
    se = np.sqrt(np.diag(expected))
    assert result.params["k2"].stderr == pytest.approx(se[1], rel=1e-4)
    assert result.params["k2"].correl["eta"] == pytest.approx(expected[1, 2] / (se[1] * se[2]), abs=1e-4)


def test_profile_limits_are_where_the_f_test_reaches_95_percent(sls_fit):
    """At each limit of lmfit's conf_interval the others, refitted by a different optimiser
    (trust region), give chi2 / chi2_best - 1 = F_0.95(1, nfree) / nfree."""
    runs, minimizer, result, ref, sigma = sls_fit
    limits = _profile(minimizer, result, ref, ["k2", "eta"])
    assert set(limits) == {"k2", "eta"}
    target = float(stats.f.ppf(0.95, 1, result.nfree)) / result.nfree
    best = _x(result.params)
    for name, si in limits.items():
        i = _ORDER.index(name)
        low, high = (math.log(v / ref[name]) for v in si)
        assert low < best[i] < high
        for value in (low, high):
            others = [j for j in range(3) if j != i]

            def fun(v, value=value, i=i, others=others):
                x = best.copy()
                x[i], x[others] = value, v
                return _residual_at(x, runs, sigma, ref)

            sol = optimize.least_squares(fun, best[others], method="trf", xtol=1e-14, ftol=1e-14)
            ratio = 2 * sol.cost / result.chisqr - 1.0
            assert ratio == pytest.approx(target, rel=1e-3), (name, value)


def test_joint_minimizer_fit_is_an_lmfit_model_fit_of_the_stacked_runs(sls_fit):
    """The same runs as one lmfit Model (model force on the used rows, weights 1 / sigma of
    each run) give the same values, standard errors and correlations."""
    runs, _, result, ref, sigma = sls_fit

    def force(runs, k1, k2, eta):
        k = _values(lmfit.create_params(k1=k1, k2=k2, eta=eta), ref)
        return np.concatenate([f[r.used] for f, r in zip(_models(runs, k), runs, strict=True)])

    model = lmfit.Model(force, independent_vars=["runs"])
    data = np.concatenate([r.force[r.used] for r in runs])
    weights = np.concatenate([np.full(int(r.used.sum()), 1.0 / s) for r, s in zip(runs, sigma, strict=True)])
    params = model.make_params(
        **{name: {"value": 0.0, "min": -_LOG_BOUND, "max": _LOG_BOUND} for name in _ORDER}
    )
    theirs = model.fit(data, params, runs=runs, weights=weights, coerce_farray=False)
    assert theirs.success
    for name in _ORDER:
        assert theirs.params[name].value == pytest.approx(result.params[name].value, abs=1e-6)
        assert theirs.params[name].stderr == pytest.approx(result.params[name].stderr, rel=1e-3)
    assert theirs.params["k2"].correl["eta"] == pytest.approx(result.params["k2"].correl["eta"], abs=1e-4)
    # matid's residual is (model - data) / sigma; lmfit's Model residual is the same up to its
    # sign convention, which changed after 1.3.0 (model - data there, data - model since)
    own = (theirs.best_fit - data) * weights
    np.testing.assert_allclose(own, result.residual, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(np.abs(theirs.residual), np.abs(own), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("offset", [5e-7, 3e-6])
def test_sandwich_jacobian_stops_at_the_bound(sls_fit, offset):
    """A log-parameter within a step of its bound (k1 -> 0) is differenced between the bound
    and one step inside (as the bounded lmfit Parameter clips the step): over two steps."""
    runs, _, result, ref, sigma = sls_fit
    params = result.params.copy()
    params["k1"].value = -_LOG_BOUND + offset
    x = _x(params)
    h = 1e-6
    expected = []
    for i in range(3):
        up, down = x.copy(), x.copy()
        up[i] = min(up[i] + h, _LOG_BOUND)
        down[i] = max(down[i] - h, -_LOG_BOUND)
        expected.append((_residual_at(up, runs, sigma, ref) - _residual_at(down, runs, sigma, ref)) / (2 * h))
    np.testing.assert_allclose(
        jacobian(params, runs, sigma, ref), np.column_stack(expected), rtol=1e-12, atol=1e-9
    )
    np.testing.assert_allclose(
        residual(params, runs, sigma, ref), _residual_at(x, runs, sigma, ref), rtol=1e-13
    )
