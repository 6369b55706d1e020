"""Records as test machines and loggers write them, from a known law (not matid's writer).

Each generator returns the file's text and the law it was drawn from; tests/corpus/
holds one copy of each (``python -m tests.fits.test_records_corpus`` rewrites them, and
tests/fits/test_records.py checks the copies equal the generators' output). Artefacts
real tests have: a tare offset, holds, a return with backlash, quantisation of the
channels, AR(1) noise, rows before contact, yield.

Layouts, from the vendors' documentation of their exports:
- LabVIEW LVM (Write To Measurement File): a header block of ``key<TAB>value`` lines
  closed by ``***End_of_Header***``, a per-channel block, then ``X_Value`` and the
  channel names, tab-separated, and a trailing ``Comment`` column.
- MTS TestSuite text export: ``name:<TAB>value`` run lines, then a header of the
  signal names over a row of units, tab-separated.
- Instron Bluehill CSV: ``"key:","value"`` lines, a blank line, quoted names over
  quoted units in parentheses, every number quoted.
- ZwickRoell testXpert II TXT export: a few header lines, tab-separated names over
  units in brackets, decimal points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from matid.fits.stats import ar1_noise
from tests import TESTS

CORPUS = TESTS / "corpus"


@dataclass(frozen=True)
class Law:
    """What a record was drawn from (SI): its stiffness and the range a hand slope may use."""

    stiffness: float  # E_t or E_b [N m^2], or the flexural slope dF/dd [N/m]
    length: float  # torsion length or free length [m]; the span for the flexural coupon
    hand_range: tuple[float, float]  # x range (file units) where the law is a line by construction
    extra: dict


def _quantise(v: np.ndarray, q: float) -> np.ndarray:
    return np.round(v / q) * q


def load_return_torsion(seed: int = 21) -> tuple[str, Law]:
    """LVM: rest at a tare, twist 0 -> 60 deg (softening past 40 deg), hold 2 s, return with backlash."""
    rng = np.random.default_rng(seed)
    E_t, L, tare = 1.5e-4, 0.05, 0.12e-3  # N m^2, m, N m
    rest = np.zeros(50)
    up = np.linspace(0.0, 60.0, 600)
    hold = np.full(200, 60.0)
    down = np.linspace(60.0, 0.0, 293)
    angle = np.r_[rest, up, hold, down]

    def loading(a):
        phi, excess = np.radians(a), np.radians(np.clip(a - 40.0, 0.0, None))
        return E_t * phi / L - 0.6 * E_t * excess**2 / L / np.radians(20.0)

    peak = loading(60.0)
    backlash = 1.5  # deg of return before the torque follows
    ret = peak - E_t * np.radians(np.clip(60.0 - down - backlash, 0.0, None)) / L * 1.1
    torque = np.r_[
        loading(rest), loading(up), np.full(hold.size, peak) * (1 - 0.01 * np.linspace(0, 1, 200)), ret
    ]
    noise, phi = 4e-6, 0.9
    torque = torque + tare + noise * ar1_noise(rng, torque.size, phi)
    n = angle.size
    time = 0.01 * np.arange(n)
    head = [
        "LabVIEW Measurement\t",
        "Writer_Version\t2",
        "Reader_Version\t2",
        "Separator\tTab",
        "Decimal_Separator\t.",
        "Multi_Headings\tNo",
        "X_Columns\tOne",
        "Time_Pref\tRelative",
        "Operator\ttorsion rig 2",
        "Date\t2024/05/02",
        "Time\t10:14:05.1234",
        "***End_of_Header***\t",
        "\t",
        "Channels\t2\t",
        f"Samples\t{n}\t{n}\t",
        "Date\t2024/05/02\t2024/05/02\t",
        "Time\t10:14:05.1234\t10:14:05.1234\t",
        "X_Dimension\tTime\tTime\t",
        "X0\t0.0000000000000000E+0\t0.0000000000000000E+0\t",
        "Delta_X\t0.010000\t0.010000\t",
        "***End_of_Header***\t",
        "X_Value\tAngle (deg)\tTorque (N mm)\tComment",
    ]
    rows = [
        f"{t:.6f}\t{a:.2f}\t{q:.3f}\t"
        for t, a, q in zip(time, _quantise(angle, 0.01), _quantise(torque * 1e3, 0.001), strict=True)
    ]
    law = Law(E_t, L, (5.0, 35.0), {"tare_N_m": tare, "rows": n, "noise_N_m": noise, "phi": phi})
    return "\r\n".join(head + rows) + "\r\n", law


def absolute_angle_torsion(seed: int = 48) -> tuple[str, Law]:
    """MTS TestSuite TXT: an absolute rotary encoder at 48 deg, twist to 108 deg (stiffening
    past 90), negative torque tare, return to 80 deg."""
    rng = np.random.default_rng(seed)
    E_t, L, tare, start = 2.2e-4, 0.08, -0.35e-3, 48.0
    up = np.linspace(start, start + 60.0, 1500)
    down = np.linspace(start + 60.0, start + 32.0, 700)
    stiff = 0.8

    def law(a):
        phi = np.radians(a - start)
        excess = np.radians(np.clip(a - start - 42.0, 0.0, None))
        return E_t * phi / L + stiff * E_t * excess**2 / L / np.radians(18.0)

    top = law(up[-1])
    angle = np.r_[up, down]
    torque = np.r_[law(up), top - 1.05 * E_t * np.radians(up[-1] - down) / L] + tare
    torque = torque + 6e-6 * ar1_noise(rng, angle.size, 0.7)
    angle = angle + rng.normal(0.0, 0.004, angle.size)
    time = 0.05 * np.arange(angle.size)
    head = [
        "Test Run Name:\tSpecimen 3 torsion",
        "Station Name:\tAxial-Torsional 858",
        "Test Definition:\ttube_torsion.tst",
        "",
        "Time\tRotary Position\tTorque",
        "sec\tdeg\tN-m",
    ]
    rows = [
        f"{t:.3f}\t{a:.4f}\t{q:.7f}"
        for t, a, q in zip(time, _quantise(angle, 0.0005), _quantise(torque, 1e-7), strict=True)
    ]
    law_ = Law(
        E_t, L, (start + 2.0, start + 38.0), {"tare_N_m": tare, "start_deg": start, "rows": angle.size}
    )
    return "\n".join(head + rows) + "\n", law_


def flexural_coupon(seed: int = 790) -> tuple[str, Law]:
    """Bluehill CSV: crosshead travel before contact, a linear rise, yield past 1.3 mm, peak, break."""
    rng = np.random.default_rng(seed)
    slope, gap, d_y = 52.0e3, 0.3e-3, 1.3e-3  # N/m, m, m
    d = np.linspace(0.0, 2.6e-3, 521)
    s = np.clip(d - gap, 0.0, None)
    F = slope * s
    past = np.clip(d - d_y, 0.0, None)
    F = F - 0.5 * slope * past**2 / 0.4e-3  # a plastic hinge: the slope falls to 0 at 1.7 mm
    peak = int(np.argmax(F))
    F[peak + 1 :] = F[peak] * np.exp(-(d[peak + 1 :] - d[peak]) / 0.05e-3)  # break
    F = F + 0.004 * rng.normal(size=d.size)
    time = d / (2.0e-3 / 60.0)
    head = [
        '"Sample ID:","PLA-flex-2"',
        '"Method:","ASTM D790 Procedure A.im_flex"',
        '"Span:","40 mm"',
        '"Width:","10 mm"',
        '"Thickness:","4 mm"',
        "",
        '"Time","Extension","Load"',
        '"(s)","(mm)","(N)"',
    ]
    rows = [
        f'"{t:.5f}","{x:.5f}","{f:.3f}"'
        for t, x, f in zip(time, _quantise(d * 1e3, 1e-5), _quantise(F, 1e-3), strict=True)
    ]
    law = Law(slope, 0.040, (0.4, 1.2), {"gap_m": gap, "yield_m": d_y, "width_m": 0.010, "height_m": 0.004})
    return "\r\n".join(head + rows) + "\r\n", law


def tip_angle(c: float, psi: float) -> float:
    """theta = c sin(psi - theta) (c = m B L / E_b) by Newton from theta = 0."""
    theta = 0.0
    for _ in range(50):
        g = theta - c * math.sin(psi - theta)
        theta -= g / (1.0 + c * math.cos(psi - theta))
    return theta


def magnetic_hold(seed: int = 30) -> tuple[str, Law]:
    """testXpert TXT: field ramp 0 -> 30 mT at 90 deg, a 20 s hold (tip creeps 2 %), ramp down."""
    rng = np.random.default_rng(seed)
    E_b, L, m = 6.5e-5, 0.03, 0.0125  # N m^2, m, A m^2
    field = np.r_[np.linspace(0.0, 0.030, 300), np.full(400, 0.030), np.linspace(0.030, 0.0, 300)]
    creep = np.r_[np.zeros(300), 0.02 * (1 - np.exp(-np.arange(400) / 80.0)), np.zeros(300)]
    theta = np.array([tip_angle(m * b * L / E_b, math.pi / 2) for b in field]) * (1 + creep)
    theta[700:] = theta[700:] + (theta[699] - theta[700]) * np.linspace(1, 0, 300)  # creep recovers
    theta = theta + np.radians(0.05) * ar1_noise(rng, theta.size, 0.5)
    time = 0.05 * np.arange(field.size)
    head = [
        "testXpert II  export",
        "Test program:\tmagnetic cantilever",
        "Specimen:\tT1 L30",
        "",
        "Time\tField\tField angle\tTip angle",
        "[s]\t[mT]\t[deg]\t[deg]",
    ]
    rows = [
        f"{t:.2f}\t{b:.3f}\t90.0\t{a:.3f}"
        for t, b, a in zip(time, _quantise(field * 1e3, 0.005), np.degrees(theta), strict=True)
    ]
    law = Law(E_b, L, (2.0, 25.0), {"moment_A_m2": m, "rows": field.size})
    return "\n".join(head + rows) + "\n", law


#: file name -> generator
RECORDS = {
    "lvm_load_return_torsion.lvm": load_return_torsion,
    "mts_absolute_angle_torsion.txt": absolute_angle_torsion,
    "bluehill_flexural_yield.csv": flexural_coupon,
    "testxpert_magnetic_hold.txt": magnetic_hold,
}


def main() -> None:
    for name, make in RECORDS.items():
        text, _ = make()
        (CORPUS / name).write_bytes(text.encode("utf-8"))


if __name__ == "__main__":
    main()
