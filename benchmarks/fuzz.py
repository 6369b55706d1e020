"""The long fuzz run of issue 12: thousands of mutated studies and scenes, and a kill -9 loop.

    nice -n 10 python benchmarks/fuzz.py --examples 5000 --kills 50

runs ``pytest tests/test_fuzz.py --hypothesis-profile=long`` with ``--examples``
cases per fuzz test (study and scene), every outcome logged as JSON lines, then
the kill -9 loop, and prints: cases, outcomes by exit code and stage, uncaught
exceptions (exit 3), hangs, half-written folders, and the kill loop's result.
Knobs: MATID_FUZZ_FULL_ONE_IN (one in N accepted inputs runs the whole command,
default here 100) and the three-point-bend whole runs, on here (MATID_FUZZ_BEND=1).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=5000, help="cases per fuzz test (2 tests)")
    parser.add_argument("--kills", type=int, default=50, help="kill -9 trials")
    parser.add_argument("--log", type=Path, default=Path(tempfile.gettempdir()) / "matid-fuzz.jsonl")
    parser.add_argument("--full-one-in", default=os.environ.get("MATID_FUZZ_FULL_ONE_IN", "100"))
    args = parser.parse_args()
    args.log.unlink(missing_ok=True)
    env = {
        **os.environ,
        "MATID_FUZZ_LOG": str(args.log),
        "MATID_FUZZ_EXAMPLES": str(args.examples),
        "MATID_FUZZ_FULL_ONE_IN": str(args.full_one_in),
        "MATID_FUZZ_BEND": "1",
        "MATID_FUZZ_LIMIT": os.environ.get("MATID_FUZZ_LIMIT", "300"),  # 2 shared cores: slow is not a hang
        "MATID_FUZZ_COLLECT": "1",  # count every outcome; do not stop at the first bad one
    }
    clock = time.perf_counter()
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/test_fuzz.py",
           "-k", "fuzzed", "--hypothesis-profile=long", "--hypothesis-show-statistics"]  # fmt: skip
    pytest = subprocess.run(cmd, cwd=ROOT, env=env, check=False)
    fuzz_s = time.perf_counter() - clock
    print(summarise(args.log, fuzz_s, pytest.returncode))
    if args.kills:
        import fuzzkit

        with tempfile.TemporaryDirectory() as tmp:
            states = fuzzkit.kill_loop(Path(tmp) / "out", trials=args.kills, seed=12)
        mixed = [s for s in states if s != "whole"]
        print(
            f"kill -9 loop: {len(states)} trials, {len(states) - len(mixed)} whole, "
            f"{len(mixed)} mixed {mixed[:3]}"
        )
    return 0 if pytest.returncode == 0 and not bad(args.log) else 1


def bad(log: Path) -> int:
    """How many logged cases ended in an outcome that is not allowed."""
    import fuzzkit

    records = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    fields = ("code", "stage", "seconds", "message", "folder")
    return sum(fuzzkit.allowed(fuzzkit.Outcome(**{k: r[k] for k in fields})) is not None for r in records)


def summarise(log: Path, seconds: float, returncode: int) -> str:
    records = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    codes = collections.Counter(str(r["code"]) for r in records)
    stages = collections.Counter((r["target"].split("/")[0], r["stage"], str(r["code"])) for r in records)
    uncaught = [r for r in records if r["code"] == 3]
    hangs = [r for r in records if r["code"] == "hang"]
    half = [r for r in records if r["stage"] == "full" and r["folder"] not in ("", "old", "new")]
    lines = [
        f"fuzz: {len(records)} cases in {seconds:.0f} s (pytest exit {returncode})",
        f"  by exit code: {dict(sorted(codes.items()))}",
        "  by target/stage/exit: " + ", ".join(f"{'/'.join(k)}: {v}" for k, v in sorted(stages.items())),
        f"  uncaught exceptions (exit 3): {len(uncaught)}",
        f"  hangs: {len(hangs)}",
        f"  half-written folders: {len(half)}",
        f"  slowest case: {max((r['seconds'] for r in records), default=0):.1f} s",
    ]
    for r in (uncaught + hangs + half)[:10]:
        lines.append(f"  ! {r['target']} {r['labels']}: {r['code']} {r['message'][:300]}")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
