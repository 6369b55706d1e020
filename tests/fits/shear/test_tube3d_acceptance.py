"""Issue 11's acceptance on every 3D continuum tube there is (physics.md section 7).

Runs over every ``T*.json`` in ``../shared/reference/tube3d`` (the shared reference beside
the repository; CI may hold spans the development copy does not, e.g. 6, 10, 15 and
30 mm), the copies ``tests/data/tube3d/T*.json`` when the shared folder is absent, and
our own continuum ``tests/data/tube3d/S<span>_bench.json`` (benchmarks/continuum/run_3d.py
with the reference's mesh; written by ``fit_tube3d.py --export``). All are the same tube:
E 50 MPa, nu 0.45, R_o 1.2, R_i 0.8 mm, 2 mm rollers; its k G A with Hutchinson's
coefficient is 27.17 N.

Each file and measurement has one expected outcome (no "A or B"):

- Centreline deflection (no contact compliance in it; every file): the interval covers
  k G A. Spans up to 10 mm: on the reference, E_s within 3 % and no warning; on our own
  continuum (1.2 % stiffer than the reference at 8 mm on the same mesh, eps 1.3-2.2 %,
  benchmarks/README.md) +0 to +7 % and no warning. Spans 15 and 20 mm: warned "poorly
  determined" (the E_s error is eps / share, the shear share falls as S^-2). Span 30 mm:
  warned "not identifiable" and "poorly determined".
- Nose travel, only on spans the contact-compliance constant never saw: the constant
  (matid.fits.shear.torsion KAPPA_RANGE, CONTACT_N; the demo's CONTACT_C) is calibrated on
  spans 8 and 20 mm (T8, T20, S8_bench), so nose travel is accepted on 6, 10, 15 and 30 mm
  (the shared reference keeps those for acceptance; S*_bench here). Span 6 mm: withheld,
  naming the centreline. Longer: warned "likely too low" (15 mm and beyond also "poorly
  determined", 30 mm also "not identifiable"), with an interval that covers k G A.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from matid.errors import FitError
from matid.fits.shear import fit as shear
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.model.results import Estimate
from tests import ROOT, TESTS

SHARED = ROOT.parent / "shared" / "reference" / "tube3d"
LOCAL = TESTS / "data" / "tube3d"
KGA = 27.17
TUBE = study.Specimen("T", 2.4e-3, 1.6e-3)
KNOWN = {
    "E_b": Estimate("E_b", 6.5345e-5, 0.0, None, 0, "linear"),
    "E_e": Estimate("E_e", 125.66, 0.0, None, 0, "sls"),
}


def _files() -> list[Path]:
    shared = sorted(SHARED.glob("T*.json")) if SHARED.is_dir() else []
    copies = sorted(p for p in LOCAL.glob("T*.json") if not (SHARED / p.name).exists())
    return shared + copies + sorted(LOCAL.glob("S*_bench.json"))


FILES = _files()


def _fit(path: Path, column: str) -> tuple[float, Estimate]:
    doc = json.loads(path.read_text())
    span = float(doc["params"]["S"]) * 1e-3
    rows = doc["rows"]
    d = np.r_[0.0, [r[column] for r in rows]] * 1e-3
    F = np.r_[0.0, [r["F"] for r in rows]]
    params = {"span": span, "specimen_length": span + 8e-3, "support_radius": 2e-3, "nose_radius": 2e-3}
    at = "centreline" if column == "delta_centroid" else "nose"
    test = study.Test("three_point_bend", "T", Path(path.name), params, window={}, deflection_at=at)
    m = Measurement(test, Table(Path(path.name), {"deflection": d, "force": F}, {}, {}, ""))
    fit = shear.fit_three_point_bend([m], specimen=TUBE, known=KNOWN)
    return span, fit.estimate("E_s")


def test_the_reference_spans_are_found():
    """T8 and T20 at least (the shared copy, or the local copies when shared/ is absent)."""
    names = {p.name for p in FILES}
    assert {"T8.json", "T20.json"} <= names


TOO_LOW, NOT_IDENTIFIABLE, POOR = (
    "E_s is likely too low",
    "E_s is not identifiable",
    "E_s is poorly determined",
)
#: span [mm] -> the warnings (their openings, in order) of the centreline fit
CENTRELINE = {6: (), 8: (), 10: (), 15: (POOR,), 20: (POOR,), 30: (NOT_IDENTIFIABLE, POOR)}
#: span [mm] -> the nose-travel outcome: "withheld", or the warnings of the estimate
NOSE = {6: "withheld", 10: (TOO_LOW,), 15: (TOO_LOW, POOR), 30: (TOO_LOW, NOT_IDENTIFIABLE, POOR)}
#: spans whose nose travel calibrated the contact-compliance constant: never accepted on
CALIBRATION_SPANS = {8, 20}


def _span_mm(path: Path) -> int:
    return round(float(json.loads(path.read_text())["params"]["S"]))


def _openings(est: Estimate) -> tuple[str, ...]:
    """The warnings by their openings (a warning of another kind stays whole, and fails the match)."""
    kinds = (TOO_LOW, NOT_IDENTIFIABLE, POOR)
    return tuple(next((o for o in kinds if w.startswith(o)), w) for w in est.warnings)


HELD_OUT = [p for p in FILES if _span_mm(p) not in CALIBRATION_SPANS]


def test_the_held_out_spans_are_found():
    """Nose travel is accepted on spans the constant never saw: 6, 10, 15, 30 mm at least."""
    assert {6, 10, 15, 30} <= {_span_mm(p) for p in HELD_OUT}


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_centreline_gives_E_s_as_expected(path):
    span, est = _fit(path, "delta_centroid")
    error = est.value / KGA - 1
    where = f"{path.name}: E_s {est.value:.3f} N ({100 * error:+.1f} %), {est.ci95}, {est.warnings}"
    assert est.ci95[0] < KGA < est.ci95[1], where
    assert _openings(est) == CENTRELINE[_span_mm(path)], where
    if span <= 10.0001e-3 and path.name.endswith("_bench.json"):
        assert 0.0 < error <= 0.07, where  # our own continuum: its eps over the share
    elif span <= 10.0001e-3:
        assert abs(error) <= 0.03, where


@pytest.mark.parametrize("path", HELD_OUT, ids=[p.name for p in HELD_OUT])
def test_nose_travel_on_a_held_out_span_is_as_expected(path):
    expected = NOSE[_span_mm(path)]
    if expected == "withheld":
        with pytest.raises(FitError, match="withheld") as err:
            _fit(path, "delta")
        assert 'deflection_at = "centreline"' in str(err.value)
        return
    _, est = _fit(path, "delta")
    where = f"{path.name}: E_s {est.value:.3f} N, {est.ci95}, {est.warnings}"
    assert est.value < 0.7 * KGA and est.ci95[0] < KGA < est.ci95[1], where
    assert _openings(est) == expected, where
