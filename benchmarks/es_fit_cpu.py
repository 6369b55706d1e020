"""CPU of the demo's E_s fits (issue 32.4), checkouts interleaved, with their values.

    python benchmarks/es_fit_cpu.py [--runs 5] CHECKOUT [CHECKOUT ...]

Each run reads and fits the demo study (``data/example/study.toml`` of the checkout) in a fresh
process with ``PYTHONPATH=<checkout>``, the three-point-bend fitter wrapped by
``time.process_time`` (every E_s fit of the study, nothing else); the checkouts take turns, so a
load that comes and goes on a shared machine hits them alike. Prints per checkout the best and
the median CPU and every run, the ratio of the best to the first checkout's, and every E_s with
its standard error and its distance from the first checkout's value in standard errors.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import json, time
from matid.app import cli, pipeline
from matid.io.study import load_study

spent = [0.0]
fitter = pipeline.FITTERS["three_point_bend"]


def timed(*args, **kwargs):
    start = time.process_time()
    try:
        return fitter(*args, **kwargs)
    finally:
        spent[0] += time.process_time() - start


pipeline.FITTERS["three_point_bend"] = timed
result = pipeline.run_study(load_study(cli.demo_study_path()))
values = {
    f"{fit.specimen} {e.parameter}": [e.value, e.stderr]
    for fit in result.fits
    if fit.kind == "three_point_bend"
    for e in fit.estimates
}
print(json.dumps({"cpu": spent[0], "values": values, "matid": pipeline.__file__}))
"""


def _once(checkout: str) -> dict:
    env = dict(os.environ, PYTHONPATH=os.path.abspath(checkout))
    out = subprocess.run(  # from the temporary folder: no matid of the current directory first
        [sys.executable, "-c", CHILD], env=env, cwd=tempfile.gettempdir(), check=True,
        capture_output=True, text=True,
    ).stdout  # fmt: skip
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("checkouts", nargs="+", help="source trees to put on PYTHONPATH")
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    runs: dict[str, list[dict]] = {c: [] for c in args.checkouts}
    for _ in range(args.runs):
        for c in args.checkouts:
            runs[c].append(_once(c))
    first = args.checkouts[0]
    best_first = min(r["cpu"] for r in runs[first])
    reference = runs[first][0]["values"]
    for c, done in runs.items():
        cpu = [r["cpu"] for r in done]
        every = " ".join(f"{t:.3f}" for t in cpu)
        assert done[0]["matid"].startswith(os.path.abspath(c)), done[0]["matid"]
        print(f"{c}: best {min(cpu):.3f} s, median {statistics.median(cpu):.3f} s "
              f"({min(cpu) / best_first:.2f}x the first's best); runs {every}")  # fmt: skip
        for name, (value, se) in done[0]["values"].items():
            ref = reference.get(name)
            apart = f", {abs(value - ref[0]) / ref[1]:.2g} stderr from the first" if ref and ref[1] else ""
            print(f"  {name} = {value!r} +- {se!r}{apart}")


if __name__ == "__main__":
    main()
