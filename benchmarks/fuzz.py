"""The long fuzz run of issues 12 and 20: mutated and hostile studies and scenes, signals, a kill -9 loop.

    nice -n 10 python benchmarks/fuzz.py --examples 3500 --signals 120 --kills 50
    nice -n 10 python benchmarks/fuzz.py --scenes-solved 6000   # issue 30: scenes through the solver
    nice -n 10 python benchmarks/fuzz.py --studies 1000         # issue 30: studies through matid fit

runs ``pytest tests/test_fuzz.py --hypothesis-profile=long`` with ``--examples``
cases per fuzz test (study, scene, and the hostile classes of tests/fuzzhostile.py:
text, paths, nesting; hypothesis stops a class early once it has tried every case
of it), ``--signals`` signalled runs, every outcome logged as JSON lines, then the
kill -9 loop, and prints: cases by class, outcomes by exit code and stage, uncaught
exceptions (exit 3), hangs, half-written or later-changed folders, processes alive
5 s after a signalled or killed run, formulas in a sheet or formula-leading text
cells in a CSV, files read from outside a study, and the kill loop's result.
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
sys.path[:0] = [str(ROOT / "tests"), str(ROOT)]  # fuzzkit imports tests.ROOT


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=5000, help="cases per fuzz test (2 tests)")
    parser.add_argument("--kills", type=int, default=50, help="kill -9 trials")
    parser.add_argument("--signals", type=int, default=100, help="signalled single and batch runs")
    parser.add_argument("--scenes-solved", type=int, default=0,
                        help="only the solver fuzz (issue 30): this many mutated scenes, each solved end to end")  # fmt: skip
    parser.add_argument("--studies", type=int, default=0,
                        help="only the fit fuzz (issue 30): this many mutated studies, "
                        "each fitted end to end")  # fmt: skip
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
        "MATID_FUZZ_SIGNALS": str(max(args.signals, 1)),  # hypothesis needs max_examples >= 1 ...
    }
    clock = time.perf_counter()
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/test_fuzz.py",
           "-k", "fuzzed" if args.signals else "fuzzed and not signals",  # ... so 0 deselects the test
           "--hypothesis-profile=long", "--hypothesis-show-statistics"]  # fmt: skip
    if args.scenes_solved:  # issue 30: through the solver; a case past 60 s is a hang
        env.update(MATID_FUZZ_SOLVED=str(args.scenes_solved), MATID_FUZZ_LIMIT="60")
        cmd[cmd.index("-k") + 1] = "fuzzed_scene_solved"
        args.kills = 0
    if args.studies:  # issue 30: matid fit of each; a case past 120 s is a hang
        env.update(MATID_FUZZ_FITTED=str(args.studies))
        env.pop("MATID_FUZZ_SOLVED", None)
        k = cmd.index("-k") + 1
        both = "fuzzed_scene_solved or fuzzed_study_fitted"
        cmd[k] = both if args.scenes_solved else "fuzzed_study_fitted"
        args.kills = 0
        if args.scenes_solved:
            env["MATID_FUZZ_SOLVED"] = str(args.scenes_solved)
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


def problem(record: dict) -> str | None:
    """What is wrong with a logged case (None: allowed); signal cases carry their own verdict."""
    import fuzzkit

    if "problem" in record:
        return record["problem"]
    fields = ("code", "stage", "seconds", "message", "folder")
    outcome = fuzzkit.Outcome(**{k: record[k] for k in fields})
    if record["stage"] == "fitted":  # matid fit: exit 4 (outputs not written) is allowed too
        from tests import fuzzfit

        return fuzzfit.allowed(outcome)
    return fuzzkit.allowed(outcome)


def bad(log: Path) -> int:
    """How many logged cases ended in an outcome that is not allowed."""
    records = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    return sum(problem(r) is not None for r in records)


def counts(records: list[dict]) -> dict[str, list[dict]]:
    """The cases of each kind of failure the issues name."""
    signals = [r for r in records if r["stage"] == "signal"]
    return {
        "uncaught exceptions (exit 3)": [r for r in records if r["code"] == 3],
        "hangs (signals: no exit within 5 s)": [r for r in records if r["code"] == "hang"],
        "half-written folders": [
            r for r in records if r["folder"] not in ("", "old", "new") and not r["folder"].startswith("temp")
        ],
        "later-changed folders (after the signal)": [r for r in signals if r.get("changed")],
        "runs with a process alive 5 s after": [r for r in signals if r.get("alive")],
        "formula in a sheet or formula-leading CSV cell": [r for r in records if r["code"] == "formula"],
        "solved end to end": [r for r in records if r["stage"] == "solved"],
        "  of them with [[wall]], [lumen], [advance] or [[sweep]]": [
            r for r in records if r["stage"] == "solved" and any(x.startswith("keys:") for x in r["labels"])
        ],
        "studies fitted end to end (matid fit)": [r for r in records if r["stage"] == "fitted"],
        "silent absurdities (a value > 1e100, a load not in the energy)": [
            r for r in records if r["code"] == "absurd"
        ],
        "hangs (> the case limit)": [r for r in records if r["code"] == "hang" and r["stage"] != "signal"],
        "files read from outside a study without leave": [r for r in records if r["code"] == "outside"],
        "outside files refused without naming the key": [r for r in records if r["code"] == "unnamed"],
        "files inside a study refused": [r for r in records if r["code"] == "refused"],
    }


def summarise(log: Path, seconds: float, returncode: int) -> str:
    records = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
    codes = collections.Counter(str(r["code"]) for r in records)
    classes = collections.Counter(r["target"].split("/")[0] for r in records)
    stages = collections.Counter((r["target"].split("/")[0], r["stage"], str(r["code"])) for r in records)
    signals = [r for r in records if r["stage"] == "signal"]
    slowest = max(records, key=lambda r: r["seconds"], default=None)
    lines = [
        f"fuzz: {len(records)} cases in {seconds:.0f} s (pytest exit {returncode})",
        f"  by class: {dict(sorted(classes.items()))}",
        f"  by exit code: {dict(sorted(codes.items()))}",
        "  by target/stage/exit: " + ", ".join(f"{'/'.join(k)}: {v}" for k, v in sorted(stages.items())),
        f"  signals: {len(signals)} runs, {sum(bool(r.get('sent')) for r in signals)} signalled before they "
        f"ended; temp folders a SIGKILL left (removed by the next run): "
        f"{sum(r['folder'].startswith('temp') for r in signals)}",
        *[f"  {name}: {len(found)}" for name, found in counts(records).items()],
        f"  slowest case: {slowest['seconds']:.1f} s ({slowest['target']} {slowest['labels']})"
        if records
        else "",
        f"  cases not allowed: {sum(problem(r) is not None for r in records)}",
    ]
    for r in [r for r in records if problem(r) is not None][:10]:
        lines.append(f"  ! {r['target']} {r['labels']}: {r['code']} {str(problem(r))[:300]}")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
