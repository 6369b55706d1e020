"""Cycles from rest of a solid with no relaxation in the record are not read as relaxation
(issue 28: two Instron WaveMatrix records of a composite coupon, E_e 4.4 % and 50 % below the
slope of every cycle).

The records have the WaveMatrix shape: trapezoidal cycles (ramp 0.8 s, hold 1 s at the peak,
ramp down, hold 1 s near 8 % of the peak strain), sampled every 12 ms, from rest. The elastic
record is written here as a line with a load-cell tare, F = F_TARE + K eps, and noise that
wanders (AR(1)); the SLS from rest has no offset and reads the tare as a relaxing arm. The
relaxing record is a true standard linear solid with tau inside each hold, written by a
time-stepping integration of its ODE here (not matid's update): the SLS must still be chosen.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from matid.fits.extension.fit import fit_extension
from matid.model import study
from matid.model.measurement import Measurement, Table

K, F_TARE, EPS_MAX, DT, NOISE = 1.13e7, -100.0, 4.1e-4, 0.012, 28.0
GAUGE = 0.025


def wavematrix_strain(cycles: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Time and strain of trapezoidal cycles from rest, sampled every DT."""
    knots_t, knots_eps, now = [0.0], [0.0], 0.0
    for _ in range(cycles):
        for duration, level in ((0.8, EPS_MAX), (1.0, EPS_MAX), (0.8, 0.08 * EPS_MAX), (1.0, 0.08 * EPS_MAX)):
            now += duration
            knots_t.append(now)
            knots_eps.append(level)
    t = np.arange(0.0, now, DT)
    return t, np.interp(t, knots_t, knots_eps)


def wandering(rng: np.random.Generator, n: int, phi: float = 0.5) -> np.ndarray:
    """AR(1) noise of standard deviation NOISE."""
    e = rng.normal(0.0, NOISE * np.sqrt(1.0 - phi**2), n)
    out = np.empty(n)
    out[0] = rng.normal(0.0, NOISE)
    for i in range(1, n):
        out[i] = phi * out[i - 1] + e[i]
    return out


def measurement(t, eps, force) -> Measurement:
    test = study.Test("extension", "T1", Path("cycles.csv"), {"gauge_length": GAUGE})
    return Measurement(
        test, Table(Path("cycles.csv"), {"time": t, "strain": eps, "force": force}, {}, {}, "")
    )


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_an_elastic_record_cycled_from_rest_is_not_read_as_relaxation(seed):
    t, eps = wavematrix_strain()
    force = F_TARE * (eps > 0) + K * eps + wandering(np.random.default_rng(seed), t.size)
    fit = fit_extension([measurement(t, eps, force)], specimen="T1")
    e_e = fit.estimate("E_e")
    assert e_e.method == "elastic-line", (e_e.method, e_e.value)  # the SLS is not chosen
    assert e_e.value == pytest.approx(K, rel=0.01)
    assert e_e.ci95[0] <= K <= e_e.ci95[1], (e_e.ci95, K)
    assert e_e.ci95[0] > 0.98 * K, e_e.ci95  # no relaxation or drift made up from the tare
    assert any("no relaxation time is resolved" in w for w in e_e.warnings)
    for name in ("sls_k2", "sls_eta"):
        assert any("not identifiable" in w for w in fit.estimate(name).warnings)


def sls_ode(t: np.ndarray, eps: np.ndarray, k1: float, k2: float, eta: float) -> np.ndarray:
    """F = k1 eps + f2, f2' = k2 eps' - (k2 / eta) f2, by an adaptive ODE solver over the
    piecewise-linear strain (the rate of the segment holding each time)."""
    rate = np.diff(eps) / np.diff(t)

    def rhs(s, f):
        i = min(int(np.searchsorted(t, s, side="right")) - 1, rate.size - 1)
        return [k2 * rate[i] - k2 / eta * f[0]]

    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], t_eval=t, method="LSODA", max_step=DT, rtol=1e-8, atol=1e-6)
    return k1 * eps + sol.y[0]


def test_a_relaxation_inside_the_holds_is_still_the_sls():
    k1, k2, tau = 0.8 * K, 0.3 * K, 0.4
    t, eps = wavematrix_strain(4)
    force = sls_ode(t, eps, k1, k2, k2 * tau) + wandering(np.random.default_rng(4), t.size)
    fit = fit_extension([measurement(t, eps, force)], specimen="T1")
    e_e = fit.estimate("E_e")
    assert e_e.method == "sls"
    assert e_e.value == pytest.approx(k1, rel=0.01)
    assert fit.estimate("sls_eta").value / fit.estimate("sls_k2").value == pytest.approx(tau, rel=0.05)
