"""The plain cases kept (issue 28): records in the shapes test machines write, generated here by
laws written in this file (not matid's example generator), fitted back with seeded noise.

A short torsion tube leaves its linear range and passes a peak (the paper's Fig. 3): the torque
is ``E_t k`` up to an onset twist per length, then ``E_t (k - x^2 / (2 s))`` with x the excess,
which peaks at ``x = s`` and falls after it.
"""

from pathlib import Path

import numpy as np
import pytest

from matid.fits import branch
from matid.fits.shear.fit import fit_three_point_bend
from matid.fits.torsion import fit_torsion
from matid.model.measurement import Measurement, Table
from matid.model.results import Estimate
from matid.model.study import Specimen, Test

E_T = 4.4e-5  # N m^2
ONSET, SCALE = 60.0, 150.0  # rad/m: linear up to ONSET; the peak at ONSET + SCALE


def _past_peak_torsion(length: float, step_deg: float, seed: int, noise: float = 0.002):
    rng = np.random.default_rng(seed)
    phi = np.deg2rad(np.arange(0.0, 180.0 + 1e-9, step_deg))
    k = phi / length
    excess = np.maximum(k - ONSET, 0.0)
    torque = E_T * (k - excess**2 / (2.0 * SCALE))
    return phi, torque + rng.normal(0.0, noise * np.max(np.abs(torque)), phi.size)


def _slope(rec) -> float:
    return float(np.polyfit(rec.x[rec.used], rec.y[rec.used], 1)[0])


@pytest.mark.parametrize("step_deg", [2.0, 4.0, 5.0])
@pytest.mark.parametrize("seed", range(5))
def test_short_torsion_tube_past_its_peak_gives_E_t_within_1_percent(step_deg, seed):
    length = 0.012  # the peak at 2.52 rad (144 deg): the record passes it and falls
    phi, torque = _past_peak_torsion(length, step_deg, seed)
    rec = branch.automatic(branch.record("torsion.csv", phi, torque, np.ones(phi.size, dtype=bool)))
    assert _slope(rec) * length == pytest.approx(E_T, rel=0.01)
    # at 1.25 x the onset the torque is ~3 noise deviations below the line: such rows must be out
    assert not np.any(rec.used & (phi / length > ONSET * 1.25)), "rows past the onset entered the line"


def test_rows_past_the_peak_are_left_out_with_their_reason():
    phi, torque = _past_peak_torsion(0.012, 2.0, seed=0)
    rec = branch.automatic(branch.record("torsion.csv", phi, torque, np.ones(phi.size, dtype=bool)))
    past = rec.excluded[branch.PAST_PEAK]
    peak = np.deg2rad(144.0)
    assert past.any() and np.all(phi[past] > peak - np.deg2rad(10.0))


@pytest.mark.parametrize("seed", range(3))
def test_a_softening_plateau_without_a_fall_is_not_cut_as_a_peak(seed):
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 1.0, 120)
    y = np.minimum(x, 0.6) + rng.normal(0.0, 1e-3, x.size)  # flat after 0.6: no fall
    assert not branch.past_peak(x, y).any()


# --------------------------------------------------------------------------- torsion: tare, noise, holds


def _torsion_fit(pieces_phi, pieces_torque, length: float):
    """fit_torsion on one file of rows (twist angle [rad], torque [N m]) as ingest delivers them."""
    phi, torque = np.concatenate(pieces_phi), np.concatenate(pieces_torque)
    test = Test("torsion", "T1", Path("torsion.csv"), {"length": length})
    table = Table(Path("torsion.csv"), {"twist_angle": phi, "torque": torque}, {}, {}, "")
    return fit_torsion([Measurement(test, table)], specimen="T1").estimate("E_t")


TARE = 3e-4  # N m: the torque channel zeroed under a small preload


@pytest.mark.parametrize("seed", range(4))
def test_torsion_with_a_tare_noise_around_zero_before_the_twist_holds_and_an_unload(seed):
    """Tare offset; rows of either sign around zero before the twist starts; load, hold, unload
    to a third, hold, load again beyond: E_t back within 1 %."""
    rng = np.random.default_rng(seed)
    length, top = 0.06, np.deg2rad(90.0)
    sd = 0.002 * E_T * top / length

    def law(phi):
        return TARE + E_T * phi / length + rng.normal(0.0, sd, phi.size)

    rest = rng.normal(0.0, 0.002 * top, 25)  # the angle channel's scatter around zero
    legs = [
        rest,
        np.linspace(0.0, 0.6 * top, 40),
        np.full(30, 0.6 * top),  # hold
        np.linspace(0.6 * top, 0.2 * top, 25),  # unload
        np.full(20, 0.2 * top),  # hold
        np.linspace(0.2 * top, top, 50),  # reload beyond
    ]
    est = _torsion_fit(legs, [law(p) for p in legs], length)
    assert est.value == pytest.approx(E_T, rel=0.01)
    assert est.ci95[0] < E_T < est.ci95[1]


# --------------------------------------------------------------------------- three-point bend

# The bend law (Timoshenko, physics.md section 5) at deflections up to 3e-4 of the span, where
# the rod model the fit uses departs from it by under 0.1 % in force (tests/fits/shear/test_fit.py,
# test_small_deflection_limit_is_timoshenko: +0.27 % at 1e-3 of the span, linear in d).
E_B, E_S, SPAN = 6.5e-5, 21.0, 0.010
D_TOP = 3e-4 * SPAN


def _timoshenko(d):
    return d / (SPAN**3 / (48 * E_B) + SPAN / (4 * E_S))


def _bend_fit(d, force):
    test = Test(
        "three_point_bend",
        "T1",
        Path("3pb.csv"),
        {"span": SPAN, "specimen_length": 0.03, "support_radius": 2e-3, "nose_radius": 2e-3},
    )
    table = Table(Path("3pb.csv"), {"deflection": d, "force": force}, {}, {}, "")
    known = {
        "E_b": Estimate("E_b", E_B, 0.0, None, 0, "linear"),
        "E_e": Estimate("E_e", 120.0, 0.0, None, 0, "sls"),
    }
    return fit_three_point_bend(
        [Measurement(test, table)],
        specimen=Specimen("T1", 2.4e-3, 1.6e-3),
        known=known,
        local_compliance=(0.0, 0.0),
        model_form=0.0,
    )


def _noise(rng, n, scale):
    return rng.normal(0.0, 0.003 * scale, n)


@pytest.mark.parametrize("seed", range(3))
def test_bend_with_noise_of_either_sign_around_zero_before_contact(seed):
    """An MTS 793 export's first rows: crosshead and load cell scatter around zero, of either
    sign, before the nose touches; then the loading curve. Was a DataError ('negative deflection
    on the loading branch')."""
    rng = np.random.default_rng(seed)
    f_top = float(_timoshenko(D_TOP))
    # the crosshead comes from a few um on the wrong side of zero, scattering as it goes
    rest = np.linspace(-0.02 * D_TOP, 0.0, 20, endpoint=False) + rng.normal(0.0, 0.003 * D_TOP, 20)
    d = np.r_[rest, np.linspace(0.0, D_TOP, 40)]
    force = np.r_[np.zeros(rest.size), _timoshenko(d[rest.size :])] + _noise(rng, d.size, f_top)
    fit = _bend_fit(d, force)
    assert fit.estimate("E_s").value == pytest.approx(E_S, rel=0.01)
    below = d < 0
    assert below.any() and not np.any(fit.series[0].used & below), "rows before contact entered the fit"


@pytest.mark.parametrize("seed", range(3))
def test_bend_with_a_toe_before_contact(seed):
    """Slack: the nose travels a fifth of the record at nearly no force (a quadratic toe), then
    the curve from the contact deflection on."""
    rng = np.random.default_rng(seed)
    toe = 0.25 * D_TOP
    d = np.linspace(0.0, toe + D_TOP, 80)
    f_top = float(_timoshenko(D_TOP))
    loaded = _timoshenko(np.maximum(d - toe, 0.0)) + 0.02 * f_top
    clean = np.where(d < toe, 0.02 * f_top * (d / toe) ** 2, loaded)
    fit = _bend_fit(d, clean + _noise(rng, d.size, f_top))
    assert fit.estimate("E_s").value == pytest.approx(E_S, rel=0.01)


@pytest.mark.parametrize("seed", range(3))
def test_bend_past_yield(seed):
    """Linear to a yield deflection, then the force falls below the line (a plastic hinge) to a
    peak and drops after it: the rows past yield stay out."""
    rng = np.random.default_rng(seed)
    d_y = 0.5 * D_TOP
    d = np.linspace(0.0, 2.0 * D_TOP, 100)
    f_top = float(_timoshenko(D_TOP))
    past = np.maximum(d - d_y, 0.0)
    clean = _timoshenko(d) - f_top * (past / D_TOP) ** 2 * 1.5
    fit = _bend_fit(d, clean + _noise(rng, d.size, f_top))
    assert fit.estimate("E_s").value == pytest.approx(E_S, rel=0.01)


def test_torsion_reports_the_r2_of_its_line_and_labels_its_axis():
    """The report's "R² of the straight line" row and the plot's x axis of a torsion fit (the
    mutation sample of 2026-11-28 renamed the info key and dropped the label unseen): R² is
    1 - SS_res / SS_tot of numpy's line through the rows used, on a clean line every row."""
    rng = np.random.default_rng(3)
    L, E_t = 0.05, 4.4e-5
    phi = np.linspace(0.0, 0.5, 200)
    torque = E_t * phi / L + rng.normal(0.0, 2e-6, phi.size)
    test = Test("torsion", "T1", Path("torsion.csv"), {"length": L})
    table = Table(Path("torsion.csv"), {"twist_angle": phi, "torque": torque}, {}, {}, "")
    fit = fit_torsion([Measurement(test, table)], specimen="T1")
    assert fit.info["excluded_points"] == 0
    x = phi / L
    residual = torque - np.polyval(np.polyfit(x, torque, 1), x)
    r2 = 1.0 - float(residual @ residual) / float(((torque - torque.mean()) ** 2).sum())
    assert fit.info["r2"] == pytest.approx(r2, rel=1e-9)
    assert "twist" in fit.x_label and "[rad/m]" in fit.x_label


# A tip magnet in a uniform field bends the rod into a circular arc, so each row is the root of
# E_b theta / L = m B sin(psi - theta) (solved here by brentq, not by matid's line fit).
TIP_E_B, MOMENT, FREE = 1.0e-4, 0.0125, 0.030


def _tip_magnet_rows(psi_deg: float, seed: int, strongest_first: bool):
    import scipy.optimize

    psi = np.deg2rad(psi_deg)
    field = np.geomspace(9e-3, 0.4, 13)

    def balance(t, b):
        return TIP_E_B * t / FREE - MOMENT * b * np.sin(psi - t)

    theta = np.array([scipy.optimize.brentq(balance, 0.0, psi, args=(b,)) for b in field])
    theta = theta + np.random.default_rng(seed).normal(0.0, np.deg2rad(0.25), theta.size)  # read to 0.5 deg
    order = slice(None, None, -1) if strongest_first else slice(None)
    return field[order], theta[order]


def _bending_fit(field, field_angle, theta):
    from matid.fits.bending import fit_bending

    test = Test("magnetic_bending", "T1", Path("bend.csv"), {"free_length": FREE, "magnet_moment": MOMENT})
    columns = {"field": field, "field_angle": np.full(field.size, field_angle), "tip_angle": theta}
    return fit_bending([Measurement(test, Table(Path("bend.csv"), columns, {}, {}, ""))], specimen="T1")


@pytest.mark.parametrize("seed", range(3))
def test_tip_magnet_equilibria_give_E_b_in_either_order(seed):
    """A table of static equilibria (no time column) read weakest or strongest field first gives
    one E_b, unflipped. Over 200 seeds of this record (13 rows, angles read to 0.5 deg) the error
    has sd 0.71 % and stays within 3 %."""
    values = []
    for strongest_first in (False, True):
        field, theta = _tip_magnet_rows(90.0, seed, strongest_first)
        fit = _bending_fit(field, np.deg2rad(90.0), theta)
        assert not fit.info["sign_flipped"]
        values.append(fit.estimate("E_b").value)
    assert values[0] == pytest.approx(TIP_E_B, rel=0.03)
    assert values[1] == pytest.approx(values[0], rel=1e-9)


def test_a_computed_torque_that_falls_is_refused_not_negated():
    """field_angle written in the other sense than tip_angle: m B sin(psi - theta) then falls as
    the tip angle rises. No torque channel exists whose polarity could be flipped, so negating the
    computed torque (what a torque meter mounted the other way round would need) gives a stiffness
    of no physical meaning (here 1.5x the true one); the fit must refuse instead."""
    from matid.errors import FitError

    field, theta = _tip_magnet_rows(60.0, seed=0, strongest_first=False)
    with pytest.raises(FitError, match="does not rise with tip angle"):
        _bending_fit(field, np.deg2rad(-60.0), theta)


def test_tip_magnet_equilibria_interval_coverage():
    """The angle noise enters x and the computed torque together, and grows with the field: the
    95 % interval covered E_b in 157 of these 200 records (78.5 %) with one noise level, 179
    (89.5 %) with the HC3 floor of stats.heteroscedastic_floor; still short of 95 % (13 rows)."""
    hits = 0
    for seed in range(200):
        field, theta = _tip_magnet_rows(90.0, seed, strongest_first=False)
        lo, hi = _bending_fit(field, np.deg2rad(90.0), theta).estimate("E_b").ci95
        hits += lo <= TIP_E_B <= hi
    assert hits >= 170


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_torsion_warnings_name_its_line_and_E_t(seed):
    """The user-visible texts of two torsion fits (the mutation sample of 2026-11-28 upper-cased
    the one and dropped the name from the other unseen): noise that wanders (AR(1), r = 0.9, made
    by scipy's lfilter) gets the misfit warning naming the torsion line; a tube that softens with
    twist (torque ~ phi (1 - 0.3 phi)) the warning that E_t depends on the range fitted."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(seed)
    L, E_t = 0.05, 4.4e-5
    phi = np.linspace(0.0, 0.5, 200)
    test = Test("torsion", "T1", Path("torsion.csv"), {"length": L})

    def warnings(torque):
        table = Table(Path("torsion.csv"), {"twist_angle": phi, "torque": torque}, {}, {}, "")
        return fit_torsion([Measurement(test, table)], specimen="T1").estimate("E_t").warnings

    wanders = warnings(E_t * phi / L + lfilter([1.0], [1.0, -0.9], rng.normal(0.0, 2e-6, phi.size)))
    misfit = "the line torque = c + E_t phi / L does not describe the data within their noise"
    assert any(w.startswith(misfit) for w in wanders), wanders
    softens = warnings(E_t * phi / L * (1 - 0.3 * phi) + rng.normal(0.0, 2e-6, phi.size))
    assert any("; E_t depends on the range fitted: " in w for w in softens), softens
