"""Standard linear solid: exact responses, and the joint fit on synthetic runs (physics.md 1)."""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from matid.errors import DataError, FitError
from matid.fits.extension.fit import fit_extension
from matid.fits.extension.prony import prony_force
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.physics.sls import sls_force, sls_ramp

K1, K2, ETA = 50.0, 30.0, 300.0  # N, N, N s: tau = 10 s
TAU = ETA / K2
GAUGE = 0.05  # m


def measurement(name: str, t, eps, force, *, elongation: bool = True) -> Measurement:
    """An extension run as ingest would deliver it (SI columns)."""
    test = study.Test("extension", "T1", Path(name), {"gauge_length": GAUGE})
    columns = {"time": t, "force": force}
    columns.update({"elongation": eps * GAUGE} if elongation else {"strain": eps})
    return Measurement(test, Table(Path(name), columns, {}, {}, ""))


def ramps(durations, rng, *, k=(K1, K2, ETA), noise=0.003, n=400, eps_max=0.05, prefix="ramp"):
    """Constant-rate ramps to eps_max, noise as a fraction of each run's peak force."""
    runs = []
    for i, duration in enumerate(durations):
        t = np.linspace(0.0, duration, n)
        eps = eps_max * t / duration
        force = sls_ramp(t, eps_max / duration, *k)
        force += rng.normal(0.0, noise * force.max(), n)
        runs.append(measurement(f"{prefix}{i}.csv", t, eps, force, elongation=i % 2 == 0))
    return runs


def piecewise(knots_t, knots_eps, n_per_segment=50):
    """Samples of a piecewise-linear history, including every knot."""
    t = np.concatenate(
        [np.linspace(a, b, n_per_segment, endpoint=False) for a, b in pairwise(knots_t)]
        + [np.array([knots_t[-1]])]
    )
    return t, np.interp(t, knots_t, knots_eps)


def ode_force(knots_t, knots_eps, t, k1, k2, eta):
    """Independent reference: f2' = k2 eps' - (k2/eta) f2 integrated segment by segment."""
    f2, out = 0.0, np.zeros_like(t)
    for (a, b), (ea, eb) in zip(pairwise(knots_t), pairwise(knots_eps), strict=True):
        inside = (t >= a) & (t <= b)
        sol = solve_ivp(
            lambda _, f, rate: k2 * rate - k2 / eta * f,
            (a, b),
            [f2],
            args=((eb - ea) / (b - a),),
            t_eval=t[inside],
            method="DOP853",
            rtol=1e-10,
            atol=1e-14,
        )
        out[inside] = sol.y[0]
        f2 = sol.y[0, -1]
    return k1 * np.interp(t, knots_t, knots_eps) + out


# --------------------------------------------------------------------------- model


@pytest.mark.parametrize("tau", [1e-4, 0.05, 1.0, 10.0, 1e5])
def test_sls_force_matches_ramp_closed_form(tau):
    rng = np.random.default_rng(1)
    t = np.r_[0.0, np.sort(rng.uniform(0.0, 20.0, 2000))]  # irregular sampling
    rate = 2e-3
    exact = sls_ramp(t, rate, K1, K2, K2 * tau)
    got = sls_force(t, rate * t, K1, K2, K2 * tau)
    assert np.max(np.abs(got - exact)) <= 1e-10 * np.max(np.abs(exact))


@pytest.mark.parametrize(
    "knots_t, knots_eps",
    [
        ([0.0, 5.0, 60.0], [0.0, 0.04, 0.04]),  # ramp and hold
        (
            [0.0, 4.0, 8.0, 12.0, 16.0, 20.0, 24.0],
            [0.0, 0.03, 0.0, 0.03, 0.0, 0.03, 0.01],
        ),  # cycles
        ([0.0, 1.0, 31.0, 32.0, 90.0], [0.0, 0.05, 0.05, 0.0, 0.0]),  # ramp, hold, unload, recover
    ],
)
def test_sls_force_matches_ode_for_piecewise_histories(knots_t, knots_eps):
    t, eps = piecewise(np.array(knots_t), np.array(knots_eps))
    reference = ode_force(np.array(knots_t), np.array(knots_eps), t, K1, K2, ETA)
    got = sls_force(t, eps, K1, K2, ETA)
    assert np.max(np.abs(got - reference)) <= 1e-9 * np.max(np.abs(reference))


def test_sls_force_rejects_bad_arguments():
    t = np.linspace(0.0, 1.0, 5)
    with pytest.raises(ValueError, match="strictly increasing"):
        sls_force(t[::-1], t, K1, K2, ETA)
    with pytest.raises(ValueError, match="positive"):
        sls_force(t, t, K1, 0.0, ETA)


# --------------------------------------------------------------------------- fit


def test_joint_fit_of_three_rates_recovers_parameters():
    rng = np.random.default_rng(7)
    # ramp durations 10 tau, tau and tau/10: rates from 0.1x to 10x of eps_max/tau
    fit = fit_extension(ramps([10 * TAU, TAU, 0.1 * TAU], rng), specimen="T1")
    truth = {"E_e": K1, "sls_k1": K1, "sls_k2": K2, "sls_eta": ETA}
    tolerance = {"E_e": 0.005, "sls_k1": 0.005, "sls_k2": 0.03, "sls_eta": 0.03}
    for name, value in truth.items():
        est = fit.estimate(name)
        assert est.value == pytest.approx(value, rel=tolerance[name])
        assert est.ci95[0] < value < est.ci95[1], name
        assert est.stderr < 0.01 * value
        assert est.warnings == ()
        assert est.method == "sls"
    assert fit.estimate("sls_k2").extra["ci_method"] == "profile"
    assert fit.info["tau_s"] == pytest.approx(TAU, rel=0.03)
    assert fit.info["n_runs"] == 3
    assert 0.7 < fit.info["reduced_chi2"] < 1.5
    assert set(fit.correlation) == {"sls_k1|sls_k2", "sls_k1|sls_eta", "sls_k2|sls_eta"}
    assert abs(fit.correlation["sls_k2|sls_eta"]) < 0.98
    assert [len(s.x) for s in fit.series] == [400, 400, 400]
    assert "ramp0.csv" in fit.series[0].label and "1/s" in fit.series[0].label
    residual = np.concatenate([s.residual for s in fit.series])
    assert np.sqrt(np.mean(residual**2)) < 0.02  # N: of the order of the added noise


def test_each_run_is_weighted_by_its_own_noise():
    rng = np.random.default_rng(3)
    runs = ramps([10 * TAU, TAU], rng, noise=0.002) + ramps([0.1 * TAU], rng, noise=0.05, prefix="noisy")
    fit = fit_extension(runs, specimen="T1")
    noise = list(fit.info["noise_N"].values())
    assert noise[2] > 10 * noise[0]  # the noisy run is recognised ...
    assert fit.estimate("E_e").value == pytest.approx(K1, rel=0.005)  # ... and down-weighted


def test_fit_of_ramp_hold_and_cycles():
    rng = np.random.default_rng(11)
    histories = [
        ([0.0, 2.0, 60.0], [0.0, 0.04, 0.04]),
        ([0.0, 5, 10, 15, 20], [0, 0.03, 0, 0.03, 0]),
    ]
    runs = []
    for i, (knots_t, knots_eps) in enumerate(histories):
        t, eps = piecewise(np.array(knots_t), np.array(knots_eps), 100)
        force = sls_force(t, eps, K1, K2, ETA)
        runs.append(measurement(f"h{i}.csv", t, eps, force + rng.normal(0, 0.003 * force.max(), t.size)))
    fit = fit_extension(runs, specimen="T1")
    assert fit.estimate("E_e").value == pytest.approx(K1, rel=0.005)
    assert fit.estimate("sls_k2").value == pytest.approx(K2, rel=0.03)
    assert fit.estimate("sls_eta").value == pytest.approx(ETA, rel=0.03)


def test_fast_relaxation_is_flagged_but_E_e_stays():
    rng = np.random.default_rng(5)
    tau = 1e-3  # far below the 0.25 s sampling interval: the arm is a pure dashpot here
    fit = fit_extension(ramps([100.0, 30.0, 10.0], rng, k=(K1, K2, K2 * tau)), specimen="T1")
    e_e = fit.estimate("E_e")
    assert e_e.value == pytest.approx(K1, rel=0.01)
    assert e_e.warnings == () and e_e.stderr is not None
    assert e_e.ci95[0] < K1 < e_e.ci95[1]
    for name in ("sls_k2", "sls_eta"):
        (warning,) = fit.estimate(name).warnings
        assert "not identifiable" in warning and "shorter than 3 sample intervals" in warning


def test_slow_relaxation_is_flagged():
    rng = np.random.default_rng(5)
    tau = 1e5  # far beyond the 10 s runs: only k1 + k2 shows
    fit = fit_extension(ramps([10.0, 3.0, 1.0], rng, k=(K1, K2, K2 * tau)), specimen="T1")
    e_e = fit.estimate("E_e")
    assert e_e.value == pytest.approx(K1 + K2, rel=0.01)  # all the data can show
    assert any("no relaxation is resolved" in w for w in e_e.warnings)
    for name in ("sls_k2", "sls_eta"):
        assert any("not identifiable" in w for w in fit.estimate(name).warnings)


def test_fixed_parameters_are_held():
    rng = np.random.default_rng(2)
    runs = ramps([10 * TAU, TAU], rng)
    fit = fit_extension(runs, specimen="T1", fixed={"sls_k2": K2, "sls_eta": ETA})
    assert fit.estimate("sls_k2").method == "fixed" and fit.estimate("sls_k2").value == K2
    assert fit.estimate("sls_eta").stderr is None
    assert fit.estimate("E_e").value == pytest.approx(K1, rel=0.005)
    fit = fit_extension(runs, specimen="T1", fixed={"E_e": K1})
    assert fit.estimate("sls_k1").method == "fixed"
    assert fit.estimate("sls_k2").value == pytest.approx(K2, rel=0.03)
    with pytest.raises(ValueError, match="unknown parameter 'E_b'"):
        fit_extension(runs, specimen="T1", fixed={"E_b": 1.0})
    with pytest.raises(FitError, match="all fixed"):
        fit_extension(runs, specimen="T1", fixed={"E_e": K1, "sls_k2": K2, "sls_eta": ETA})


def test_bad_runs_raise_named_errors():
    t = np.linspace(0.0, 1.0, 20)
    with pytest.raises(FitError, match="flat.csv: strain or force does not change"):
        fit_extension([measurement("flat.csv", t, 0 * t, t)], specimen="T1")
    with pytest.raises(DataError, match="back.csv.*time must increase"):
        fit_extension([measurement("back.csv", t[::-1], t, t)], specimen="T1")
    table = Table(Path("nostrain.csv"), {"time": t, "force": t}, {}, {}, "")
    test = study.Test("extension", "T1", Path("nostrain.csv"), {"gauge_length": GAUGE})
    with pytest.raises(DataError, match="nostrain.csv.*'strain' or 'elongation'"):
        fit_extension([Measurement(test, table)], specimen="T1")
    with pytest.raises(FitError, match="no extension runs"):
        fit_extension([], specimen="T1")


# --------------------------------------------------------------------------- real-data artefacts


def ramp_hold(rng, name, rise, hold, force_fn, *, n=300, eps_max=0.05, noise=0.003):
    """A ramp to eps_max in `rise` s held to `hold` s; force from force_fn(t, eps)."""
    t, eps = piecewise(np.array([0.0, rise, hold]), np.array([0.0, eps_max, eps_max]), n)
    force = force_fn(t, eps)
    return measurement(name, t, eps, force + rng.normal(0.0, noise * force.max(), t.size))


def two_arm(t, eps):
    """k0 = 50 N, arms (30 N, 1 s) and (40 N, 100 s): relaxation over two decades."""
    return prony_force(t, eps, 50.0, [30.0, 40.0], [1.0, 100.0])


def test_prony_force_is_the_sls_for_one_arm():
    t, eps = piecewise(np.array([0.0, 3.0, 9.0]), np.array([0.0, 0.04, 0.01]))
    assert np.allclose(prony_force(t, eps, K1, [K2], [TAU]), sls_force(t, eps, K1, K2, ETA))


def test_two_arm_solid_is_not_passed_off_as_an_sls():
    rng = np.random.default_rng(21)
    runs = [ramp_hold(rng, f"hold{i}.csv", rise, 600.0, two_arm) for i, rise in enumerate([0.5, 20.0])]
    fit = fit_extension(runs, specimen="T1")
    e_e = fit.estimate("E_e")
    assert e_e.method == "prony" and e_e.value == pytest.approx(50.0, rel=0.02)
    assert e_e.ci95[0] < 50.0 < e_e.ci95[1]
    assert e_e.warnings[0].startswith("the standard linear solid does not describe these runs")
    assert fit.info["model_choice"]["arms_preferred"] == 2
    for name in ("sls_k1", "sls_k2", "sls_eta"):
        assert any("standard linear solid does not describe" in w for w in fit.estimate(name).warnings)
    assert fit.estimate("prony_tau1").value == pytest.approx(1.0, rel=0.1)
    assert fit.estimate("prony_tau2").value == pytest.approx(100.0, rel=0.1)
    assert fit.estimate("prony_k2").value == pytest.approx(40.0, rel=0.05)
    plot = fit.info["plot_data"]["force_time"]["hold0.csv"]
    assert set(plot) == {"time_s", "force_N", "model_N", "prony_N", "used"} and plot["time_s"].size == 601
    # the force-time figure draws the model that gives E_e: the Prony series, closer to the data
    assert fit.info["plot_data"]["model"].startswith("Prony series, 2 arms")
    rms = {key: np.sqrt(np.mean((plot[key] - plot["force_N"]) ** 2)) for key in ("model_N", "prony_N")}
    assert rms["prony_N"] < 0.5 * rms["model_N"], rms


def test_an_sls_stays_an_sls():
    rng = np.random.default_rng(22)
    runs = [
        ramp_hold(rng, f"h{i}.csv", rise, 100.0, lambda t, e: sls_force(t, e, K1, K2, ETA))
        for i, rise in enumerate([0.5, 20.0])
    ]
    fit = fit_extension(runs, specimen="T1")
    assert fit.info["model_choice"]["arms_preferred"] == 1
    assert fit.estimate("prony_k0") is None
    assert all(e.warnings == () for e in fit.estimates)
    assert not fit.info["lack_of_fit"]["misfit"]


def test_slack_rows_are_left_out_and_marked():
    """Fast unloading: the SLS would push (F < 0) but the strip goes slack (F = 0)."""
    rng = np.random.default_rng(23)
    knots_t, knots_eps = np.array([0.0, 10.0, 11.0, 40.0]), np.array([0.0, 0.05, 0.0, 0.0])
    t, eps = piecewise(knots_t, knots_eps, 150)
    model = sls_force(t, eps, K1, K2, ETA)
    assert model.min() < -0.5  # the SLS pulls the strip into compression
    force = np.maximum(model, 0.0) + rng.normal(0.0, 0.005, t.size)
    runs = [measurement("slack.csv", t, eps, force)] + ramps([10 * TAU, TAU, 0.1 * TAU], rng)
    fit = fit_extension(runs, specimen="T1")
    assert fit.estimate("E_e").value == pytest.approx(K1, rel=0.01)
    assert fit.estimate("sls_eta").value == pytest.approx(ETA, rel=0.05)
    used = fit.series[0].used
    slack = model < -0.1
    assert not used[slack].any() and used[model > 0.1].all()
    assert (
        fit.info["left_out"]["slack.csv"]["slack strip (force about 0 while the model would push)"]
        >= slack.sum()
    )


def test_window_on_extension_rows():
    rng = np.random.default_rng(24)
    runs = ramps([10 * TAU, TAU], rng)
    t = np.linspace(0.0, TAU, 400)
    eps = 0.05 * t / TAU
    force = sls_ramp(t, 0.05 / TAU, K1, K2, ETA)
    force[t > 0.8 * TAU] *= 0.5  # the strip tears: outside the window
    test = study.Test(
        "extension", "T1", Path("torn.csv"), {"gauge_length": GAUGE}, window={"strain": (0.0, 0.04)}
    )
    runs.append(
        Measurement(test, Table(Path("torn.csv"), {"time": t, "force": force, "strain": eps}, {}, {}, ""))
    )
    fit = fit_extension(runs, specimen="T1")
    assert fit.estimate("E_e").value == pytest.approx(K1, rel=0.005)
    assert np.array_equal(fit.series[2].used, eps <= 0.04)
    assert fit.info["left_out"] == {"torn.csv": {"outside the window": int(np.sum(eps > 0.04))}}


def test_no_interval_rather_than_an_overflow_when_tau_is_far_beyond_the_run():
    # tau = eta/k2 = 17 s against one 1.1 s ramp with AR(1) noise: k2 and eta are not identifiable,
    # their standard errors are hundreds of times their values, and exp(t se/value) of the
    # t-log interval overflowed (OverflowError, exit 3 in matid fit; found by the session's review)
    from matid.fits.extension import prony
    from matid.fits.stats import ar1_noise, wald_log_interval

    assert wald_log_interval(1.0, 400.0, 2.0) is None
    assert prony._estimate("prony_k1", 1.0, 400.0, 10.0, 100).ci95 is None  # the same interval
    assert wald_log_interval(2.0, 0.1, 2.0) == pytest.approx(
        (2.0 * np.exp(-0.1), 2.0 * np.exp(0.1)), rel=1e-15
    )
    rng = np.random.default_rng(219233270)
    k, duration = (90.398, 5.5953, 95.938), 1.1064
    t = np.linspace(0.0, duration, 400)
    force = sls_ramp(t, 0.05 / duration, *k)
    force = force + 0.0012320 * force.max() * ar1_noise(rng, t.size, 0.5)
    fit = fit_extension([measurement("r0.csv", t, 0.05 * t / duration, force)], specimen="T1")
    by = {e.parameter: e for e in fit.estimates}
    for name in ("sls_k2", "sls_eta"):
        assert by[name].ci95 is None
        assert any("not identifiable" in w for w in by[name].warnings)
    assert np.isfinite(by["E_e"].value) and by["E_e"].warnings


def test_the_force_time_figure_draws_and_names_the_prony_series_that_gives_e_e():
    from matplotlib.figure import Figure

    from matid.report.holds import hold_drawings

    rng = np.random.default_rng(21)
    runs = [ramp_hold(rng, f"hold{i}.csv", rise, 600.0, two_arm) for i, rise in enumerate([0.5, 20.0])]
    (drawing,) = hold_drawings(fit_extension(runs, specimen="T1"))
    assert "Prony series, 2 arms" in drawing.caption and "SLS" not in drawing.caption
    fig = Figure()
    drawing.draw(fig, (0.1, 0.1, 0.9, 0.9))
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any(text.startswith("Prony series, 2 arms") for text in legend), legend
