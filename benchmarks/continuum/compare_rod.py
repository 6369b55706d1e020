"""Compare matid's rod model of the bend with the 2D plane-stress continuum (results/plane2d_*.json).

For each span and support convention alpha (0: matid, 1/2, 1; see rod_alpha.py):

- nose travel: E_s chosen so the rod's force equals the continuum's at d/S = 0.5 %
  ("the same small-deflection stiffness"), E_b = EI and E_e = E b h of the strip;
  then the force error (rod - continuum)/continuum at d/S = 1, 5, 10, 15 %;
- centreline: E_s chosen so the rod's F / delta_centroid equals the continuum's at
  d/S = 0.5 %; then the force error at the same centreline deflection;
- the support force tilt from vertical: the continuum's against the rod's, and the
  alpha it implies, (phi_c - theta) / (psi_in - theta) with the rod's (alpha = 0)
  section angle theta and span-side tangent psi_in at the same centreline deflection.

Writes results/compare_rod.json. Usage: python benchmarks/continuum/compare_rod.py [--level 1]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
from rod_alpha import AlphaModel, support_angles  # noqa: E402

from matid.rod.bend import BendGeometry  # noqa: E402

ALPHAS = (0.0, 0.5, 1.0)
POINTS = (0.01, 0.05, 0.10, 0.15)
MATCH = 0.005
ELEMENTS = 48


def strip_constants(p: dict) -> dict:
    """SI stiffnesses of the plane-stress strip (k: Cowper's rectangle, 10(1+nu)/(12+11nu))."""
    b, h, E, nu = p["b"] * 1e-3, p["h"] * 1e-3, p["E"] * 1e6, p["nu"]
    k = 10 * (1 + nu) / (12 + 11 * nu)
    return {"E_b": E * b * h**3 / 12, "E_e": E * b * h, "kGA": k * E / (2 * (1 + nu)) * b * h, "k": k}


def rod_path(model, c, E_s, d):
    path = model.solve(c["E_b"], E_s, c["E_e"], d)
    ang = [support_angles(model, path, i) for i in range(len(d))]
    return path.force, ang


def fit_E_s(model, c, target, d_match, measure) -> float:
    """E_s with measure(rod at d_match) = target (secant on log E_s)."""

    def resid(log_es):
        F, ang = rod_path(model, c, np.exp(log_es), np.array([d_match]))
        return np.log(measure(F[0], ang[0]) / target)

    x0, x1 = np.log(c["kGA"]), np.log(0.7 * c["kGA"])
    f0, f1 = resid(x0), resid(x1)
    for _ in range(30):
        x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
        f1 = resid(x1)
        if abs(f1) < 1e-7:
            break
    return float(np.exp(x1))


def compare(res: dict) -> dict:
    p = res["params"]
    S = p["S"]
    rows = res["rows"]
    dS = np.array([r["delta"] for r in rows]) / S
    F_c = np.array([r["F"] for r in rows])
    dc_c = np.array([r["delta_centroid"] for r in rows])
    phi_c = np.array([r["angle"] for r in rows])
    c = strip_constants(p)
    geo = BendGeometry(
        span=S * 1e-3,
        specimen_length=(S + 2 * p["overhang"]) * 1e-3,
        support_radius=p["Rs"] * 1e-3,
        nose_radius=p["Rn"] * 1e-3,
        outer_diameter=p["h"] * 1e-3,
    )
    d_match = MATCH * S * 1e-3
    F_match = float(np.interp(MATCH, dS, F_c))
    k_cl = float(np.interp(MATCH, dS, F_c / dc_c))  # continuum F / delta_centroid, N/mm
    grid = np.linspace(0, 0.16, 65)[1:] * S * 1e-3
    out = {"span_mm": S, "strip": c, "F_cont": {}, "alphas": {}}
    for x in POINTS:
        out["F_cont"][f"{x:g}"] = float(np.interp(x, dS, F_c))
    for al in ALPHAS:
        model = AlphaModel(geo, alpha=al, elements=ELEMENTS)
        E_nose = fit_E_s(model, c, F_match, d_match, lambda F, a: F)
        F_r, _ = rod_path(model, c, E_nose, grid)
        nose_err = {
            f"{x:g}": float(np.interp(x * S * 1e-3, grid, F_r) / np.interp(x, dS, F_c) - 1) for x in POINTS
        }
        E_cl = fit_E_s(model, c, k_cl * 1e3, d_match, lambda F, a: F / a["delta_centroid"])
        F_r, ang = rod_path(model, c, E_cl, grid)
        dc_r = np.array([a["delta_centroid"] for a in ang]) * 1e3
        cl_err, tilt = {}, {}
        for x in POINTS:
            dc = float(np.interp(x, dS, dc_c))
            cl_err[f"{x:g}"] = float(np.interp(dc, dc_r, F_r) / np.interp(x, dS, F_c) - 1)
            th = np.interp(dc, dc_r, [a["theta"] for a in ang])
            psi = np.interp(dc, dc_r, [a["psi_in"] for a in ang])
            phi_r = np.interp(dc, dc_r, [a["angle"] for a in ang])
            phi = float(np.interp(x, dS, phi_c))
            tilt[f"{x:g}"] = {
                "phi_cont": phi,
                "phi_rod": float(phi_r),
                "theta_rod": float(th),
                "psi_in_rod": float(psi),
                "alpha_implied": float((phi - th) / (psi - th)),
            }
        out["alphas"][f"{al:g}"] = {
            "E_s_nose": E_nose,
            "E_s_centreline": E_cl,
            "force_error_nose": nose_err,
            "force_error_centreline": cl_err,
            "support_tilt": tilt,
        }
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--level", default="1")
    a = ap.parse_args(argv)
    out = {}
    for f in sorted((HERE / "results").glob(f"plane2d_S*_L{a.level}.json")):
        res = json.loads(f.read_text())
        out[f.stem] = compare(res)
        print(f.stem, json.dumps(out[f.stem]["alphas"], indent=None)[:2000])
    (HERE / "results" / f"compare_rod_L{a.level}.json").write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
