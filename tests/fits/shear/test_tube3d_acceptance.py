"""Issue 11's acceptance on every 3D continuum tube there is (physics.md section 7).

Runs over every ``T*.json`` in ``../shared/reference/tube3d`` (the shared reference beside
the repository; CI may hold spans the development copy does not, e.g. 6, 10, 15 and
30 mm), the copies ``tests/data/tube3d/T*.json`` when the shared folder is absent, and
our own continuum ``tests/data/tube3d/S<span>_bench.json`` (benchmarks/continuum/run_3d.py
with the reference's mesh; written by ``fit_tube3d.py --export``). All are the same tube:
E 50 MPa, nu 0.45, R_o 1.2, R_i 0.8 mm, 2 mm rollers; its k G A with Hutchinson's
coefficient is 27.17 N.

- Centreline deflection: the interval covers k G A at every span. On the reference, E_s
  within 3 % at spans up to 10 mm. Beyond 10 mm, within 3 % or warned "poorly
  determined": the E_s error is eps / share, eps the continuum's compliance error against
  the rod (0.4-0.9 % on the reference), and the shear share falls as S^-2. Our own
  continuum is 1.2 % stiffer than the reference at 8 mm on the same mesh (eps 1.3-2.2 %,
  benchmarks/README.md), so at 6-10 mm it gives +3.7 to +6.3 %: there only the interval
  is checked.
- Nose travel: never a confident wrong E_s. Withheld, or within 10 % with an interval
  that covers k G A, or warned with the reason (the local contact compliance, or that
  E_s is not identifiable at this span) and an interval that covers k G A.
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
REASONS = ("E_s is likely too low", "E_s is not identifiable")


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


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_centreline_gives_E_s_within_3_percent(path):
    span, est = _fit(path, "delta_centroid")
    error = est.value / KGA - 1
    poor = any("poorly determined" in w for w in est.warnings)
    where = f"{path.name}: E_s {est.value:.3f} N ({100 * error:+.1f} %), {est.ci95}, {est.warnings}"
    assert est.ci95[0] < KGA < est.ci95[1], where
    if span > 10.0001e-3:
        assert abs(error) <= 0.03 or poor, where
    elif not path.name.endswith("_bench.json"):
        assert abs(error) <= 0.03 and not poor, where
    else:  # our own continuum: its own eps (1.3-2.2 %) over the share gives +3.7 to +6.3 % here
        assert 0.0 < error <= 0.07 and not poor, where


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_nose_travel_is_never_a_confident_wrong_number(path):
    try:
        _, est = _fit(path, "delta")
    except FitError as err:
        assert "withheld" in str(err) and 'deflection_at = "centreline"' in str(err)
        return
    covers = est.ci95[0] < KGA < est.ci95[1]
    where = f"{path.name}: E_s {est.value:.3f} N, {est.ci95}, {est.warnings}"
    if abs(est.value / KGA - 1) <= 0.10:
        assert covers, where
    else:
        assert covers and any(w.startswith(REASONS) for w in est.warnings), where
