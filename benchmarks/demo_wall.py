"""Wall time of ``matid demo`` as a user runs it: a new process each time, checkouts interleaved.

    python benchmarks/demo_wall.py [--runs 5] [CHECKOUT ...]

Each run is ``python -m matid demo --quiet --out <tmp>`` in a fresh process with
``PYTHONPATH=<checkout>`` (none: the installed matid), from a temporary folder; the checkouts
take turns, so a load that comes and goes on a shared machine hits them alike. Prints the
best, the median and every run per checkout, in seconds, and the median ratio to the first.
``matid demo`` on the console adds the launcher of the installed script (~0.01 s; a pyenv
shim adds ~0.05 s).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time


def _once(checkout: str | None, folder: str) -> float:
    env = dict(os.environ)
    if checkout:
        env["PYTHONPATH"] = os.path.abspath(checkout)
    started = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "matid", "demo", "--quiet", "--out", os.path.join(folder, "out")],
        cwd=folder, env=env, check=True, stdout=subprocess.DEVNULL,
    )  # fmt: skip
    return time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("checkouts", nargs="*", help="source trees to put on PYTHONPATH (default: installed)")
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    checkouts = args.checkouts or [None]
    times: dict[str | None, list[float]] = {c: [] for c in checkouts}
    with tempfile.TemporaryDirectory() as folder:
        for c in checkouts:
            _once(c, folder)  # warm the file cache and pint's definition cache
        for _ in range(args.runs):
            for c in checkouts:
                times[c].append(_once(c, folder))
    first = statistics.median(times[checkouts[0]])
    for c, runs in times.items():
        median = statistics.median(runs)
        every = " ".join(f"{t:.2f}" for t in runs)
        print(f"{c or 'installed'}: best {min(runs):.2f} s, median {median:.2f} s "
              f"({median / first:.2f}x the first); runs {every}")  # fmt: skip


if __name__ == "__main__":
    main()
