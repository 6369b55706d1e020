"""Per-scene cost of the stacked batch (matid.rod.solve_many) against a loop of the solve_bvp
baseline, on P1 of ``matid bench --sections peers`` (magnetic cantilever q = 6.4, 120 deg, planar).

Protocol (as peers): process CPU, interleaved (batch, baseline loop, batch, ...) in one run, best
of ``--repeats``; every call solves fresh scenes (load scaled by 1 + 1e-9 i, so nothing
scene-specific is cached between calls); the baseline's collocation tolerance is the loosest with
a tip error <= 1e-6 against a tight reference, matid runs at its scene tolerance (1e-6). Prints the
ratio (baseline per scene / batch per scene) at each N and the worst tip error of each. With
``--profile``: a pyinstrument profile of one batch of N = 100.

    PYTHONPATH=$PWD python benchmarks/batch.py [--sizes 10 100 1000] [--repeats 3] [--profile]
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from matid.bench import peers as P
from matid.rod.many import solve_many


def scenes_and_bases(n: int, call: int) -> tuple[list, list]:
    made = [P.problems(1.0 + 1e-9 * (call * n + i + 1))[0] for i in range(n)]
    return [p["scene"] for p in made], [p["baseline"] for p in made]


def run(sizes: list[int], repeats: int) -> list[dict]:
    base0 = P.problems()[0]["baseline"]
    reference = base0.tip(tol=1e-9, nodes=200)
    tol = P.calibrate(base0, reference)
    solve_many(scenes_and_bases(2, 10**6)[0])  # the mesh caches, once (as the serial bench's warm-up)
    rows = []
    for n in sizes:
        best = {"batch": np.inf, "baseline": np.inf}
        err = {"batch": 0.0, "baseline": 0.0}
        reps = repeats if n < 1000 else max(1, repeats - 1)
        for call in range(reps):
            scenes, bases = scenes_and_bases(n, call)
            t0 = time.process_time()
            sols = solve_many(scenes)
            best["batch"] = min(best["batch"], time.process_time() - t0)
            t0 = time.process_time()
            tips = [b.tip(tol=tol) for b in bases]
            best["baseline"] = min(best["baseline"], time.process_time() - t0)
            L = scenes[0].rod.length
            err["batch"] = max(
                max(float(np.max(np.abs(s.position[-1] / L - reference))) for s in sols), err["batch"]
            )
            err["baseline"] = max(max(float(np.max(np.abs(t - reference))) for t in tips), err["baseline"])
        rows.append(
            {
                "N": n,
                "batch_ms_per_scene": 1e3 * best["batch"] / n,
                "bvp_ms_per_scene": 1e3 * best["baseline"] / n,
                "ratio": best["baseline"] / best["batch"],
                "tip_error_batch": err["batch"],
                "tip_error_bvp": err["baseline"],
                "bvp_tol": tol,
            }
        )
        print(_line(rows[-1]), flush=True)
    return rows


def _line(r: dict) -> str:
    return (
        f"N = {r['N']:5d}: batch {r['batch_ms_per_scene']:.3f} ms/scene, "
        f"solve_bvp {r['bvp_ms_per_scene']:.3f} ms/scene, ratio {r['ratio']:.2f}x; "
        f"tip error batch {r['tip_error_batch']:.1e}, "
        f"bvp {r['tip_error_bvp']:.1e} (bvp tol {r['bvp_tol']:g})"
    )


def profile(n: int = 100) -> str:
    from pyinstrument import Profiler

    scenes = scenes_and_bases(n, 7)[0]
    profiler = Profiler(interval=0.0002)
    profiler.start()
    solve_many(scenes)
    profiler.stop()
    return profiler.output_text(unicode=False, color=False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()
    machine = f"{platform.machine()} {platform.processor()}".strip()
    print(f"machine: {machine}, Python {platform.python_version()}, numpy {np.__version__}")
    run(args.sizes, args.repeats)
    if args.profile:
        print(profile())


if __name__ == "__main__":
    main()
