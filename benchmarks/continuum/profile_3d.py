"""Where along the span the 3D tube is stiffer than the rod: section deflections against Timoshenko.

Reads runs of ``run_3d.py --profile`` (the area-weighted mean deflection of every
section) and compares the deflection between two sections, v(x_a) - v(x_b), per
newton with Timoshenko's closed form (E I, Hutchinson's k G A = 27.17 N), at the
smallest load (d/S = 0.25 %, where the rod model equals Timoshenko to ~0.2 %).
x is measured from mid-span; v(x) = uy(S/2) - uy(x) is the deflection relative to
the support section, and for a central load F at distance xi = S/2 - x from the
support

    v = F xi (3 S^2 - 4 xi^2) / (48 E I) + F xi / (2 k G A).

eps(x_a, x_b) = C_Timoshenko / C_continuum - 1 over that pair. The pair (0, S/2) is
the centreline deflection of issue 11; pairs that keep 1.5 mm off the nose and
the support show whether the continuum's excess stiffness sits at the contacts.

    python benchmarks/continuum/profile_3d.py benchmarks/continuum/results/tube3d_S*_profile.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

EI, KGA = 65.345, 27.17  # N mm^2, N


def timoshenko(x: np.ndarray, S: float) -> np.ndarray:
    """Deflection per newton at x (from mid-span) relative to the support section [mm/N]."""
    xi = 0.5 * S - np.asarray(x)
    return xi * (3 * S**2 - 4 * xi**2) / (48 * EI) + xi / (2 * KGA)


def pairs(S: float) -> list[tuple[float, float]]:
    off = 1.5
    return [(0.0, S / 2), (off, S / 2), (0.0, S / 2 - off), (off, S / 2 - off)]


def analyse(path: Path) -> list[str]:
    doc = json.loads(Path(path).read_text())
    S = float(doc["params"]["S"])
    row = doc["rows"][0]
    x, uy = np.array(row["profile"]).T
    F = row["F"]
    v = np.interp(S / 2, x, uy) - uy  # relative to the support section
    out = [f"{Path(path).name}: S = {S:g} mm, d/S = {100 * row['delta'] / S:.2f} %, F = {F:.4f} N"]
    for a, b in pairs(S):
        c_cont = (np.interp(a, x, v) - np.interp(b, x, v)) / F
        c_tim = float(timoshenko(a, S) - timoshenko(b, S))
        out.append(f"  sections {a:g}-{b:g} mm: C continuum {c_cont:.5f}, Timoshenko {c_tim:.5f} mm/N, "
                   f"eps {100 * (c_tim / c_cont - 1):+.2f} %")  # fmt: skip
    return out


if __name__ == "__main__":
    for f in sys.argv[1:]:
        print("\n".join(analyse(Path(f))))
