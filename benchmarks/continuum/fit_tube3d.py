"""matid's E_s fit on 3D continuum tube data (tube3d format): centreline and nose travel.

Usage (from the repository root):

    python benchmarks/continuum/fit_tube3d.py ../shared/reference/tube3d/T*.json \
        benchmarks/continuum/results/tube3d_S*_refmesh.json
    python benchmarks/continuum/fit_tube3d.py --json out.json FILES...

Every file is a CalculiX run of the reference tube (E 50 MPa, nu 0.45, R_o 1.2,
R_i 0.8 mm; ``params.S`` the span in mm; rows ``delta`` nose travel, ``F`` force,
``delta_centroid`` centreline deflection, mm and N). Prints, per file and
measurement, E_s, its interval, its error against Hutchinson's k G A = 27.17 N,
the shear share of the centreline compliance, and the warnings (or why E_s was
withheld). Also the compliance error eps of the rod against the continuum:
eps = C_rod(k G A) / C_continuum - 1 on the centreline (F / delta_centroid), the
quantity whose 1/share amplification the E_s error is.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from matid.errors import FitError
from matid.fits.shear import fit as shear
from matid.fits.shear.checks import shear_share
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.model.results import Estimate

E_B = 6.5345e-5  # N m^2, E I of the reference tube
E_E = 125.66  # N, E A
KGA = 27.17  # N, Hutchinson's k G A
TUBE = study.Specimen("T", 2.4e-3, 1.6e-3)
KNOWN = {
    "E_b": Estimate("E_b", E_B, 0.0, None, 0, "linear"),
    "E_e": Estimate("E_e", E_E, 0.0, None, 0, "sls"),
}


def load(path: Path) -> tuple[float, dict[str, np.ndarray]]:
    """(span [m], columns in SI with a leading zero row) of a tube3d-format file."""
    doc = json.loads(Path(path).read_text())
    rows = doc["rows"]
    cols = {k: np.r_[0.0, [r[k] for r in rows]] * 1e-3 for k in ("delta", "delta_centroid")}
    cols["F"] = np.r_[0.0, [r["F"] for r in rows]]
    return float(doc["params"]["S"]) * 1e-3, cols


def measurement(d: np.ndarray, F: np.ndarray, span: float, at: str, name: str) -> Measurement:
    params = {
        "span": span,
        "specimen_length": span + 8e-3,
        "support_radius": 2e-3,
        "nose_radius": 2e-3,
    }
    test = study.Test("three_point_bend", "T", Path(name), params, window={}, deflection_at=at)
    return Measurement(test, Table(Path(name), {"deflection": d, "force": F}, {}, {}, ""))


def fit(path: Path, at: str) -> dict:
    """matid's fit of one file: value, interval, warnings, or the reason it was withheld."""
    span, c = load(path)
    d = c["delta_centroid"] if at == "centreline" else c["delta"]
    m = measurement(d, c["F"], span, at, Path(path).name)
    out = {"file": Path(path).name, "span_mm": round(1e3 * span, 6), "at": at}
    out["shear_share"] = shear_share(span, E_B, KGA)
    try:
        est = shear.fit_three_point_bend([m], specimen=TUBE, known=KNOWN).estimate("E_s")
    except FitError as err:
        return {**out, "withheld": str(err)}
    out.update(E_s=est.value, ci95=list(est.ci95), error=est.value / KGA - 1, warnings=list(est.warnings))
    out["covers"] = bool(est.ci95[0] <= KGA <= est.ci95[1])
    return out


def rod_compliance_error(path: Path) -> list[float]:
    """eps = C_rod / C_continuum - 1 at each row, on the centreline, with E_s = k G A.

    C_rod is matid's BendModel (the fit's own model) at the continuum's centreline
    deflection, so eps is what the fit must absorb by moving E_s.
    """
    span, c = load(path)
    F = c["F"]
    m = measurement(c["delta_centroid"], F, span, "centreline", Path(path).name)
    b = shear.bend_data(m, TUBE, E_B)
    prob = shear.Problem([b], E_B, E_E, fit_E_b=False, elements=48)
    r, _ = prob.evaluate(np.array([math.log(KGA)]))
    F_rod = r + b.F  # model force at the measured centreline deflection
    return [float(b.F[i] / F_rod[i] - 1) for i in range(b.F.size) if b.F[i] > 0]


REFERENCE_ROW = ("t", "delta", "F", "Vs", "Hs", "uy_mid", "uy_sup", "delta_centroid")


def export(path: Path, folder: Path) -> Path:
    """A run of run_3d.py in the shared reference's format, as S<span>_bench.json (tests/data/tube3d)."""
    doc = json.loads(Path(path).read_text())
    out = {
        "params": doc["params"],
        "nodes": doc["nodes"],
        "elements": doc["elements"],
        "wall_s": doc.get("runtime_s"),
        "rows": [{k: r[k] for k in REFERENCE_ROW} for r in doc["rows"]],
        "ccx_rc": doc["ccx_rc"],
        "source": f"benchmarks/continuum/results/{Path(path).name}",
    }
    folder.mkdir(parents=True, exist_ok=True)
    target = folder / f"S{doc['params']['S']:g}_bench.json"
    target.write_text(json.dumps(out, indent=1) + "\n")
    return target


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--json", type=Path)
    ap.add_argument(
        "--export", type=Path, help="also write each file in the reference's format to this folder"
    )
    a = ap.parse_args(argv)
    if a.export:
        for f in a.files:
            export(f, a.export)
    table = []
    for f in a.files:
        eps = rod_compliance_error(f)
        for at in ("centreline", "nose"):
            r = fit(f, at)
            r["eps_centreline"] = eps
            table.append(r)
            if "withheld" in r:
                what = "withheld: " + r["withheld"][:90]
            else:
                lo, hi = r["ci95"]
                w = "; ".join(x[:70] for x in r["warnings"]) or "-"
                what = f"E_s {r['E_s']:.2f} N ({100 * r['error']:+.1f} %), CI {lo:.2f}-{hi:.2f}"
                what += f", covers {r['covers']}; {w}"
            eps_s = "/".join(f"{100 * e:+.2f}" for e in eps)
            share = 100 * r["shear_share"]
            print(f"{r['file']} S={r['span_mm']:g} share {share:.1f} % eps {eps_s} % {at}: {what}")
    if a.json:
        a.json.write_text(json.dumps(table, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
