"""Extension of a material that is not linear over the record (issue 28 item 5): a neo-Hookean
strip pulled to 36 % strain in ten load-unload cycles. E_e, a mean over the strain range, has
an interval that spans the record's elastic tangents and a warning that states the range.

The force is the neo-Hookean law written here, F = mu A (lambda - lambda^-2), lambda = 1 + eps
(hyperelastic: no relaxation), whose tangent mu A (1 + 2 lambda^-3) falls from 3 mu A at small
strain to 1.8 mu A at 36 %; not matid's SLS.
"""

from __future__ import annotations

import numpy as np

from matid.app.pipeline import run_study
from matid.io.study import load_study
from tests.fits.extension.relaxation import write_bluehill

MU_A = 9.2  # N: small-strain tangent 27.6 N
PEAK, RATE, CYCLES, DT, GAUGE = 0.36, 0.01, 10, 0.1, 0.05


def tangent(eps):
    return MU_A * (1.0 + 2.0 / (1.0 + eps) ** 3)


def test_e_e_of_a_neo_hookean_strip_spans_its_tangents_and_says_so(tmp_path):
    period = 2.0 * PEAK / RATE
    t = np.arange(int(CYCLES * period / DT) + 1) * DT
    phase = np.mod(t, period) / period
    eps = PEAK * (1.0 - np.abs(1.0 - 2.0 * phase))  # triangle wave 0 -> PEAK -> 0
    lam = 1.0 + eps
    force = MU_A * (lam - lam**-2) + np.random.default_rng(5).normal(0.0, 0.02, t.size)
    write_bluehill(tmp_path / "strip.csv", t, eps * GAUGE, force)
    (tmp_path / "study.toml").write_text(
        '[study]\nname = "neo-Hookean strip"\n\n[[specimen]]\nid = "S1"\nwidth = "10 mm"\n'
        'height = "1 mm"\n\n[[test]]\nkind = "extension"\nspecimen = "S1"\nfile = "strip.csv"\n'
        'gauge_length = "50 mm"\ncolumns = { time = "Time", elongation = "Extension", force = "Load" }\n',
        encoding="utf-8",
    )
    (fit,) = run_study(load_study(tmp_path / "study.toml")).fits
    e_e = next(e for e in fit.estimates if e.parameter == "E_e")
    low, high = e_e.ci95
    assert low <= tangent(0.30) and high >= tangent(0.03), (e_e.value, e_e.ci95)
    assert high - low > 0.3 * (tangent(0.0) - tangent(PEAK))
    (warning,) = [w for w in e_e.warnings if "not linear in strain" in w]
    assert "strain 0" in warning and "0.35" in warning
