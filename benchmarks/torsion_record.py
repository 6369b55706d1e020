"""Wall time and peak memory of ``matid fit`` on one long load-return torsion record (issue 32.4).

    python benchmarks/torsion_record.py [--rows 7400000] [--keep DIR] [CHECKOUT]

Writes, in a temporary folder (or ``--keep DIR``), a one-test study (tube 2.4/1.6 mm,
``length = "50 mm"``) and its record: ``twist_angle [deg]`` = i mod 90 (load-return cycles
0..89 deg), ``torque [N m]`` = 2e-5 N m/deg x angle + N(0, 2e-5) (seed 1), written as ``%.0f`` and
``%.4e``; then runs ``python -m matid fit --quiet`` on it in a fresh process with
``PYTHONPATH=<checkout>`` (default: this one) and prints the file's size, the exit code, wall
and CPU seconds, the peak resident memory of the process (``ru_maxrss`` of the waited child) and
E_t against the generating value (2e-5 N m/deg x 180/pi x 50 mm = 5.72958e-5 N m^2).
10^7 rows (134 MiB) are over ``matid.limits.MAX_CSV_BYTES``: then the time to the refusal.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

STUDY = """[study]
name = "long load-return torsion record"

[[specimen]]
id = "T"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"

[[test]]
kind = "torsion"
specimen = "T"
file = "torsion.csv"
length = "50 mm"
"""
SLOPE = 2e-5  # N m per degree


def write_record(folder: Path, rows: int, chunk: int = 1_000_000) -> Path:
    """The study and its record (module docstring), written a chunk of rows at a time."""
    (folder / "study.toml").write_text(STUDY)
    path = folder / "torsion.csv"
    rng = np.random.default_rng(1)
    with path.open("w") as out:
        out.write("twist_angle [deg],torque [N m]\n")
        for start in range(0, rows, chunk):
            angle = (np.arange(start, min(start + chunk, rows)) % 90).astype(float)
            torque = SLOPE * angle + rng.normal(0.0, 2e-5, angle.size)
            np.savetxt(out, np.column_stack([angle, torque]), fmt=["%.0f", "%.4e"], delimiter=",")
    return path


def run(folder: Path, checkout: str) -> dict:
    env = dict(os.environ, PYTHONPATH=os.path.abspath(checkout))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    done = subprocess.run(  # from the folder: no matid of the current directory first
        [sys.executable, "-m", "matid", "fit", "--quiet", "--out", str(folder / "out"), str(folder)],
        cwd=folder, env=env, capture_output=True, text=True,
    )  # fmt: skip
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    out = {"exit": done.returncode, "wall_s": wall, "cpu_s": cpu, "peak_rss_MB": after.ru_maxrss / 1024}
    stiffness = folder / "out" / "stiffness.json"
    if done.returncode != 2 and stiffness.exists():
        rows = json.loads(stiffness.read_text())
        found = [r["E_t"]["value"] for r in _records(rows) if isinstance(r.get("E_t"), dict)]
        out["E_t"] = found[0] if found else None
    if done.returncode != 0:
        out["stderr"] = done.stderr.strip().splitlines()[-1:] if done.stderr else []
    return out


def _records(tree):
    """Every dict in a JSON tree (the estimates of stiffness.json wherever they sit)."""
    if isinstance(tree, dict):
        yield tree
        for value in tree.values():
            yield from _records(value)
    elif isinstance(tree, list):
        for value in tree:
            yield from _records(value)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("checkout", nargs="?", default=str(Path(__file__).resolve().parents[1]))
    parser.add_argument("--rows", type=int, default=7_400_000)
    parser.add_argument("--keep", help="write the study here (and keep it) instead of a temporary folder")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(args.keep or tmp)
        folder.mkdir(parents=True, exist_ok=True)
        record = folder / "torsion.csv"
        if not (args.keep and record.exists() and (folder / "rows").exists()
                and (folder / "rows").read_text() == str(args.rows)):  # fmt: skip
            write_record(folder, args.rows)
            (folder / "rows").write_text(str(args.rows))
        size = record.stat().st_size
        print(f"{args.rows} rows, {size / 2**20:.1f} MiB; checkout {args.checkout}")
        result = run(folder, args.checkout)
        print(json.dumps(result))
        if result.get("E_t"):
            print(f"E_t {result['E_t']:.6g} N m^2 (generated {SLOPE * 180 / np.pi * 0.05:.6g})")


if __name__ == "__main__":
    main()
