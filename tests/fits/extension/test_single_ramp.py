"""A single tensile ramp to failure from a preload (issue 28 item 2: an MTS TestSuite record that
starts at 145 N, E_e -14.6 % with an interval excluding the hand value).

The force is a law written here, with no relaxation: a preload F0 and an elastic curve whose
tangent falls with strain, F = F0 + K eps (1 - eps / (2 EPS_S)), pulled at one rate. A single
ramp cannot tell this bend from relaxation: the SLS's Maxwell arm takes it and E_e lands low.
The hand value is the least-squares line over the test's window, computed here.
"""

from __future__ import annotations

import numpy as np

from matid.app.pipeline import run_study
from matid.io.study import load_study
from tests.fits.extension.relaxation import write_bluehill

K, EPS_S, F0, GAUGE, RATE, DT = 2.4e4, 0.06, 145.0, 0.033, 2.5e-4, 0.1


def test_a_single_ramp_that_bends_has_an_interval_spanning_its_tangents(tmp_path):
    t = np.arange(0.0, 0.05 / RATE, DT)
    eps = RATE * t
    force = F0 + K * eps * (1.0 - eps / (2.0 * EPS_S)) + np.random.default_rng(3).normal(0.0, 0.5, t.size)
    write_bluehill(tmp_path / "ramp.csv", t, eps * GAUGE, force)
    (tmp_path / "study.toml").write_text(
        '[study]\nname = "ramp"\n\n[[specimen]]\nid = "S1"\nwidth = "7 mm"\nheight = "3 mm"\n\n'
        '[[test]]\nkind = "extension"\nspecimen = "S1"\nfile = "ramp.csv"\ngauge_length = "33 mm"\n'
        'columns = { time = "Time", elongation = "Extension", force = "Load" }\n'
        'window = { elongation = ["0.3 mm", "0.8 mm"] }\n',
        encoding="utf-8",
    )
    inside = (eps * GAUGE >= 0.3e-3) & (eps * GAUGE <= 0.8e-3)
    hand = float(np.polyfit(eps[inside], force[inside], 1)[0])
    (fit,) = run_study(load_study(tmp_path / "study.toml")).fits
    e_e = next(e for e in fit.estimates if e.parameter == "E_e")
    assert e_e.ci95[0] <= hand <= e_e.ci95[1], (e_e.value, e_e.ci95, hand)
    (warning,) = [w for w in e_e.warnings if "single ramp" in w]
    assert "window on strain" in warning
