"""Run the 2D plane-stress bend (ccx_deck) and write results/plane2d_S<span>_L<level>.json.

Usage (from the repository root; each run a few minutes on 2 cores):

    python benchmarks/continuum/run_2d.py --span 8 --level 1
    python benchmarks/continuum/run_2d.py --span 6 --level 1 --dtmax 0.025
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from ccx_deck import Params, run  # noqa: E402
from results_io import save  # noqa: E402


def main(argv=None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--span", type=float, required=True)
    ap.add_argument("--level", type=float, default=1.0)
    ap.add_argument("--d-over-S", type=float, default=0.15)
    ap.add_argument("--dtmax", type=float, default=1 / 40)
    ap.add_argument("--K", type=float, default=1e5)
    ap.add_argument("--tag", default="")
    ap.add_argument("--work", default="/tmp/matid_ccx2d")
    a = ap.parse_args(argv)
    p = Params(S=a.span, level=a.level, d_over_S=a.d_over_S, dtmax=a.dtmax, dt0=min(a.dtmax, 1 / 160), K=a.K)
    name = f"plane2d_S{a.span:g}_L{a.level:g}{a.tag}"
    t0 = time.time()
    out = run(p, Path(a.work) / name)
    save(name, out, t0)


if __name__ == "__main__":
    main()
