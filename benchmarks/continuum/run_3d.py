"""Run the 3D quarter tube (ccx_tube3d) and write results/tube3d_<tag>.json.

Usage (from the repository root; a few minutes each on 2 busy cores):

    python benchmarks/continuum/run_3d.py --span 8
    python benchmarks/continuum/run_3d.py --span 8 --Ri 0.9 --tag thin
    python benchmarks/continuum/run_3d.py --span 8 --ax 2 --tag _ax2   # mesh check
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from ccx_tube3d import TubeParams, run  # noqa: E402
from results_io import save  # noqa: E402


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--span", type=float, required=True)
    ap.add_argument("--Ri", type=float, default=0.8)
    ap.add_argument("--E", type=float, default=50.0)
    ap.add_argument("--level", type=float, default=1.0)
    ap.add_argument("--ax", type=float, default=1.0, help="extra refinement along the axis")
    ap.add_argument("--wall", type=float, default=1.0, help="extra refinement through the wall")
    ap.add_argument("--circ", type=float, default=1.0, help="extra refinement round the circumference")
    ap.add_argument("--etype", default="C3D20")
    ap.add_argument("--profile", action="store_true", help="also store the deflection of every section")
    ap.add_argument("--phi-grade", type=float, default=0.6, help="circumferential grading (0: uniform)")
    ap.add_argument("--slave", default="tube", choices=("tube", "rollers"), help="slave side of the contacts")
    ap.add_argument("--roll-dx", type=float, default=0.0, help="roller element size along the arc (mm)")
    ap.add_argument("--roll-dz", type=float, default=0.0, help="roller element size along its axis (mm)")
    ap.add_argument("--rs-a", type=float, nargs=2, default=(60.0, 120.0), help="support roller sector (deg)")
    ap.add_argument("--threads", type=int, default=1, help="ccx threads (the machine is shared)")
    ap.add_argument("--nice", type=int, default=15)
    ap.add_argument("--tag", default="")
    ap.add_argument("--work", default="/tmp/matid_ccx3d")
    a = ap.parse_args(argv)
    p = TubeParams(
        S=a.span,
        Ri=a.Ri,
        E=a.E,
        level=a.level,
        ax=a.ax,
        wall=a.wall,
        circ=a.circ,
        etype=a.etype,
        slave=a.slave,
        phi_grade=a.phi_grade,
        profile=a.profile,
        roll_dx=a.roll_dx,
        roll_dz=a.roll_dz,
        rs_a=tuple(a.rs_a),
    )
    name = f"tube3d_S{a.span:g}_Ri{a.Ri:g}_E{a.E:g}_L{a.level:g}{a.tag}"
    t0 = time.time()
    out = run(p, Path(a.work) / name, threads=a.threads, nice=a.nice)
    save(name, out, t0, threads=a.threads)


if __name__ == "__main__":
    main()
