"""E_b and E_t: lines through the origin, linear-range detection (physics.md section 2)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from matid import study
from matid.errors import DataError, FitError
from matid.fits.linear import bending_torque, fit_bending, fit_torsion, linear_range, magnet_torque
from matid.ingest import Measurement, Table

E_B = 2.0e-4  # N m^2
E_T = 1.5e-4  # N m^2
MOMENT = 0.05  # A m^2


def measurement(kind: str, name: str, params: dict, **columns) -> Measurement:
    """A test and its table as ingest would deliver them (SI columns)."""
    test = study.Test(kind, "T1", Path(name), params)
    return Measurement(test, Table(Path(name), columns, {}, {}, ""))


def tip_angle(field: float, psi: float, length: float, stiffness: float = E_B) -> float:
    """Exact equilibrium theta = (m B L / E_b) sin(psi - theta) of the tip magnet."""
    c = MOMENT * field * length / stiffness
    return brentq(lambda th: th - c * np.sin(psi - th), 0.0, psi) if c > 0 else 0.0


def bending_run(length, rng, *, stiffness=E_B, n=30, angle_noise=0.002, field_noise=0.003):
    """Field swept to 30 mT at 90 and 60 degrees; measured tip angle and field carry noise."""
    field = np.tile(np.linspace(0.002, 0.03, n // 2), 2)
    psi = np.repeat(np.radians([90.0, 60.0]), n // 2)
    theta = np.array([tip_angle(b, p, length, stiffness) for b, p in zip(field, psi, strict=True)])
    return {
        "tip_angle": theta + rng.normal(0.0, angle_noise, n),
        "field": field * (1.0 + rng.normal(0.0, field_noise, n)),
        "field_angle": psi,
    }


def bending_study(rng, lengths=(0.02, 0.03, 0.05), **kwargs) -> list[Measurement]:
    return [
        measurement(
            "magnetic_bending",
            f"bend_{i}.csv",
            {"free_length": length, "magnet_moment": MOMENT},
            **bending_run(length, rng, **kwargs),
        )
        for i, length in enumerate(lengths)
    ]


# --------------------------------------------------------------------------- bending


def test_magnet_torque_balances_the_exact_circle():
    theta = tip_angle(0.02, np.pi / 2, 0.04)
    assert magnet_torque(MOMENT, 0.02, np.pi / 2, theta) == pytest.approx(E_B * theta / 0.04)


def test_bending_from_field_recovers_E_b():
    fit = fit_bending(bending_study(np.random.default_rng(1)), specimen="T1")
    est = fit.estimate("E_b")
    assert est.value == pytest.approx(E_B, rel=0.005)
    assert est.ci95[0] < E_B < est.ci95[1]
    assert est.n_points == 90 and est.method == "linear" and est.warnings == ()
    assert fit.info["free_lengths_m"] == [0.02, 0.03, 0.05]
    assert fit.info["r2"] > 0.99
    assert set(fit.info["per_length_slopes"]) == {"0.02", "0.03", "0.05"}
    for slope in fit.info["per_length_slopes"].values():
        assert slope["E_b"] == pytest.approx(E_B, rel=0.02)
    assert [s.label for s in fit.series][0] == "bend_0.csv (L = 20 mm)"
    assert np.allclose(fit.series[1].y_fit, est.value * fit.series[1].x)


def test_bending_from_torque_column():
    rng = np.random.default_rng(2)
    runs = []
    for i, length in enumerate([0.025, 0.04]):
        theta = np.linspace(0.05, 0.8, 25)
        torque = E_B * theta / length * (1.0 + rng.normal(0.0, 0.003, theta.size))
        params = {"free_length": length}  # no magnet_moment needed
        runs.append(measurement("magnetic_bending", f"t{i}.csv", params, tip_angle=theta, torque=torque))
    est = fit_bending(runs, specimen="T1").estimate("E_b")
    assert est.value == pytest.approx(E_B, rel=0.005)
    assert est.ci95[0] < E_B < est.ci95[1]


def test_bending_interval_coverage():
    """The 95 % interval holds the truth in about 95 % of repeated experiments."""
    rng = np.random.default_rng(2024)
    hits = sum(
        lo < E_B < hi
        for lo, hi in (
            fit_bending(bending_study(rng, n=12), specimen="T1").estimate("E_b").ci95 for _ in range(40)
        )
    )
    assert 34 <= hits <= 40  # 85 % .. 100 %


def test_length_dependent_slopes_are_reported_not_fatal():
    rng = np.random.default_rng(3)
    runs = bending_study(rng, lengths=(0.02,)) + bending_study(rng, lengths=(0.05,), stiffness=1.3 * E_B)
    fit = fit_bending(runs, specimen="T1")
    (warning,) = fit.estimate("E_b").warnings
    assert "disagree beyond their errors" in warning
    slopes = fit.info["per_length_slopes"]
    assert slopes["0.05"]["E_b"] / slopes["0.02"]["E_b"] == pytest.approx(1.3, rel=0.02)


def test_bending_torque_needs_moment_or_torque_column():
    m = measurement(
        "magnetic_bending",
        "nomoment.csv",
        {"free_length": 0.03},
        tip_angle=np.ones(3),
        field=np.ones(3),
        field_angle=np.ones(3),
    )
    with pytest.raises(DataError, match="nomoment.csv.*magnet_moment"):
        bending_torque(m.table, m.test)
    with pytest.raises(DataError, match="nomoment.csv"):
        fit_bending([m], specimen="T1")
    flat = measurement(
        "magnetic_bending",
        "flat.csv",
        {"free_length": 0.03},
        tip_angle=np.zeros(4),
        torque=np.ones(4),
    )
    with pytest.raises(FitError, match="x != 0"):
        fit_bending([flat], specimen="T1")


# --------------------------------------------------------------------------- torsion


def torsion_curve(x, onset, *, power=3, change=-0.2):
    """Linear E_T x up to |x| = onset, then a smooth departure reaching `change` at the end."""
    span = np.abs(x).max() - onset
    excess = np.clip(np.abs(x) - onset, 0.0, None) / span if span > 0 else np.zeros_like(x)
    return E_T * x + change * E_T * np.abs(x).max() * np.sign(x) * excess**power


@pytest.mark.parametrize(
    "power, change, late",
    [(3, -0.2, 1.7), (3, 0.2, 1.7), (2, -0.2, 1.4)],  # cubic softening/stiffening, quadratic
)
def test_linear_range_stops_near_the_onset(power, change, late):
    rng = np.random.default_rng(4)
    x = np.linspace(-150.0, 150.0, 201)  # rad/m
    onset = 60.0
    y = torsion_curve(x, onset, power=power, change=change)
    y = y + rng.normal(0.0, 0.003 * np.abs(y).max(), x.size)
    mask = linear_range(x, y)
    cutoff = np.abs(x[mask]).max()
    assert onset <= cutoff <= late * onset  # the departure must grow to the noise level first
    assert np.all(mask == (np.abs(x) <= cutoff))  # a window |x| <= cutoff, both directions
    slope = np.dot(x[mask], y[mask]) / np.dot(x[mask], x[mask])
    assert slope == pytest.approx(E_T, rel=0.01)


def test_linear_range_keeps_linear_data():
    kept = []
    for seed in range(10):
        rng = np.random.default_rng(seed)
        x = np.linspace(0.0, 100.0, 120)  # one-sided
        y = E_T * x + rng.normal(0.0, 0.01 * E_T * 100.0, x.size)
        kept.append(linear_range(x, y).mean())
    assert min(kept) >= 0.9 and np.median(kept) == 1.0


def test_linear_range_edge_cases():
    x = np.linspace(-1.0, 1.0, 5)
    assert linear_range(x, x).all()  # too few points to test: all kept
    x = np.linspace(0.0, 1.0, 40)
    y = np.where(x < 0.001, x, 10 * x**3)  # curved from the start
    assert linear_range(x, y).sum() == 6
    y[3] = np.nan
    assert not linear_range(x, y)[3]
    with pytest.raises(ValueError, match="same length"):
        linear_range(x, y[:-1])


def test_torsion_fit_over_the_linear_range():
    rng = np.random.default_rng(5)
    runs = []
    # the short tube softens beyond 1.2 rad (60 rad/m); the long one stays linear
    for name, length, change in [("short.csv", 0.02, -0.25), ("long.csv", 0.1, 0.0)]:
        phi = np.linspace(-3.0, 3.0, 121)
        torque = torsion_curve(phi / length, 1.2 / 0.02, change=change)
        torque += rng.normal(0.0, 0.003 * np.abs(torque).max(), phi.size)
        runs.append(measurement("torsion", name, {"length": length}, twist_angle=phi, torque=torque))
    fit = fit_torsion(runs, specimen="T1")
    est = fit.estimate("E_t")
    assert est.value == pytest.approx(E_T, rel=0.01)
    assert est.ci95[0] < est.value < est.ci95[1]
    short, long = fit.series
    assert not short.used.all() and long.used.all()
    assert 60.0 <= fit.info["linear_range"]["short.csv"] <= 110.0  # onset 60 rad/m
    assert fit.info["linear_range"]["long.csv"] == pytest.approx(30.0)
    assert fit.info["excluded_points"] == int((~short.used).sum()) > 0
    assert est.n_points == int(short.used.sum()) + 121
    assert est.warnings == ()  # more than half the points are linear


def test_torsion_warns_when_little_is_linear():
    rng = np.random.default_rng(6)
    phi = np.linspace(0.0, 3.0, 80)
    torque = torsion_curve(phi / 0.02, 0.3 / 0.02, change=-0.5) + rng.normal(0.0, 1e-6, phi.size)
    run = measurement("torsion", "soft.csv", {"length": 0.02}, twist_angle=phi, torque=torque)
    (warning,) = fit_torsion([run], specimen="T1").estimate("E_t").warnings
    assert warning.startswith("soft.csv: only") and "linear range" in warning


def test_torsion_stiffening_onset_and_unequal_noise_is_unbiased():
    """Regression: a stiffening short tube (quadratic onset) pooled with a long linear one of
    lower noise. The old nested-window detector admitted points past the onset and the
    unweighted pooled slope was biased by +1.0 to +1.7 % with intervals missing the truth."""
    errors, covered = [], 0
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        runs = []
        for name, length in [("short.csv", 0.02), ("long.csv", 0.08)]:
            phi = np.linspace(-np.pi, np.pi, 25)
            k = phi / length
            excess = np.clip(np.abs(k) - 70.0, 0.0, None)
            torque = E_T * (k + np.sign(k) * excess**2 / 300.0)  # stiffening beyond 70 rad/m
            torque += rng.normal(0.0, 0.005 * np.abs(torque).max(), phi.size)  # 0.5 % of own range
            runs.append(measurement("torsion", name, {"length": length}, twist_angle=phi, torque=torque))
        est = fit_torsion(runs, specimen="T1").estimate("E_t")
        errors.append(est.value / E_T - 1.0)
        covered += est.ci95[0] <= E_T <= est.ci95[1]
    assert max(abs(e) for e in errors) < 0.01
    assert abs(np.mean(errors)) < 0.003  # no systematic bias
    assert covered >= 9  # 95 % intervals: at least 9 of 12
