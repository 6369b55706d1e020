"""Experiment design for E_s (matid.fits.design), checked against the tube3d continuum tube."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from matid.app.cli import main
from matid.fits import design
from matid.fits.shear import fit as shear
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.model.results import Estimate
from tests import TESTS

TUBE = study.Specimen("T", 2.4e-3, 1.6e-3)
E_B, E_E, KGA = 6.5345e-5, 125.66, 27.17
DATA = TESTS / "data" / "tube3d"


def nose_fit(span_mm: int) -> float:
    """E_s the rod model returns from the continuum tube's nose travel (biased by the contacts)."""
    rows = json.loads((DATA / f"T{span_mm}.json").read_text())["rows"]
    d = np.r_[0.0, [r["delta"] for r in rows]] * 1e-3
    F = np.r_[0.0, [r["F"] for r in rows]]
    params = {"span": span_mm * 1e-3, "specimen_length": span_mm * 1e-3 + 8e-3}
    params |= {"support_radius": 2e-3, "nose_radius": 2e-3}
    test = study.Test("three_point_bend", "T", Path("n.csv"), params)
    known = {
        "E_b": Estimate("E_b", E_B, 0.0, None, 0, "linear"),
        "E_e": Estimate("E_e", E_E, 0.0, None, 0, "sls"),
    }
    m = Measurement(test, Table(Path("n.csv"), {"deflection": d, "force": F}, {}, {}, ""))
    return shear.fit_three_point_bend([m], specimen=TUBE, known=known).estimate("E_s").value


@pytest.mark.parametrize("span_mm", [8, 20])
def test_predicted_nose_bias_brackets_the_continuum(span_mm):
    """The predicted bias range of nose travel contains what the continuum tube actually gives."""
    (option,) = [
        o for o in design.design(TUBE, E_b=E_B, E_e=E_E, spans=[span_mm * 1e-3]) if o.measurement == "nose"
    ]
    actual = nose_fit(span_mm) / KGA - 1
    assert option.bias[1] <= actual <= option.bias[0]
    assert not option.ok  # a 50-80 % bias never qualifies


def test_short_spans_with_centreline_qualify_long_spans_do_not():
    options = design.design(TUBE, E_b=E_B, E_e=E_E, precision=0.05)
    centre = {round(1e3 * o.span): o for o in options if o.measurement == "centreline"}
    # 8 mm is marginal (5.1 %): the rod's form error against a tube is 1 % of the compliance or more
    # (benchmarks/README.md: two 3D continua of this tube, 0.4-0.9 % and 1.3-2.2 %), amplified 1/share
    assert centre[6].ok and not any(centre[s].ok for s in (10, 15, 20, 30))
    assert not centre[8].ok and 0.05 < centre[8].rel_sd < 0.055 < centre[10].rel_sd  # marginal, 5.1 %
    shares = [centre[s].share for s in sorted(centre)]
    assert shares == sorted(shares, reverse=True)  # shear matters less as the span grows
    # Timoshenko share with Hutchinson k G A at 8 mm: 0.0736 / (0.0736 + 0.1632)
    assert centre[8].share == pytest.approx(0.311, abs=0.01)
    text = design.summary(options, 0.05)
    assert "Best: centreline deflection at 6 mm" in text and "nose travel does not qualify" in text


def test_design_needs_E_e_or_E_t():
    with pytest.raises(Exception, match="E_e or E_t"):
        design.design(TUBE, E_b=E_B)


def test_command_line(capsys):
    code = main(["design", "--outer-diameter", "2.4 mm", "--inner-diameter", "1.6 mm"]
                + ["--E-b", "6.5345e-5 N m^2", "--E-e", "125.66 N", "--spans", "6,10"])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0 and "6 mm  centreline" in out and "10 mm  nose" in out
    bad = main(["design", "--outer-diameter", "2.4 kg", "--E-b", "1 N m^2", "--E-e", "1 N"])
    assert bad == 2 and "design" in capsys.readouterr().err
    assert main(["design", "--outer-diameter", "2.4 mm", "--E-b", "6.5e-5 N m^2"]) == 2
