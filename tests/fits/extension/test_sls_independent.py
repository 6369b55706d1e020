"""The extension (SLS) fit on records matid did not make.

The ramp-and-hold records here come from ``scipy.integrate.solve_ivp`` of the standard
linear solid's ODE (not from :mod:`matid.physics.sls`), with AR(1) noise, written in the
Zwick testXpert style (cp1252, ``;``, decimal comma, units row, preamble; see
tests/corpus/testxpert_zwick.TXT) and fitted through ``matid fit`` as a user would.

1. Clean records (AR(1) noise only): the 95 % intervals cover k1, k2 and eta.
2. The same with a load-cell tare offset and a slack toe: the fit warns, and every warning
   of the fit reaches stiffness.json, the terminal summary and the report's warnings box
   (docs/contract.md section 7).
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from matid.app.cli import main
from matid.app.pipeline import run_study
from matid.io.results import stiffness_json
from matid.io.study import load_study

K1, K2, TAU = 40.0, 25.0, 5.0  # N, N, s
ETA = K2 * TAU  # N s
GAUGE = 0.05  # m
STRAIN = 0.04  # ramp end
RATES = (0.005, 0.02)  # 1/s: ramps of 8 s and 2 s
HOLD = 30.0  # s
DT = 0.1  # s


def sls_record(
    rate: float, tau: float = TAU, hold: float = HOLD
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, strain, force) of a ramp to STRAIN at ``rate`` then a hold of ``hold`` s (at least one
    sample), from the ODE f2' = k2 eps' - f2 / tau, F = k1 eps + f2, integrated piecewise (eps' jumps)."""
    t_ramp = STRAIN / rate
    t = np.arange(0.0, t_ramp + hold + DT / 2, DT)
    ramp = t <= t_ramp
    opts = dict(method="DOP853", rtol=1e-11, atol=1e-13)
    up = solve_ivp(
        lambda s, f: [K2 * rate - f[0] / tau], (0.0, t_ramp), [0.0], t_eval=t[ramp], dense_output=True, **opts
    )
    f_end = up.sol(t_ramp)[0]
    hold = solve_ivp(lambda s, f: [-f[0] / tau], (t_ramp, t[-1]), [f_end], t_eval=t[~ramp], **opts)
    eps = np.minimum(rate * t, STRAIN)
    force = K1 * eps + np.concatenate([up.y[0], hold.y[0]])
    return t, eps, force


def ar1(rng: np.random.Generator, n: int, phi: float, sd: float) -> np.ndarray:
    e = np.empty(n)
    e[0] = rng.normal(0.0, sd)
    innovations = rng.normal(0.0, sd * np.sqrt(1 - phi**2), n)
    for i in range(1, n):
        e[i] = phi * e[i - 1] + innovations[i]
    return e


def write_testxpert(path: Path, t, elongation_m, force_n) -> None:
    """Zwick testXpert export: preamble, ';', decimal comma, units row (s, µm, mN), cp1252, CRLF."""
    lines = [
        "Prüfer: Müller",
        "Prüfvorschrift;ISO 527-1",
        "Prüfzeit;Standardweg;Standardkraft;Bemerkung;",
        "s;µm;mN;;",
    ]
    for a, b, c in zip(t, elongation_m * 1e6, force_n * 1e3, strict=True):
        lines.append(f"{a:.3f};{b:.4f};{c:.4f};;".replace(".", ","))
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("cp1252"))


def make_study(
    folder: Path,
    *,
    seed: int,
    tare: float = 0.0,
    toe: float = 0.0,
    tau: float = TAU,
    phi: float = 0.8,
    quantum: float = 0.0,
    rates: tuple[float, ...] = RATES,
    hold: float = HOLD,
) -> Path:
    """Ramp-and-hold runs of one tube, one per rate; ``tare`` [N] adds to every force, ``toe`` [m] of
    crosshead travel comes before the strip is taut (force 0 there, strain from its end)."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True, exist_ok=True)
    tests = []
    for i, rate in enumerate(rates, 1):
        t, eps, force = sls_record(rate, tau, hold)
        elongation = eps * GAUGE
        if toe:
            n_toe = int(round(toe / (rate * GAUGE) / DT))
            t = np.concatenate([np.arange(n_toe) * DT, t + n_toe * DT])
            elongation = np.concatenate([np.arange(n_toe) * DT * rate * GAUGE, elongation + toe])
            force = np.concatenate([np.zeros(n_toe), force])
        force = force + tare + ar1(rng, t.size, phi, 0.004)
        if quantum:  # a load cell's resolution
            force = np.round(force / quantum) * quantum
        name = f"zug_r{i}.TXT"
        write_testxpert(folder / name, t, elongation, force)
        tests.append(
            f'[[test]]\nkind = "extension"\nspecimen = "S1"\nfile = "{name}"\ngauge_length = "50 mm"\n'
            'encoding = "cp1252"\n'
            'columns = { time = "Prüfzeit", elongation = "Standardweg", force = "Standardkraft" }\n'
        )
    toml = (
        '[study]\nname = "independent SLS records"\n\n'
        '[[specimen]]\nid = "S1"\nouter_diameter = "2.4 mm"\ninner_diameter = "1.6 mm"\n\n' + "\n".join(tests)
    )
    (folder / "study.toml").write_text(toml, encoding="utf-8")
    return folder / "study.toml"


def fit(study: Path, out: Path, capsys) -> tuple[int, str, dict, str]:
    code = main(["fit", str(study), "--out", str(out), "--quiet"])
    stdout = capsys.readouterr().out
    doc = json.loads((out / "stiffness.json").read_text(encoding="utf-8"))
    page = (out / "report.html").read_text(encoding="utf-8")
    start = page.index('<section id="warnings">')
    box = html.unescape(page[start : page.index("</section>", start)])  # the report's warnings box
    return code, stdout, doc, box


def test_the_ode_record_matches_the_ramp_closed_form():
    """The generator itself: during the ramp F = k1 r t + eta r (1 - exp(-t/tau))."""
    t, eps, force = sls_record(RATES[0])
    ramp = t <= STRAIN / RATES[0]
    r = RATES[0]
    closed = K1 * r * t[ramp] + ETA * r * (1 - np.exp(-t[ramp] / TAU))
    np.testing.assert_allclose(force[ramp], closed, rtol=1e-9, atol=1e-12)


def test_matid_fit_recovers_the_ode_parameters(tmp_path, capsys):
    code, stdout, doc, _ = fit(make_study(tmp_path / "study", seed=11), tmp_path / "out", capsys)
    assert code == 0, stdout
    params = doc["specimens"]["S1"]
    for name, true in (("sls_k1", K1), ("sls_k2", K2), ("sls_eta", ETA)):
        item = params[name]
        low, high = item["ci95"]
        assert low <= true <= high, (name, item["value"], low, high)
        assert abs(item["value"] / true - 1) < 0.02, (name, item["value"])
        assert (high - low) / true < 0.1, (name, low, high)  # an interval that says something


def test_interval_coverage_over_many_records(tmp_path):
    """40 records: each 95 % interval covers its true value at least 34 times (a binomial
    (40, 0.95) falls below 34 with probability 0.3 %)."""
    n, covered = 40, {"sls_k1": 0, "sls_k2": 0, "sls_eta": 0}
    for seed in range(100, 100 + n):
        result = run_study(load_study(make_study(tmp_path / f"s{seed}", seed=seed)))
        params = stiffness_json(result)["specimens"]["S1"]
        for name, true in (("sls_k1", K1), ("sls_k2", K2), ("sls_eta", ETA)):
            low, high = params[name]["ci95"]
            covered[name] += low <= true <= high
            assert abs(params[name]["value"] / true - 1) < 0.02, (seed, name, params[name]["value"])
    assert all(c >= 34 for c in covered.values()), covered


@pytest.mark.parametrize(
    ("bad", "expected"),
    [
        (dict(tare=0.1, toe=2e-4), "does not describe the data"),
        (dict(tau=2000.0), "not identifiable"),
    ],
    ids=["tare 0.1 N and slack toe 0.2 mm", "tau 2000 s beyond 38 s runs"],
)
def test_every_warning_of_a_bad_record_reaches_every_output(tmp_path, capsys, bad, expected):
    """A tare and a slack toe (the SLS does not fit), or a relaxation far slower than the
    runs (k2 and eta not identifiable): each warning of the extension fit (the TestFit's
    own and its estimates') is in stiffness.json, printed by `matid fit`, and in the
    report's warnings box."""
    study = make_study(tmp_path / "study", seed=13, **bad)
    (ext,) = [f for f in run_study(load_study(study)).fits if f.kind == "extension"]
    source = {(None, w) for w in ext.warnings} | {(e.parameter, w) for e in ext.estimates for w in e.warnings}
    assert any(expected in w for _, w in source), source
    code, stdout, doc, box = fit(study, tmp_path / "out", capsys)
    assert code == 0, stdout
    params = doc["specimens"]["S1"]
    flat = " ".join(box.split())
    for parameter, warning in source:
        for name in [parameter] if parameter else [e.parameter for e in ext.estimates]:
            assert warning in params[name]["warnings"], (name, warning)
        assert any(warning in w for w in doc["warnings"]), warning
        assert warning in stdout, warning
        assert " ".join(warning.split()) in flat, warning


def _warnings(study: Path) -> set[tuple[str | None, str]]:
    (ext,) = [f for f in run_study(load_study(study)).fits if f.kind == "extension"]
    return {(None, w) for w in ext.warnings} | {(e.parameter, w) for e in ext.estimates for w in e.warnings}


@pytest.mark.parametrize("row", [200, 345, 370])
def test_the_warnings_of_unidentifiable_k2_and_eta_do_not_hang_on_the_last_digit(tmp_path, row):
    """tau 2000 s beyond 38 s runs: k2 and eta end anywhere along a flat valley. One force reading
    moved by 0.1 uN (its last written digit; the noise is 4 mN) must not change the warnings on
    k2, eta and E_e: the printed tau and relative standard errors moved with it (4.4e+03 s, 9494 %
    against 9490 %), so the same study could warn differently from one run to the next (the flaky
    test above). Rows 345 and 370: the elastic line's reason printed the unresolved SLS's
    equilibrium stiffness, 4.736 N, and 5.989 or 4.735 N with the reading moved (2026-11-28, a
    failure of this test in the suite). The misfit warning's statistics of the residuals may move
    with the data."""
    study = make_study(tmp_path / "a", seed=13, tau=2000.0)
    moved = make_study(tmp_path / "b", seed=13, tau=2000.0)
    path = moved.parent / "zug_r1.TXT"
    lines = path.read_bytes().decode("cp1252").split("\r\n")
    t, elongation, force, *rest = lines[row].split(";")
    force_mN = float(force.replace(",", ".")) + 1e-4
    lines[row] = ";".join([t, elongation, f"{force_mN:.4f}".replace(".", ","), *rest])
    path.write_bytes("\r\n".join(lines).encode("cp1252"))
    first, second = (
        {(p, w) for p, w in _warnings(s) if "describe the data within their noise" not in w}
        for s in (study, moved)
    )
    assert any("not identifiable" in w for _, w in first), first
    assert second == first


def test_every_warning_is_the_same_wherever_along_its_flat_valley_the_sls_lands(tmp_path, monkeypatch):
    """tau 2000 s beyond 38 s runs: k2 and eta lie along a flat valley, and a relative change of
    1e-15 in the least squares' starting point moves the SLS's k1 from 4.736 to 5.989 N (both
    stacks; the last bits of one call and the next in one process can differ the same way). No
    warning of any estimate may move with it: the flaky outputs test above compared the warnings
    of two such calls (2026-11-28: tau 4.29e3 against 4.4e3 s printed, and the SLS's equilibrium
    stiffness 4.736 against 5.989 N, before the digits went).

    Starts along the valley (k1 + k2 = 64.85 N, tau 1e4 s) land elsewhere again. From k1 = 60 N
    the first least squares ends at its evaluation limit, far off, and the residual noise it
    weights the next fit with (1.72 and 1.81 N, in another ratio than the runs' 4.2 and 3.7 mN)
    moves the landing and so the final weights by 0.26 % on one run: the misfit warning, then on
    those weights, printed reduced chi2 7.03 where every other landing printed 7.07 (the one start
    of 263 tried whose warnings differed; the failure of this test in a suite run at load 6,
    2026-11-28, had two landings whose warnings differed). The misfit is now judged on each run's
    model-free noise."""
    from matid.fits.extension import lsq

    study = make_study(tmp_path / "study", seed=13, tau=2000.0)
    starts = lsq._starts
    landed, said, e_e = set(), set(), set()
    # k1 lands at 4.736, 5.99, 5.989, 9.12 N (at the lowest pins: 5.99, 4.736, 4.736, 9.12)
    shifted = [
        lambda *a, rel=rel: [{k: v * (1 + rel) for k, v in s.items()} for s in starts(*a)]
        for rel in (0.0, -1e-15, 1e-13, 1e-5)
    ]
    # and from these at 0.94, 4.15, 9.71, 6.43, 6.83 (the reweighting above), 8.68, 9.02, 4.59 N
    along = [
        lambda *a, k1=k1: [{"k1": k1, "k2": 64.85 - k1, "eta": (64.85 - k1) * 1e4}]
        for k1 in (1.0, 20.0, 40.0, 58.0, 60.0, 61.0, 62.0, 64.0)
    ]
    for pinned in shifted + along:
        monkeypatch.setattr(lsq, "_starts", pinned)
        (ext,) = run_study(load_study(study)).fits
        landed.add(round(ext.estimate("sls_k1").value, 1))
        said.add(tuple((e.parameter, e.warnings) for e in ext.estimates) + (ext.warnings,))
        e_e.add(ext.estimate("E_e").value)
    assert len(landed) > 4, landed  # the starts did land apart
    assert len(said) == 1, said
    # the elastic line is weighted by each run's model-free noise, not by the landed fit's residual
    # noise: E_e is the same to the last bit (was 64.84447772686316 against 64.84447687148294 N,
    # whose printed digits could straddle a rounding step: the flaky outputs test)
    assert len(e_e) == 1, e_e


@pytest.mark.parametrize(
    ("rates", "toe"),
    [((0.005,), 2e-4), ((0.005, 0.02), 0.0)],
    ids=["one ramp after a slack toe", "ramps at two rates"],
)
def test_the_warnings_of_ramps_are_the_same_wherever_along_its_flat_valley_the_sls_lands(
    tmp_path, monkeypatch, rates, toe
):
    """tau 2000 s beyond ramps of 8 s (and 2 s) that hold for 0.15 s: k1 lands anywhere between
    0.9 and 30 N from starts along the valley. One ramp: E_e is the ramp's line, and its warning
    on the slack toe stated the force offset of the landed SLS (-0.0002 to -0.116 N, at 7 of 7
    landings), now the ramp line's. Two rates: the SLS misfit warning stated its intervals'
    widening from the landed Jacobian (3.0x at one landing, 3.1x at others), now left out where
    k2 and eta are not identifiable. (There E_e is still the landed SLS's k1, which moves: no line
    is fitted to ramps at several rates without a hold or an unloading.)"""
    from matid.fits.extension import lsq

    study = make_study(tmp_path / "study", seed=13, tau=2000.0, rates=rates, hold=0.15, toe=toe)
    starts = lsq._starts
    landed, said = set(), set()
    for k1 in (None, 1.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0):
        along = [{"k1": k1, "k2": 64.85 - k1, "eta": (64.85 - k1) * 1e4}] if k1 else None
        monkeypatch.setattr(lsq, "_starts", (lambda *a, along=along: along) if along else starts)
        (ext,) = run_study(load_study(study)).fits
        landed.add(round(ext.estimate("sls_k1").value, 1))
        said.add(tuple((e.parameter, e.warnings) for e in ext.estimates) + (ext.warnings,))
    # the starts did land apart: at least 4 distinct k1 (the lowest pins: 0.9, 2.4, 5.1, 5.5 N on two rates)
    assert len(landed) >= 4, landed
    assert len(said) == 1, said
    (warnings,) = said
    assert any("not identifiable" in w for _, ws in warnings[:-1] for w in ws), warnings
    assert not toe or any("force offset" in w for w in dict(warnings[:-1])["E_e"]), warnings


@pytest.mark.parametrize(
    ("bad", "widened"),
    [(dict(tare=0.1, toe=2e-4), True), (dict(tau=2000.0), False)],
    ids=["tare and slack toe", "tau 2000 s beyond 38 s runs"],
)
def test_the_sls_misfit_warning_names_the_model_and_says_what_to_do(tmp_path, bad, widened):
    """Both records leave AR(1) residuals the SLS does not describe. The SLS parameters' misfit warning
    names the model, gives the advice, and states how much the intervals were widened (the fit's
    info) only where k2 and eta are identifiable: where they are not, the factor moves with where
    along the valley the fit landed (the mutation sample of 2026-11-28 dropped the advice and
    upper-cased the model unseen)."""
    (ext,) = run_study(load_study(make_study(tmp_path / "study", seed=13, **bad))).fits
    for name in ("sls_k1", "sls_k2", "sls_eta"):
        (said,) = [w for w in ext.estimate(name).warnings if "within their noise" in w]
        assert said.startswith("the standard linear solid does not describe the data within their noise: "), (
            said
        )
        assert said.endswith(
            ". Check the fit plots; a model with more arms (prony_*) or a window on the part the model "
            "follows may describe the runs"
        ), said
        factor = f"; the interval is widened {ext.info['interval_widening']:.1f}x for it."
        assert (factor in said) == widened, (factor, said)
        assert ("widened" in said) == widened, said


def test_k2_and_eta_of_a_relaxation_beyond_the_runs_send_the_reader_to_e_e(tmp_path):
    """tau 2000 s beyond 38 s runs: E_e is the elastic line's slope, and the first warning on k2 and
    on eta, as a reader sees it, says they are not identifiable and points to E_e's warning (the
    mutation sample of 2026-11-28 lower-cased E_e there unseen)."""
    (ext,) = run_study(load_study(make_study(tmp_path / "study", seed=13, tau=2000.0))).fits
    assert ext.estimate("E_e").method == "elastic-line"
    for name in ("sls_k2", "sls_eta"):
        first = ext.estimate(name).warnings[0]
        assert first.startswith("k2 and eta are not identifiable: "), first
        assert first.endswith("(E_e is the line's slope; see its warning)"), first


def test_e_e_of_a_true_sls_keeps_its_interval(tmp_path):
    # seed 149: BIC preferred a 2-arm Prony model whose fast arm (tau 3.3 ms) lies 30x below the
    # 0.1 s sampling interval; its covariance is singular, so E_e became prony_k0 with no standard
    # error and no interval, warned that "the SLS does not describe these runs". A model the data
    # do not determine is no longer preferred (prony.choose). That the intervals cover the truth
    # is tested over 40 records above.
    (ext,) = run_study(load_study(make_study(tmp_path / "study", seed=149))).fits
    e_e = ext.estimate("E_e")
    assert e_e.method == "sls" and e_e.stderr is not None and e_e.ci95 is not None
    assert ext.info["model_choice"]["arms_preferred"] == 1
    assert not any("does not describe these runs" in w for w in e_e.warnings)


def test_a_quantised_record_has_a_finite_reduced_chi2(tmp_path):
    """Force resolved to 0.02 N with 4 mN noise: most second differences are 0, so the MAD
    noise is 0; the run noise must then come from the rms of the second differences
    (:func:`matid.fits.stats.difference_noise`), not 1e-9 x the peak force (reduced chi2 9.2e12)."""
    (ext,) = run_study(load_study(make_study(tmp_path / "study", seed=5, phi=0.0, quantum=0.02))).fits
    assert ext.info["reduced_chi2"] < 100, ext.info["reduced_chi2"]
