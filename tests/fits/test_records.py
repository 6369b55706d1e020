"""Records of any shape (docs/contract.md section 10), read from machine-style exports.

Each record of tests/fits/test_records_corpus.py goes through ``matid.fit`` with a
study.toml written around the file as a lab engineer would; its value is compared with
a hand value computed here from the file's numbers, read with the standard library
(a textbook formula, or a slope over a range chosen from the known generating law).
"""

from __future__ import annotations

import csv
import math
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import matid
from matid.errors import DataError
from matid.fits.branch import HOLD_ROWS
from matid.fits.shear import window as bend_window
from matid.fits.shear.fit import bend_data
from matid.fits.torsion import fit_torsion
from matid.io.ingest.read import read_table
from matid.model import study as study_mod
from matid.model.measurement import Measurement, Table
from tests.fits.test_records_corpus import CORPUS, RECORDS


def slope(x: np.ndarray, y: np.ndarray) -> float:
    """Least-squares slope of y = c + a x, by the normal equations."""
    xm, ym = x.mean(), y.mean()
    return float(np.sum((x - xm) * (y - ym)) / np.sum((x - xm) ** 2))


def columns(path: Path, skip: int, delimiter: str, picks: list[int]) -> np.ndarray:
    """The numeric columns ``picks`` of the rows after ``skip`` lines, by the csv module."""
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle, delimiter=delimiter))[skip:]
    return np.array([[float(row[k]) for k in picks] for row in rows if row and row[0].strip()])


def study(tmp_path: Path, name: str, specimen: str, test: str) -> Path:
    shutil.copy(CORPUS / name, tmp_path / name)
    (tmp_path / "study.toml").write_text(
        f'[study]\nname = "records"\n\n[[specimen]]\nid = "T1"\n{specimen}\n\n[[test]]\nspecimen = "T1"\n'
        f'file = "{name}"\n{test}\n',
        encoding="utf-8",
    )
    return tmp_path / "study.toml"


def fitted(path: Path, kind: str):
    start = time.perf_counter()
    result = matid.fit(path)
    wall = time.perf_counter() - start
    (fit,) = [f for f in result.study_result.fits if f.kind == kind]
    return fit, wall


def report(name: str, value: float, hand: float, fit, wall: float) -> None:
    """One line of the numbers the issue asks for (shown with pytest -s)."""
    used = sum(int(s.used.sum()) for s in fit.series)
    total = sum(s.x.size for s in fit.series)
    print(
        f"\n{name}: matid {value:.5g} hand {hand:.5g} ({100 * (value / hand - 1):+.2f} %), "
        f"rows {used}/{total}, {wall:.2f} s"
    )


def within_two_percent(tmp_path: Path, name: str, specimen: str, test: str, parameter: str, hand: float):
    """Fit corpus record ``name`` through matid fit's pipeline, print the issue's numbers, and
    check the value against ``hand``: within 2 %. Returns (fit, estimate)."""
    kind = re.search(r'kind = "(\w+)"', test).group(1)
    fit, wall = fitted(study(tmp_path, name, specimen, test), kind)
    est = fit.estimate(parameter)
    report(name, est.value, hand, fit, wall)
    assert est.value == pytest.approx(hand, rel=0.02)
    return fit, est


def test_corpus_copies_are_the_generators_output():
    for name, make in RECORDS.items():
        assert (CORPUS / name).read_bytes() == make()[0].encode("utf-8"), name


LVM = "lvm_load_return_torsion.lvm"
LVM_HEADER = 22  # lines before the numbers (file header, segment header, channel names)


def test_load_return_torsion_with_tare():
    """LVM: rest at a tare, load to 60 deg (softening past 40), hold, return with backlash.
    The columns are read here (ingest's header detection is tested below); the fit is matid's."""
    _, law = RECORDS[LVM]()
    data = columns(CORPUS / LVM, LVM_HEADER, "\t", [1, 2])  # angle [deg], torque [N mm]
    angle, torque = data[:, 0], data[:, 1]
    rise = np.arange(angle.size) <= int(np.argmax(angle))  # the loading branch, by hand
    lo, hi = law.hand_range
    pick = rise & (angle >= lo) & (angle <= hi)
    hand = slope(np.radians(angle[pick]) / law.length, torque[pick] * 1e-3)  # E_t = d tau / d(phi / L)
    test = study_mod.Test("torsion", "T1", Path(LVM), {"length": law.length})
    table = Table(Path(LVM), {"twist_angle": np.radians(angle), "torque": torque * 1e-3}, {}, {}, "")
    start = time.perf_counter()
    fit = fit_torsion([Measurement(test, table)], specimen="T1")
    wall = time.perf_counter() - start
    est = fit.estimate("E_t")
    report(LVM, est.value, hand, fit, wall)
    assert est.value == pytest.approx(hand, rel=0.02)
    assert est.ci95[0] < law.stiffness < est.ci95[1]
    left = fit.info["left_out"][LVM]
    assert left["unloading (x moves back towards its start)"] >= 250  # the return
    assert left["hold (x constant)"] >= 200  # the rest and the hold at 60 deg
    assert fit.info["fitted_x_range"][LVM][1] < math.radians(48.0) / law.length  # not the softened part
    rest = torque[: int(np.argmax(angle > 0))] * 1e-3  # the rows at rest before the twist: the tare
    marginal = law.extra["noise_N_m"] / math.sqrt(1 - law.extra["phi"] ** 2)  # AR(1) noise's sd
    assert abs(est.extra["tare_offset_N_m"][LVM] - rest.mean()) < 3 * marginal
    assert est.n_points >= 300


def test_load_return_torsion_lvm_reads_through_matid(tmp_path):
    """The LabVIEW Measurement File layout of NI's specification (a segment header of
    Channels, Samples, Date, Time, X_Dimension, X0, Delta_X before the channel names), read
    and fitted by matid fit's pipeline: the same value as the fit of the hand-read columns."""
    path = study(
        tmp_path,
        LVM,
        'outer_diameter = "2.4 mm"\ninner_diameter = "1.6 mm"',
        'kind = "torsion"\nlength = "50 mm"\ncolumns = { twist_angle = "Angle", torque = "Torque" }',
    )
    _, law = RECORDS[LVM]()
    fit, _ = fitted(path, "torsion")
    assert fit.series[0].x.size == law.extra["rows"]
    data = columns(CORPUS / LVM, LVM_HEADER, "\t", [1, 2])  # angle [deg], torque [N mm]
    test = study_mod.Test("torsion", "T1", Path(LVM), {"length": law.length})
    table = Table(Path(LVM), {"twist_angle": np.radians(data[:, 0]), "torque": data[:, 1] * 1e-3}, {}, {}, "")
    by_hand = fit_torsion([Measurement(test, table)], specimen="T1").estimate("E_t").value
    assert fit.estimate("E_t").value == pytest.approx(by_hand, rel=1e-9)


def test_torsion_from_an_absolute_start_angle(tmp_path):
    """MTS: an encoder at 48 deg, a negative torque tare, stiffening past 90 deg, a partial return."""
    name = "mts_absolute_angle_torsion.txt"
    _, law = RECORDS[name]()
    data = columns(CORPUS / name, 6, "\t", [1, 2])  # angle [deg], torque [N m]
    angle, torque = data[:, 0], data[:, 1]
    rise = np.arange(angle.size) <= int(np.argmax(angle))
    lo, hi = law.hand_range
    pick = rise & (angle >= lo) & (angle <= hi)
    hand = slope(np.radians(angle[pick]) / law.length, torque[pick])
    fit, est = within_two_percent(
        tmp_path,
        name,
        'outer_diameter = "3 mm"\ninner_diameter = "2 mm"',
        'kind = "torsion"\nlength = "80 mm"\n'
        'columns = { twist_angle = "Rotary Position", torque = "Torque" }',
        "E_t",
        hand,
    )
    assert "sign_flipped" not in est.extra["warning_kinds"]  # an angle offset is not a sign error
    x_lo, x_hi = fit.info["fitted_x_range"][name]
    assert x_lo < math.radians(law.extra["start_deg"] + 5.0) / law.length  # from the start ...
    assert x_hi < math.radians(law.extra["start_deg"] + 48.0) / law.length  # ... not into the stiffening
    assert fit.info["left_out"][name]["unloading (x moves back towards its start)"] >= 650


def test_magnetic_bending_with_a_hold(tmp_path):
    """testXpert: field ramp to 30 mT, 20 s hold with creep, ramp down; E_b by the torque balance."""
    name = "testxpert_magnetic_hold.txt"
    _, law = RECORDS[name]()
    data = columns(CORPUS / name, 6, "\t", [1, 2, 3])  # field [mT], psi [deg], theta [deg]
    field, psi, theta = data[:, 0] * 1e-3, np.radians(data[:, 1]), np.radians(data[:, 2])
    m = law.extra["moment_A_m2"]
    ramp = np.arange(field.size) < 300  # the ramp up, by hand (the generator's first 300 rows)
    lo, hi = law.hand_range
    pick = ramp & (data[:, 0] >= lo) & (data[:, 0] <= hi)
    torque = m * field * np.sin(psi - theta)  # tau = m B sin(psi - theta)
    hand = slope(theta[pick] / law.length, torque[pick])
    fit, est = within_two_percent(
        tmp_path,
        name,
        'outer_diameter = "2.4 mm"\ninner_diameter = "1.6 mm"',
        'kind = "magnetic_bending"\nfree_length = "30 mm"\nmagnet_moment = "0.0125 A m^2"\n'
        'columns = { field = "Field", field_angle = "Field angle", tip_angle = "Tip angle" }',
        "E_b",
        hand,
    )
    assert est.value == pytest.approx(law.stiffness, rel=0.02)
    on_hold = np.zeros(law.extra["rows"], dtype=bool)
    on_hold[300:700] = True  # the generator's hold (20 s at 30 mT)
    used = fit.series[0].used
    assert (used & on_hold).sum() <= 0.1 * on_hold.sum()  # the hold is left out ...
    assert not used[700:].any()  # ... and so is the return
    reasons = set(fit.info["left_out"][name])
    assert {"hold (x constant)", "held load (y constant while x creeps)"} <= reasons


def test_flexural_coupon_past_yield_with_rows_before_contact():
    """Bluehill: crosshead travel before contact, a line, yield from 1.3 mm, peak and break.
    The cut of the bend (toe zero, yield) against the law: D790's zero (the gap) and the
    slope over a hand range, and the flexural modulus E = S^3 m / (4 b h^3) of ASTM D790."""
    name = "bluehill_flexural_yield.csv"
    _, law = RECORDS[name]()
    data = columns(CORPUS / name, 8, ",", [1, 2])  # extension [mm], load [N]
    d, F = data[:, 0] * 1e-3, data[:, 1]
    lo, hi = law.hand_range
    pick = (data[:, 0] >= lo) & (data[:, 0] <= hi)
    hand = slope(d[pick], F[pick])
    table = read_table(
        CORPUS / name, "three_point_bend", columns={"deflection": "Extension", "force": "Load"}
    )
    start = time.perf_counter()
    c = bend_window.cut(table["deflection"], table["force"], np.ones(table.n_rows, dtype=bool))
    wall = time.perf_counter() - start
    used_d, used_F = table["deflection"][c.used], table["force"][c.used]
    value = slope(used_d, used_F)
    S, b, h = law.length, law.extra["width_m"], law.extra["height_m"]
    E_hand, E = S**3 * hand / (4 * b * h**3), S**3 * value / (4 * b * h**3)
    print(
        f"\n{name}: matid E {E / 1e9:.4g} GPa hand {E_hand / 1e9:.4g} GPa ({100 * (E / E_hand - 1):+.2f} %), "
        f"rows {int(c.used.sum())}/{c.used.size}, {wall:.3f} s"
    )
    assert E == pytest.approx(E_hand, rel=0.02)
    assert c.d0 == pytest.approx(law.extra["gap_m"], rel=0.05)
    assert used_d.max() <= law.extra["yield_m"] + 0.1e-3  # nothing far past yield
    assert any(r.startswith("past yield") for r in c.reasons)
    assert any(r.startswith("toe") for r in c.reasons)


# --------------------------------------------------------------------------- windows and checks


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def load_return(n_up: int = 200, n_down: int = 150, *, tare: float = 2e-3, seed: int = 5):
    """Twist 0 -> 1 rad and back on a 50 mm tube, unloading stiffer (hysteresis), N m."""
    E_t, L = 1.5e-4, 0.05
    up, down = np.linspace(0.0, 1.0, n_up), np.linspace(1.0, 0.2, n_down)
    top = E_t * 1.0 / L
    torque = np.r_[E_t * up / L, top - 1.4 * E_t * (1.0 - down) / L] + tare
    torque = torque + 2e-6 * np.random.default_rng(seed).normal(size=torque.size)
    return np.r_[up, down], torque, E_t, L


def test_window_replaces_the_automatic_range(tmp_path):
    """Issue 21: the window was cut again by the automatic range (-34 %, or E_t <= 0). Now
    exactly the window's rows are fitted, here the whole record up to the turn."""
    phi, torque, E_t, L = load_return()
    text = "Angle (rad),Torque (N m)\n" + "".join(
        f"{a:.6f},{q:.8f}\n" for a, q in zip(phi, torque, strict=True)
    )
    path = write(tmp_path, "w.csv", text)
    table = read_table(path, "torsion", columns={"twist_angle": "Angle", "torque": "Torque"})
    window = {"twist_angle": (0.3, 1.0)}
    test = study_mod.Test("torsion", "T1", Path("w.csv"), {"length": L}, window=window)
    fit = fit_torsion([Measurement(test, table)], specimen="T1")
    inside = (phi >= 0.3) & (phi <= 1.0)
    assert np.array_equal(fit.series[0].used, inside)  # the unloading rows inside the window too
    assert fit.info["left_out"] == {"w.csv": {"outside the window": int((~inside).sum())}}
    # without the window the loading branch alone is fitted, unloading left out with its reason
    plain = study_mod.Test("torsion", "T1", Path("w.csv"), {"length": L})
    auto = fit_torsion([Measurement(plain, table)], specimen="T1")
    assert auto.estimate("E_t").value == pytest.approx(E_t, rel=0.01)
    assert auto.info["left_out"]["w.csv"]["unloading (x moves back towards its start)"] >= 140


def test_window_with_too_few_rows_names_it():
    phi, torque, _, L = load_return()
    test = study_mod.Test(
        "torsion", "T1", Path("few.csv"), {"length": L}, window={"twist_angle": (0.5, 0.51)}
    )
    table = Table(Path("few.csv"), {"twist_angle": phi, "torque": torque}, {}, {}, "")
    with pytest.raises(
        DataError, match=r"few.csv.*window \{twist_angle = \[0.5, 0.51\]\} \(SI\) holds \d rows"
    ):
        fit_torsion([Measurement(test, table)], specimen="T1")


def test_an_angle_offset_is_not_a_sign_error(tmp_path):
    """An absolute encoder reading -90 .. -30 deg while the torque rises from 0: torque and angle
    have opposite signs on every row, which the reader took for a sign error (exit 2)."""
    angle = np.linspace(-90.0, -30.0, 120)
    torque = 1.5e-4 * np.radians(angle + 90.0) / 0.05 * 1e3  # N mm
    text = "Angle (deg),Torque (N mm)\n" + "".join(
        f"{a:.4f},{q:.6f}\n" for a, q in zip(angle, torque, strict=True)
    )
    path = write(tmp_path, "abs.csv", text)
    table = read_table(path, "torsion", columns={"twist_angle": "Angle", "torque": "Torque"})
    test = study_mod.Test("torsion", "T1", Path("abs.csv"), {"length": 0.05})
    est = fit_torsion([Measurement(test, table)], specimen="T1").estimate("E_t")
    assert est.value == pytest.approx(1.5e-4, rel=1e-3)
    assert "sign_flipped" not in est.extra["warning_kinds"]


def test_bend_window_excludes_rows_before_contact(tmp_path):
    """Rows before contact at negative crosshead travel: the reader rejected the file although
    its message recommended a window; now the window is honoured and the check runs on the rows
    fitted, where a negative deflection is still an error."""
    d = np.linspace(-0.2, 1.0, 61)  # mm
    F = np.clip(d, 0.0, None) * 2.0  # N
    path = write(
        tmp_path,
        "pre.csv",
        "deflection [mm],force [N]\n" + "".join(f"{a:.4f},{f:.5f}\n" for a, f in zip(d, F, strict=True)),
    )
    table = read_table(path, "three_point_bend")
    rig = {"span": 0.03, "specimen_length": 0.04, "support_radius": 2e-3, "nose_radius": 2e-3}
    specimen = study_mod.Specimen("T1", 2.4e-3, 1.6e-3)

    def data(window):
        test = study_mod.Test("three_point_bend", "T1", path, rig, window=window)
        return bend_data(Measurement(test, table), specimen, 1e-3)

    b = data({"deflection": (0.05e-3, 1.0e-3)})
    assert np.array_equal(b.loading, (d >= 0.05) & (d <= 1.0)) and b.cut.d0 == 0.0
    with pytest.raises(DataError, match="pre.csv.*negative deflection"):
        data({"deflection": (-0.1e-3, 1.0e-3)})


@settings(max_examples=30, deadline=None)
@given(
    start=st.floats(-2.0, 2.0),
    direction=st.sampled_from([1.0, -1.0]),
    tare=st.floats(-0.5, 0.5),
    hold=st.integers(0, 120),
    back=st.floats(0.0, 1.0),
    onset=st.floats(0.5, 1.0),
    seed=st.integers(0, 2**16),
)
def test_any_start_direction_tare_hold_and_return(start, direction, tare, hold, back, onset, seed):
    """A twist from any absolute angle in either direction, a tare, a hold at the top, a return
    of any depth, softening past ``onset`` of the twist: E_t within 1 %, no row of the return
    fitted, nor of a hold long enough to be one."""
    E_t, L, turn = 1.5e-4, 0.05, 1.0
    up = np.linspace(0.0, turn, 200)
    down = np.linspace(turn, turn * (1.0 - back), max(int(150 * back), 1))
    twist = np.r_[up, np.full(hold, turn), down]

    def law(t):
        excess = np.clip(t - onset * turn, 0.0, None)
        return E_t * (t - excess**2 / (2 * (1 - onset * turn) + 1e-9) * 0.5) / L

    top = law(turn)
    torque = np.r_[law(up), np.full(hold, top), top - 1.3 * E_t * (turn - down) / L]
    full = E_t * turn / L
    torque = direction * (torque + tare * full) + 1e-3 * full * np.random.default_rng(seed).normal(
        size=twist.size
    )
    angle = start + direction * twist
    test = study_mod.Test("torsion", "T1", Path("h.csv"), {"length": L})
    table = Table(Path("h.csv"), {"twist_angle": angle, "torque": torque}, {}, {}, "")
    fit = fit_torsion([Measurement(test, table)], specimen="T1")
    assert fit.estimate("E_t").value == pytest.approx(E_t, rel=0.01)
    used = fit.series[0].used
    assert not used[200 + hold + 1 :].any()  # the return
    if hold >= HOLD_ROWS:
        assert not used[200:].any()  # the hold


def test_warnings_carry_their_kind():
    """Each warning of a line fit has a machine-readable kind, in the order of the texts."""
    phi, torque, _, L = load_return(n_up=200, n_down=0)
    window = {"twist_angle": (0.5, 0.535)}  # 7 rows, torque recorded with the other sign
    test = study_mod.Test("torsion", "T1", Path("k.csv"), {"length": L}, window=window)
    table = Table(Path("k.csv"), {"twist_angle": phi[:200], "torque": -torque[:200]}, {}, {}, "")
    est = fit_torsion([Measurement(test, table)], specimen="T1").estimate("E_t")
    assert len(est.warnings) == len(est.extra["warning_kinds"])
    assert est.extra["warning_kinds"][0] == "sign_flipped"
    assert est.extra["fitted_rows"] == {"k.csv": 7}
