"""E_s from the three-point bend: the rod model inside least squares (physics.md section 6).

Synthetic curves come from an independent strong-form shooting model of the bend
(``matid.example.forward.bend_force``, matid.example.bend_shooting), with seeded noise of
0.3 % of the largest force as in the demo study. Tolerances are set from the
scatter measured over 20 seeds (see each test).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from matid.app.pipeline import run_study
from matid.errors import FitError
from matid.example.forward import bend_force, unloading_force
from matid.fits.shear import fit as shear
from matid.io.results import stiffness_json
from matid.io.study import load_study
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.model.results import Estimate

E_B, E_S, E_E = 6.5e-5, 21.0, 120.0  # N m^2, N, N (demo specimen T1)
OUTER = 2.4e-3
ROLLERS = 2e-3
NOISE = 0.003  # force sd as a fraction of the largest force
SPECIMEN = study.Specimen("T1", OUTER, 1.6e-3)


def rig(span: float, specimen_length: float = 0.03) -> dict[str, float]:
    return {
        "span": span,
        "specimen_length": specimen_length,
        "support_radius": ROLLERS,
        "nose_radius": ROLLERS,
    }


def measurement(d, force, params: dict, name: str = "3pb.csv") -> Measurement:
    """A bend test and its table as ingest would deliver them (SI columns)."""
    test = study.Test("three_point_bend", "T1", Path(name), params)
    return Measurement(test, Table(Path(name), {"deflection": d, "force": force}, {}, {}, ""))


def rod_curve(span: float, specimen_length: float = 0.03, n: int = 30, d_max: float | None = None):
    """Noise-free loading curve of the rod model at 96 elements, to 10 % of the span by default."""
    d = np.linspace(0.0, 0.1 * span if d_max is None else d_max, n)
    force = bend_force(d, E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=OUTER, **rig(span, specimen_length))
    return d, force


def noisy(force: np.ndarray, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return force + rng.normal(0.0, NOISE * force.max(), force.size)


def fit_rod(*args, **kwargs):
    """The shear fit on rod data (the shooting model): no local contact compliance, no model-form error."""
    return shear.fit_three_point_bend(*args, local_compliance=(0.0, 0.0), model_form=0.0, **kwargs)


def known(E_b: float = E_B, sd_b: float = 0.0, E_e: float = E_E, sd_e: float = 0.0) -> dict[str, Estimate]:
    """E_b and E_e as the earlier fits (or [[fixed]] entries) hand them to the shear fit."""
    return {
        "E_b": Estimate("E_b", E_b, sd_b, None, 0, "linear"),
        "E_e": Estimate("E_e", E_e, sd_e, None, 0, "sls"),
    }


@pytest.fixture(scope="module")
def curve10():
    return rod_curve(0.010)


@pytest.fixture(scope="module")
def with_unloading(curve10):
    """The 10 mm curve followed by 8 unloading rows (8 % hysteresis, as the demo), seed 12."""
    d, force = curve10
    d_max = d[-1]
    d_un = np.linspace(d_max, 0.2 * d_max, 9)[1:]
    f_un = unloading_force(
        d_un,
        bend_force(d_un, E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=OUTER, **rig(0.010)),
        d_max=d_max,
        hysteresis=0.08,
    )
    all_d, all_f = np.concatenate([d, d_un]), noisy(np.concatenate([force, f_un]), 12)
    fit = fit_rod([measurement(all_d, all_f, rig(0.010))], specimen=SPECIMEN, known=known())
    return all_d, all_f, fit


# --------------------------------------------------------------------------- one span, E_b and E_e held


def test_round_trip_one_span(with_unloading):
    _, _, fit = with_unloading
    est = fit.estimate("E_s")
    assert est.value == pytest.approx(E_S, rel=0.01)  # measured scatter over 20 seeds: 0.29 % sd
    assert est.ci95[0] < E_S < est.ci95[1]
    assert est.ci95[0] < est.value < est.ci95[1]
    assert 0.001 < est.stderr / est.value < 0.01
    assert est.method == "cosserat-fe" and est.n_points == 30 and est.warnings == ()
    fe = est.extra["fe"]
    assert fe["element"] == "P2" and fe["elements"] >= shear.START_ELEMENTS
    assert 0 <= fe["discretization_error"] < 0.1 * est.stderr / est.value
    assert fe["runtime_s"] > 0 and fe["rod_solves"] >= 1
    assert fit.kind == "three_point_bend" and fit.specimen == "T1" and fit.correlation == {}
    assert [e.parameter for e in fit.estimates] == ["E_s"]
    info = fit.info
    assert info["spans_mm"] == [10.0]
    assert info["shear_share"][0] == pytest.approx(shear.shear_share(0.01, E_B, est.value), abs=1e-4)
    assert info["E_b_used"] == E_B and info["E_e_used"] == E_E
    assert info["noise_N"] == pytest.approx(NOISE * fit.series[0].y.max(), rel=0.3)
    assert info["sensitivity_to_noise"] > 3  # a 10 % change in E_s stands well above the noise
    assert info["held_stiffness_propagation"] == {}  # zero stderr: nothing to propagate


def test_unloading_rows_are_excluded_and_counted(with_unloading):
    d, force, fit = with_unloading
    (series,) = fit.series
    used = np.arange(d.size) < 30
    assert np.array_equal(series.used, used)
    assert np.array_equal(series.x, d) and np.array_equal(series.y, force)
    assert np.all(np.isfinite(series.y_fit[used])) and np.all(np.isnan(series.y_fit[~used]))
    assert fit.info["unloading_rows_excluded"] == 8
    assert fit.estimate("E_s").n_points == 30
    # the same fit without the unloading rows gives the same E_s: they carry no weight
    alone = fit_rod([measurement(d[used], force[used], rig(0.010))], specimen=SPECIMEN, known=known())
    assert alone.estimate("E_s").value == pytest.approx(fit.estimate("E_s").value, rel=1e-8)
    assert alone.info["unloading_rows_excluded"] == 0


def test_held_stiffness_uncertainty_is_propagated(curve10):
    """A wrong E_b moves E_s as dlogE_s/dlogE_b says; its stderr enters the interval."""
    d, force = curve10
    data = [measurement(d, noisy(force, 5), rig(0.010))]
    base = fit_rod(data, specimen=SPECIMEN, known=known(sd_b=0.002 * E_B, sd_e=0.01 * E_E))
    moved = fit_rod(data, specimen=SPECIMEN, known=known(E_b=1.01 * E_B))
    held = base.info["held_stiffness_propagation"]
    assert set(held) == {"E_b", "E_e"}
    slope = np.log(moved.estimate("E_s").value / base.estimate("E_s").value) / np.log(1.01)
    assert held["E_b"]["dlogEs_dlogp"] == pytest.approx(slope, rel=0.05)
    # Timoshenko's -(1 - share)/share (-2.68 here) holds at small deflection (measured -2.66 at
    # d <= 1e-3 span); large deflection lowers it (-2.39 at 3 %, -1.89 at 10 % of the span).
    share = base.info["shear_share"][0]
    assert -(1 - share) / share < slope < -0.5 * (1 - share) / share
    assert held["E_b"]["contribution"] == pytest.approx(abs(slope) * 0.002, rel=0.05)
    assert abs(held["E_e"]["dlogEs_dlogp"]) < 0.05  # extension barely matters at 10 % of span
    est, own = base.estimate("E_s"), moved.estimate("E_s")
    var = (est.stderr / est.value) ** 2
    own_var = (own.stderr / own.value) ** 2
    assert var == pytest.approx(own_var + sum(h["contribution"] ** 2 for h in held.values()), rel=0.05)


# --------------------------------------------------------------------------- several spans, E_b fitted


def test_two_spans_fit_E_s_and_E_b_jointly():
    """8 and 10 mm, seed 2. Measured over 20 seeds: E_s error sd 0.62 % (reported stderr 0.62 %),
    E_b error sd 0.43 % (stderr 0.47 %), correlation -0.97. Tolerances are about 3 sd."""
    rng_seeds = {0.008: 21, 0.010: 22}
    tests = []
    for span, seed in rng_seeds.items():
        d, force = rod_curve(span)
        tests.append(measurement(d, noisy(force, seed), rig(span), name=f"3pb_S{1e3 * span:g}.csv"))
    fit = fit_rod(tests, specimen=SPECIMEN, known=known(E_b=1.05 * E_B), fit_E_b=True)
    es, eb = fit.estimate("E_s"), fit.estimate("E_b")
    assert es.value == pytest.approx(E_S, rel=0.02)
    assert eb.value == pytest.approx(E_B, rel=0.015)
    for est, truth in ((es, E_S), (eb, E_B)):
        assert est.method == "cosserat-fe" and est.n_points == 60
        assert abs(est.value - truth) < 4 * est.stderr
        assert est.ci95[0] < est.value < est.ci95[1]
    assert es.stderr / es.value < 0.015 and eb.stderr / eb.value < 0.01
    assert -1.0 < fit.correlation["E_s|E_b"] < -0.9  # a stiffer E_b trades against a softer E_s
    assert fit.info["spans_mm"] == [8.0, 10.0]
    assert [s.label.split()[0] for s in fit.series] == ["3pb_S8.csv", "3pb_S10.csv"]
    # E_b fitted here, so only E_e's (zero) uncertainty may be propagated
    assert "E_b" not in fit.info["held_stiffness_propagation"]


def test_fit_E_b_needs_two_spans(curve10):
    d, force = curve10
    with pytest.raises(FitError, match="two or more spans"):
        fit_rod([measurement(d, force, rig(0.010))], specimen=SPECIMEN, known=known(), fit_E_b=True)


# --------------------------------------------------------------------------- limits and warnings


def test_small_deflection_limit_is_timoshenko():
    """Timoshenko data at d <= 1e-5 span give back its E_s.

    The rod model departs from Timoshenko linearly in d: the contact on the rollers
    rolls inwards by (roller + tube radius) x slope, shortening the span (measured:
    force +0.27 % at d = 1e-3 span, +0.027 % at 1e-4; with zero radii the departure
    vanishes). So the limit is taken at 1e-5 of the span, where it is 0.003 %.
    """
    span = 0.010
    d = np.linspace(0.0, 1e-5 * span, 15)
    force = shear.timoshenko_force(d, span, E_B, E_S)
    force = force + np.random.default_rng(0).normal(0.0, 1e-6 * force.max(), d.size)
    fit = fit_rod([measurement(d, force, rig(span))], specimen=SPECIMEN, known=known())
    assert fit.estimate("E_s").value == pytest.approx(E_S, rel=1e-3)
    assert fit.info["timoshenko_start_N"] == pytest.approx(E_S, rel=1e-3)


def test_slender_span_is_flagged_short_span_is_not(with_unloading):
    d, force = rod_curve(0.040, specimen_length=0.06, d_max=0.002)
    fit = fit_rod(
        [measurement(d, noisy(force, 3), rig(0.040, 0.06))],
        specimen=SPECIMEN,
        known=known(sd_b=0.002 * E_B),
    )
    est = fit.estimate("E_s")
    assert fit.info["shear_share"][0] < shear.MIN_SHEAR_SHARE
    assert any("not identifiable" in w for w in est.warnings)
    assert est.stderr / est.value > 0.05  # a 0.2 % stderr of E_b alone spreads E_s by ~9 %
    assert not any("not identifiable" in w for w in with_unloading[2].estimate("E_s").warnings)


def test_coverage_of_the_interval(curve10):
    """Ten noise seeds on one curve: the 95 % interval covers the truth at least 8 times."""
    d, force = curve10
    covered = 0
    for seed in range(100, 110):
        est = fit_rod(
            [measurement(d, noisy(force, seed), rig(0.010))], specimen=SPECIMEN, known=known()
        ).estimate("E_s")
        covered += est.ci95[0] < E_S < est.ci95[1]
    assert covered >= 8


# --------------------------------------------------------------------------- missing E_b, pipeline


def test_missing_E_b_names_it_and_the_specimen(curve10):
    d, force = curve10
    with pytest.raises(FitError, match=r"E_b.*T1|T1.*E_b"):
        fit_rod([measurement(d, force, rig(0.010))], specimen=SPECIMEN, known={"E_e": known()["E_e"]})


STUDY = """
[study]
name = "shear only"

[[specimen]]
id = "T1"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"

[[test]]
kind = "three_point_bend"
specimen = "T1"
file = "3pb_T1_S10.csv"
span = "10 mm"
specimen_length = "30 mm"
support_radius = "2 mm"
nose_radius = "2 mm"
"""
FIXED = """
[[fixed]]
specimen = "T1"
parameter = "E_b"
value = "6.5e-5 N m^2"

[[fixed]]
specimen = "T1"
parameter = "E_e"
value = "120 N"
"""


def test_pipeline_with_fixed_E_b_and_E_e(tmp_path, with_unloading):
    d, force, _ = with_unloading
    rows = "\n".join(f"{1e3 * x:.6f},{f:.6f}" for x, f in zip(d, force, strict=True))
    (tmp_path / "3pb_T1_S10.csv").write_text("deflection [mm],force [N]\n" + rows + "\n", encoding="utf-8")
    (tmp_path / "study.toml").write_text(STUDY, encoding="utf-8")

    failed = run_study(load_study(tmp_path))  # no E_b for T1: the fit fails, the run goes on
    assert not failed.ok and failed.fits == ()
    (failure,) = failed.failures
    assert failure.kind == "three_point_bend" and "E_b" in failure.reason and "T1" in failure.reason

    # nose travel at 10 mm on this tube: the local contact compliance (predicted from E_e and the
    # wall) is 2-4x the shear compliance; the value stands with that warning first (these data come
    # from the rod model, so the value itself is right) and an interval widened by the predicted bias
    (tmp_path / "study.toml").write_text(STUDY + FIXED, encoding="utf-8")
    result = run_study(load_study(tmp_path))
    assert result.ok and [f.kind for f in result.fits] == ["three_point_bend"]
    doc = json.loads(json.dumps(stiffness_json(result)))
    entry = doc["specimens"]["T1"]
    assert set(entry) == {"E_b", "E_s", "E_e"}
    assert entry["E_b"]["method"] == entry["E_e"]["method"] == "fixed"
    es = entry["E_s"]
    assert es["method"] == "cosserat-fe" and es["unit"] == "N" and es["n_points"] == 30
    assert es["value"] == pytest.approx(E_S, rel=0.01)
    assert es["warnings"][0].startswith("E_s is likely too low") and "centreline" in es["warnings"][0]
    assert es["ci95"][1] > 2 * es["value"] and es["ci95"][0] < es["value"]


# --------------------------------------------------------------------------- the direct Jacobian


@pytest.mark.parametrize("fit_E_b", [False, True])
def test_jacobian_matches_central_differences(fit_E_b):
    spans = (0.008, 0.010)
    data = []
    for span in spans:
        d = np.linspace(0.0, 0.1 * span, 10)
        data.append(
            shear.bend_data(
                measurement(d, shear.timoshenko_force(d, span, E_B, E_S), rig(span)), SPECIMEN, E_B
            )
        )
    problem = shear.Problem(data, E_B, E_E, fit_E_b=fit_E_b, elements=16)
    x = np.log([23.0, 6.0e-5][: 1 + fit_E_b])  # away from the data's values: non-zero residuals
    _, J = problem.evaluate(x)
    h = 1e-4
    for k in range(x.size):
        step = np.zeros_like(x)
        step[k] = h
        fd = (problem.evaluate(x + step)[0] - problem.evaluate(x - step)[0]) / (2 * h)
        assert np.max(np.abs(fd - J[:, k])) < 1e-6 * np.max(np.abs(J[:, k]))
