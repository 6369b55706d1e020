"""Print the tables of benchmarks/README.md from results/compare_rod_L1.json and results/*.json."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent / "results"


def rod_tables() -> None:
    comp = json.loads((HERE / "compare_rod_L1.json").read_text())
    for name, c in comp.items():
        print(f"\n{name}: strip kGA = {c['strip']['kGA']:.2f} N, EI = {c['strip']['E_b']:.4e} N m^2")
        print("| d/S | F cont (N) | nose: alpha 0 / 1/2 / 1 | centreline: alpha 0 / 1/2 / 1 |")
        print("| --- | --- | --- | --- |")
        for x in ("0.01", "0.05", "0.1", "0.15"):
            n = " / ".join(f"{100 * c['alphas'][a]['force_error_nose'][x]:+.1f}" for a in ("0", "0.5", "1"))
            cl = " / ".join(
                f"{100 * c['alphas'][a]['force_error_centreline'][x]:+.1f}" for a in ("0", "0.5", "1")
            )
            print(f"| {float(x) * 100:g} % | {c['F_cont'][x]:.3f} | {n} % | {cl} % |")
        print(
            "fitted E_s (N), nose / centreline:",
            {a: (round(v["E_s_nose"], 2), round(v["E_s_centreline"], 2)) for a, v in c["alphas"].items()},
        )
        print("| d/S | phi cont | rod alpha 0: theta / psi_in | alpha implied |")
        print("| --- | --- | --- | --- |")
        for x in ("0.01", "0.05", "0.1", "0.15"):
            t = c["alphas"]["0"]["support_tilt"][x]
            print(
                f"| {float(x) * 100:g} % | {t['phi_cont']:.4f} | {t['theta_rod']:.4f} / {t['psi_in_rod']:.4f}"
                f" | {t['alpha_implied']:.2f} |"
            )


def continuum_angles() -> None:
    for f in sorted(HERE.glob("plane2d_*.json")):
        r = json.loads(f.read_text())
        print(f"\n{f.stem}: nodes {r['nodes']}, run {r.get('runtime_s', 0):.0f} s")
        S = r["params"]["S"]
        for x in (0.0025, 0.01, 0.05, 0.10, 0.15):
            row = min(r["rows"], key=lambda q: abs(q["delta"] / S - x))
            if abs(row["delta"] / S - x) > 0.004:
                continue
            print(
                f"  d/S {row['delta'] / S:.4f}: F {row['F']:.4f} dc {row['delta_centroid']:.4f}"
                f" phi {row['angle']:.4f} psi_in {row['psi_in']:.4f} theta_sec {row['theta_sec']:.4f}"
            )


def tubes() -> None:
    for f in sorted(HERE.glob("tube3d_*.json")):
        r = json.loads(f.read_text())
        p = r["params"]
        print(f"\n{f.stem}: nodes {r['nodes']}, run {r.get('runtime_s', 0):.0f} s")
        for row in r["rows"]:
            print(
                f"  d/S {row['delta'] / p['S']:.4f}: F {row['F']:.5f} dc {row['delta_centroid']:.5f}"
                f" local {row['local_compliance']:.4f} mm/N  E*local {p['E'] * row['local_compliance']:.2f}"
            )
        F = np.array([q["F"] for q in r["rows"]])
        u = np.array([q["delta"] - q["delta_centroid"] for q in r["rows"]])
        n, lc = np.polyfit(np.log(F), np.log(u), 1)
        print(
            f"  u_local = {np.exp(lc):.4f} mm * (F/N)^{n:.3f};"
            f"  at F = 0.1 N: {np.exp(lc) * 0.1 ** (n - 1):.4f} mm/N"
        )


if __name__ == "__main__":
    if (HERE / "compare_rod_L1.json").exists():
        rod_tables()
    continuum_angles()
    tubes()
