"""Bending stiffness of the 3D tube mesh alone: a clamped half tube with a tip load (CalculiX).

Checks whether the continuum tube of ``ccx_tube3d`` bends with E I, without
rollers, contact or the three-point-bend sections. Half model (z = 0 symmetry),
the ``ccx_tube3d`` section mesh (2 elements through the wall, 12 round the half
circumference, graded), 0.6 mm elements along x, linear elastic, small
deflection. x = 0 clamped; at x = L a vertical load P spread over the tip
section by area. The area-weighted mean deflection w of interior sections
(2.5 diameters from both ends) is fitted by

    w(x) = c0 + c1 x + (P / EI) (L x^2 / 2 - x^3 / 6),

where c0 + c1 x takes up the clamp's local effects and the shear term P x / k G A,
so EI comes from the curvature alone. Run (a minute on one thread):

    python benchmarks/continuum/ccx_cantilever.py [--L 30] [--ax 1] [--circ 1]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time
from pathlib import Path

import numpy as np
from ccx_deck import _refine, parse_dat
from ccx_tube3d import Mesh3, _phi_grid, _weights

HERE = Path(__file__).parent
EI_TUBE = 50.0 * np.pi / 4 * (1.2**4 - 0.8**4)  # N mm^2


def run(L: float, ax: float, circ: float, wall: float, work: Path, P: float = 0.01) -> dict:
    Ro, Ri, E, nu = 1.2, 0.8, 50.0, 0.45
    xc = _refine(np.linspace(0.0, L, int(round(L / (0.6 / ax))) + 1))
    rc = _refine(np.linspace(Ri, Ro, int(round(2 * wall)) + 1))
    pc = _refine(_phi_grid(int(round(12 * circ))))
    X, R, PH = np.meshgrid(xc, rc, pc, indexing="ij")
    m = Mesh3()
    tube = m.block("TUBE", np.stack([X, R * np.cos(PH), R * np.sin(PH)], -1))
    ok = tube[0] > 0
    w = _weights(rc, pc)[ok]
    sections = [i for i, x in enumerate(xc) if 5 * Ro <= x <= L - 5 * Ro and i % 2 == 0]
    lines = ["*HEADING", f"clamped half tube L={L}", "*NODE, NSET=NALL"]
    lines += [f"{i + 1}, {x:.10g}, {y:.10g}, {z:.10g}" for i, (x, y, z) in enumerate(m.nodes)]
    lines.append("*ELEMENT, TYPE=C3D20, ELSET=TUBE")
    for e, conn in enumerate(m.blocks["TUBE"], start=1):
        v = [str(x) for x in [e, *conn]]
        lines += [", ".join(v[:16]) + ",", ", ".join(v[16:])]
    sets = {"CLAMP": tube[0][ok], "ZSYM": np.concatenate([tube[:, :, 0].ravel(), tube[:, :, -1].ravel()])}
    sets |= {f"S{i}": tube[i][ok] for i in sections}
    for name, ids in sets.items():
        ids = [int(v) for v in np.ravel(ids) if v > 0]
        lines.append(f"*NSET, NSET={name}")
        lines += [", ".join(map(str, ids[k : k + 12])) for k in range(0, len(ids), 12)]
    tip = tube[-1][ok]
    half = P / 2  # the half model carries half the load
    lines += ["*MATERIAL, NAME=TUBE", "*ELASTIC", f"{E}, {nu}", "*SOLID SECTION, ELSET=TUBE, MATERIAL=TUBE"]
    lines += ["*BOUNDARY", "CLAMP, 1, 3", "ZSYM, 3, 3", "*STEP", "*STATIC", "*CLOAD"]
    lines += [f"{int(n)}, 2, {-half * wi / w.sum():.10g}" for n, wi in zip(tip, w, strict=True)]
    for i in sections:
        lines += [f"*NODE PRINT, NSET=S{i}", "U"]
    lines.append("*END STEP")
    work.mkdir(parents=True, exist_ok=True)
    (work / "cant.inp").write_text("\n".join(lines) + "\n")
    env = {"OMP_NUM_THREADS": "1", "CCX_NPROC_EQUATION_SOLVER": "1", "PATH": "/usr/bin:/bin"}
    t0 = time.time()
    proc = subprocess.run(
        ["nice", "-n", "15", "ccx", "-i", "cant"], cwd=work, env=env, capture_output=True, text=True
    )
    res = parse_dat(work / "cant.dat")
    (d,) = res.values()
    order = {int(n): k for k, n in enumerate(tube[0][ok])}  # same (r, phi) layout in every section
    xs, ws = [], []
    for i in sections:
        ids = {int(n): k for k, n in enumerate(tube[i][ok])}
        uy = np.zeros(len(order))
        for row in d[f"S{i}:displacements"]:
            uy[ids[int(row[0])]] = row[2]
        xs.append(xc[i])
        ws.append(float(np.sum(uy * w) / w.sum()))
    x, wv = np.array(xs), -np.array(ws)
    A = np.column_stack([np.ones_like(x), x, P * (L * x**2 / 2 - x**3 / 6)])
    coef, *_ = np.linalg.lstsq(A, wv, rcond=None)
    EI = 1.0 / coef[2]
    resid = wv - A @ coef
    return {
        "L": L, "ax": ax, "circ": circ, "wall": wall, "nodes": len(m.nodes), "ccx_rc": proc.returncode,
        "EI_fit": float(EI), "EI_tube": float(EI_TUBE), "EI_ratio": float(EI / EI_TUBE),
        "rms_residual_over_tip": float(np.sqrt(np.mean(resid**2)) / wv.max()),
        "runtime_s": time.time() - t0,
    }  # fmt: skip


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--L", type=float, default=30.0)
    ap.add_argument("--ax", type=float, default=1.0)
    ap.add_argument("--circ", type=float, default=1.0)
    ap.add_argument("--wall", type=float, default=1.0)
    a = ap.parse_args(argv)
    tag = f"cantilever_L{a.L:g}_ax{a.ax:g}_circ{a.circ:g}_wall{a.wall:g}"
    out = run(a.L, a.ax, a.circ, a.wall, Path("/tmp/matid_ccx3d") / tag)
    (HERE / "results" / f"{tag}.json").write_text(json.dumps(out, indent=1))
    print(tag, out)


if __name__ == "__main__":
    main()
