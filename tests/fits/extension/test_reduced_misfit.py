"""A long relaxation whose law no Prony series of few arms follows (issue 28 item 6): the fit on
bin means gives the fit on every row within its standard error.

The record relaxes as a power law, G(t) = G_inf + c (1 + t / t0)^-m (a Nutting-type solid, as
elastomers such as VHB4910 relax: still falling at the end of the hold), under a ramp and a
hold; the force is the closed-form Boltzmann integral written below, not matid's SLS or Prony
code. Every model matid tries misses part of this record, so its residuals run in long
stretches: bins weighted by an AR(1) model of those residuals (correlation ~1) counted each bin
as one row and moved E_e by many standard errors.
"""

from __future__ import annotations

import numpy as np
import pytest

from matid.app.pipeline import run_study
from matid.fits.extension import reduce
from matid.io.study import load_study
from tests.fits.extension.relaxation import write_bluehill

G_INF, C, T0, M = 0.5, 1.5, 0.5, 0.3  # N, N, s, 1
RATE, STRAIN, GAUGE = 0.1, 0.5, 0.08  # 1/s, 1, m
NOISE = 0.002  # N


def power_law_record(n: int, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, strain, force): F(t) = RATE [H(t) - H(t - min(t, t1))], H(u) = int_0^u G."""
    t = np.arange(n) * dt
    t1 = STRAIN / RATE

    def h(u):
        return G_INF * u + C * T0 / (1.0 - M) * ((1.0 + u / T0) ** (1.0 - M) - 1.0)

    force = RATE * (h(t) - h(t - np.minimum(t, t1)))
    return t, np.minimum(RATE * t, STRAIN), force


def _fit(folder, monkeypatch, reduce_above):
    monkeypatch.setattr(reduce, "REDUCE_ABOVE", reduce_above)
    folder.mkdir()
    t, eps, force = power_law_record(8000, 0.1)
    force = force + np.random.default_rng(3).normal(0.0, NOISE, t.size)
    write_bluehill(folder / "relax.csv", t, eps * GAUGE, force)
    (folder / "study.toml").write_text(
        '[study]\nname = "power-law relaxation"\n\n[[specimen]]\nid = "R1"\nwidth = "10 mm"\n'
        'height = "1 mm"\n\n[[test]]\nkind = "extension"\nspecimen = "R1"\nfile = "relax.csv"\n'
        'gauge_length = "80 mm"\ncolumns = { time = "Time", elongation = "Extension", force = "Load" }\n',
        encoding="utf-8",
    )
    (fit,) = run_study(load_study(folder / "study.toml")).fits
    return {e.parameter: e for e in fit.estimates}, fit.info["model_choice"]["arms_preferred"]


def test_bin_means_give_the_full_records_values_when_the_model_misses_the_record(tmp_path, monkeypatch):
    full, arms_full = _fit(tmp_path / "full", monkeypatch, 10**9)
    binned, arms_binned = _fit(tmp_path / "binned", monkeypatch, 1000)
    assert arms_binned == arms_full
    for name in ("E_e", "sls_k1"):
        assert binned[name].n_points == full[name].n_points == 8000
        assert abs(binned[name].value - full[name].value) < full[name].stderr, name
        assert binned[name].stderr == pytest.approx(full[name].stderr, rel=0.1), name


def test_e_e_interval_reaches_below_the_end_of_a_hold_that_still_relaxes(tmp_path):
    """The equilibrium stiffness is at most force / strain at the end of the hold. With the
    relaxation time held at 20 s ([[fixed]] from another test) the SLS puts k1 between the
    mid-hold and the end: E_e must say that it lies above the end of the hold and widen its
    interval to below it (the noise-only interval excluded every value the record allows)."""
    t, eps, force = power_law_record(8000, 0.1)
    noisy = force + np.random.default_rng(3).normal(0.0, NOISE, t.size)
    write_bluehill(tmp_path / "relax.csv", t, eps * GAUGE, noisy)
    (tmp_path / "study.toml").write_text(
        '[study]\nname = "power-law relaxation"\n\n[[specimen]]\nid = "R1"\nwidth = "10 mm"\n'
        'height = "1 mm"\n\n[[test]]\nkind = "extension"\nspecimen = "R1"\nfile = "relax.csv"\n'
        'gauge_length = "80 mm"\ncolumns = { time = "Time", elongation = "Extension", force = "Load" }\n'
        '\n[[fixed]]\nspecimen = "R1"\nparameter = "sls_k2"\nvalue = "1 N"\n'
        '\n[[fixed]]\nspecimen = "R1"\nparameter = "sls_eta"\nvalue = "20 N s"\n',
        encoding="utf-8",
    )
    (fit,) = run_study(load_study(tmp_path / "study.toml")).fits
    e_e = next(e for e in fit.estimates if e.parameter == "E_e")
    end = float(np.mean(force[-100:] / eps[-100:]))  # noise-free stiffness over the last 10 s
    assert e_e.value > end
    assert e_e.ci95[0] < end < e_e.ci95[1]
    assert any("end of its hold" in w for w in e_e.warnings)
