"""Time of the extension fits: the demo study's, and a long relaxation record's.

Compare two checkouts, interleaved (each run a fresh process, best of ``--repeat``)::

    python benchmarks/extension_time.py demo OLD_CHECKOUT NEW_CHECKOUT [--repeat 5]

prints the wall and process CPU time of the demo's :func:`fit_extension` calls (the
module attribute is wrapped before the pipeline imports it) and of the whole
``run_study``. ``long N DT CHECKOUT`` times ``matid fit`` (reading, fits, report: the
user's wall time) on a ramp + hold relaxation of N rows at step DT written by
tests/fits/extension/relaxation.py (a solve_ivp record in an Instron Bluehill export).

Measured 2026-11-26 on 2 cores at load 11-13 (shared machine), old = 1747a33 (scipy
port, no lmfit), new = branch lmfit:

- demo, best of 5 interleaved: extension fits CPU 0.52 s old, 0.68 s new (wall 1.62 /
  2.05 s); lmfit's overhead per Minimizer and Parameters copy (asteval, deepcopy).
- ``long 90000 0.05``: new exit 0, 27.7 s and 24.7 s wall, 6.8 s and 7.1 s CPU (fits on
  bin means, report included); old exit 3 (KeyError 'time') after 137.6 s wall, 34.3 s
  CPU.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

_DEMO = r"""
import json, time
from matid.fits.extension import fit as extension
spent = {"wall": 0.0, "cpu": 0.0}
original = extension.fit_extension
def timed(*args, **kwargs):
    w, c = time.perf_counter(), time.process_time()
    try:
        return original(*args, **kwargs)
    finally:
        spent["wall"] += time.perf_counter() - w
        spent["cpu"] += time.process_time() - c
extension.fit_extension = timed
from pathlib import Path
from matid.app import pipeline
from matid.io.study import load_study
study = load_study(Path("matid/example/study.toml"))
w = time.perf_counter()
pipeline.run_study(study)
spent["run_study"] = time.perf_counter() - w
print(json.dumps(spent))
"""


def _demo_once(checkout: str) -> dict:
    env = {**os.environ, "PYTHONPATH": checkout}
    done = subprocess.run(
        [sys.executable, "-c", _DEMO], cwd=checkout, env=env, capture_output=True, text=True, check=True
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def demo(old: str, new: str, repeat: int) -> None:
    best: dict[str, dict] = {}
    for _ in range(repeat):
        for label, checkout in (("old", old), ("new", new)):
            got = _demo_once(checkout)
            mine = best.setdefault(label, got)
            for key, value in got.items():
                mine[key] = min(mine[key], value)
    for label, times in best.items():
        fits = f"extension fits wall {times['wall']:.3f} s, cpu {times['cpu']:.3f} s"
        print(f"{label}: {fits}; run_study {times['run_study']:.2f} s")


def long(n: int, dt: float, checkout: str) -> None:
    sys.path.insert(0, str(ROOT))
    from tests.fits.extension.relaxation import make_study

    with tempfile.TemporaryDirectory() as tmp:
        study = make_study(Path(tmp) / "study", n=n, dt=dt)
        env = {**os.environ, "PYTHONPATH": checkout}
        start, cpu = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
        done = subprocess.run(
            [sys.executable, "-m", "matid", "fit", str(study), "--out", str(Path(tmp) / "out"), "--quiet"],
            cwd=checkout,
            env=env,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - start
        used = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu_s = used.ru_utime + used.ru_stime - cpu.ru_utime - cpu.ru_stime
    load = os.getloadavg()[0]
    print(f"matid fit on {n} rows: exit {done.returncode}, wall {wall:.1f} s, cpu {cpu_s:.1f} s", end="")
    print(f", load {load:.1f}")
    if done.returncode:
        print(done.stderr[-2000:])


if __name__ == "__main__":
    if sys.argv[1] == "demo":
        repeat = int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 5
        demo(sys.argv[2], sys.argv[3], repeat)
    else:
        long(int(sys.argv[2]), float(sys.argv[3]), sys.argv[4])
