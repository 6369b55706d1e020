"""n-term Prony (generalised Maxwell) solid: model, fit, choice against the SLS by BIC."""

from __future__ import annotations

import numpy as np
import pytest

from matid.fits.extension import prony
from matid.physics.sls import sls_force


def history(duration: float, n: int = 300):
    """Ramp to 5 % strain in duration / 10, then hold to duration."""
    t = np.linspace(0.0, duration, n)
    return t, 0.05 * np.minimum(t / (0.1 * duration), 1.0)


def data(force_fn, rng, durations=(5.0, 50.0, 500.0), noise=0.02):
    out = []
    for duration in durations:
        t, eps = history(duration)
        force = force_fn(t, eps) + rng.normal(0.0, noise, t.size)
        out.append(prony.Data(t, eps, force, np.ones(t.size, dtype=bool), noise))
    return out


def test_prony_force_superposes_arms():
    t, eps = history(100.0)
    two = prony.prony_force(t, eps, 10.0, [20.0, 5.0], [2.0, 40.0])
    parts = sls_force(t, eps, 10.0, 20.0, 40.0) + sls_force(t, eps, 0.0, 5.0, 200.0)
    assert np.allclose(two, parts)
    # the hold relaxes to k0 eps once every arm has decayed
    long_t, long_eps = history(1e5, 3000)
    assert prony.prony_force(long_t, long_eps, 10.0, [20.0, 5.0], [2.0, 40.0])[-1] == pytest.approx(
        0.5, rel=1e-6
    )


def test_two_arms_are_recovered_and_preferred():
    rng = np.random.default_rng(1)
    choice = prony.choose(data(lambda t, e: prony.prony_force(t, e, 50.0, [30.0, 40.0], [0.5, 30.0]), rng))
    assert choice.best == 2 and choice.delta_bic > 100
    fit = choice.fits[2]
    values, se = fit.values(), fit.stderr()
    truth = {"prony_k0": 50.0, "prony_k1": 30.0, "prony_tau1": 0.5, "prony_k2": 40.0, "prony_tau2": 30.0}
    for name, value in truth.items():
        assert values[name] == pytest.approx(value, rel=0.05), name
        assert abs(values[name] - value) < 4 * se[name], name
    assert set(choice.table()) >= {"1 arm", "2 arms"}


def test_an_sls_is_not_given_extra_arms():
    rng = np.random.default_rng(2)
    choice = prony.choose(data(lambda t, e: prony.prony_force(t, e, 50.0, [30.0], [5.0]), rng))
    assert choice.best == 1
    fit = choice.fits[1]
    assert fit.k0 == pytest.approx(50.0, rel=0.01) and fit.taus[0] == pytest.approx(5.0, rel=0.05)


def test_preferred_model_reports_named_estimates_with_warnings():
    rng = np.random.default_rng(3)
    choice = prony.choose(data(lambda t, e: prony.prony_force(t, e, 50.0, [30.0, 40.0], [0.5, 30.0]), rng))
    estimates, e_e, sls = prony.preferred(choice, sls_k1=61.0, longest_run=500.0)
    assert [e.parameter for e in estimates] == [
        "prony_k0",
        "prony_k1",
        "prony_tau1",
        "prony_k2",
        "prony_tau2",
    ]
    assert all(e.method == "prony" and e.ci95[0] < e.value < e.ci95[1] for e in estimates)
    assert "2-arm Prony" in e_e and "61 N" in e_e and "prony_k0 = " in e_e
    assert sls.startswith("the standard linear solid does not describe these runs")
