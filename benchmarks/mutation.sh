#!/usr/bin/env bash
# Mutation testing of matid's core maths: a seeded sample of mutmut 3 mutants per file.
#
#   benchmarks/mutation.sh [SAMPLE] [SEED] [FILE...]
#
# SAMPLE  mutants per file (default 30); "all" runs every mutant of the files (a full run).
# SEED    the sample's seed (default 29); the same seed and source give the same mutants.
# FILE    files (globs, relative to the repository) to mutate instead of FILES below.
# MAX_CHILDREN (environment, default 1): mutants run in parallel.
# TESTS (environment, optional): space-separated test paths that replace pyproject's
# pytest_add_cli_args_test_selection for this run (a narrow selection makes mutmut's first pass short).
# OUT, TMPDIR (environment): where the results go (default benchmarks/results/mutation) and where the
# copy is made; give two runs at once different ones.
#
# Not in CI: 30 mutants of each of the 9 physics/newton/linear files take ~20 min on one core.
# The tests that may kill a mutant are pyproject's [tool.mutmut] pytest_add_cli_args_test_selection;
# mutmut runs, for each mutant, those of them that called the mutated function.
# The run happens in a copy of the working tree (tracked and untracked files, not ignored ones) in
# $TMPDIR/matid-mutation, so the tree can change while it runs. It prints, and writes to
# benchmarks/results/mutation/table.md, a table file -> killed/total; survivors.txt holds the diff
# of every survivor (mutmut show). Equivalent mutants we know of: benchmarks/mutation_equivalent.md.
set -euo pipefail

# The core files (update when files move).
FILES=(
    "matid/physics/*.py"
    "matid/rod/newton.py"
    "matid/rod/fem.py"
    "matid/rod/models.py"
    "matid/fits/linear.py"
    "matid/fits/extension/*.py"
    "matid/fits/shear/*.py"
    "matid/io/ingest/*.py"
)

SAMPLE=${1:-30}
SEED=${2:-29}
shift $(( $# < 2 ? $# : 2 ))
if (( $# )); then FILES=("$@"); fi
MAX_CHILDREN=${MAX_CHILDREN:-1}

ROOT=$(cd "$(dirname "$0")/.." && pwd)
OUT=${OUT:-$ROOT/benchmarks/results/mutation}
WORK=${TMPDIR:-/tmp}/matid-mutation  # outside the repository: mutmut asks git about its folder
rm -rf "$OUT" "$WORK"
mkdir -p "$OUT" "$WORK"
cd "$ROOT"
git ls-files -z --cached --others --exclude-standard \
    | tar --null --ignore-failed-read -T - -cf - 2>/dev/null | tar -xf - -C "$WORK"
cd "$WORK"
unset PYTHONPATH  # the tests must import mutants/matid, not the tree's matid

# Mutate only FILES: `only_mutate` (glob patterns) goes into the copy's [tool.mutmut].
TESTS=${TESTS:-} python - "${FILES[@]}" <<'EOF'
import json, os, re, sys
from pathlib import Path
p = Path("pyproject.toml")
text = p.read_text()
assert "\n[tool.mutmut]\n" in text and "\nonly_mutate" not in text
text = text.replace("\n[tool.mutmut]\n", f"\n[tool.mutmut]\nonly_mutate = {json.dumps(sys.argv[1:])}\n")
if os.environ["TESTS"]:
    line = re.compile(r"^pytest_add_cli_args_test_selection = .*$", re.M)
    assert len(line.findall(text)) == 1
    text = line.sub(lambda m: f"pytest_add_cli_args_test_selection = {json.dumps(os.environ['TESTS'].split())}", text)
p.write_text(text)
EOF

# Generate every mutant of FILES (mutmut's own first step of `mutmut run`), without running tests.
python - "$MAX_CHILDREN" <<'EOF' > "$OUT/generate.log" 2>&1
import sys
from mutmut.__main__ import copy_also_copy_files, copy_src_dir, create_mutants, setup_source_paths
copy_src_dir()
copy_also_copy_files()
setup_source_paths()
create_mutants(int(sys.argv[1]))
EOF

# Draw the sample: per file, random.Random(f"{SEED} {file}").sample of its sorted mutant names, so a
# file's sample does not depend on which other files are listed.
mutmut results --all true > "$OUT/all.txt"
python - "$SAMPLE" "$SEED" "$OUT/all.txt" > "$OUT/sample.txt" <<'EOF'
import random, sys
from collections import defaultdict
sample, seed, listing = sys.argv[1], sys.argv[2], sys.argv[3]
by_file = defaultdict(list)
for line in open(listing):
    name = line.strip().rpartition(":")[0]
    if name:
        by_file[name.rpartition(".")[0].replace(".", "/") + ".py"].append(name)
for file, names in sorted(by_file.items()):
    names.sort()
    chosen = names if sample == "all" else random.Random(f"{seed} {file}").sample(names, min(int(sample), len(names)))
    print("\n".join(sorted(chosen)))
EOF
echo "$(wc -l < "$OUT/sample.txt") mutants sampled (sample $SAMPLE per file, seed $SEED) of $(wc -l < "$OUT/all.txt")"

start=$(date +%s)
xargs -a "$OUT/sample.txt" mutmut run --max-children "$MAX_CHILDREN" > "$OUT/run.log" 2>&1 \
    || { tail -40 "$OUT/run.log"; exit 1; }
elapsed=$(( $(date +%s) - start ))

mutmut results --all true > "$OUT/results.txt"
python - "$OUT/sample.txt" "$OUT/results.txt" "$SAMPLE" "$SEED" "$elapsed" > "$OUT/table.md" <<'EOF'
import sys
from collections import Counter, defaultdict
sample_file, results_file, sample, seed, elapsed = sys.argv[1:]
chosen = set(open(sample_file).read().split())
status = {}
for line in open(results_file):
    name, _, st = line.strip().rpartition(": ")
    if name in chosen:
        status[name] = st
by_file = defaultdict(Counter)
for name, st in status.items():
    by_file[name.rpartition(".")[0].replace(".", "/") + ".py"][st] += 1
# A mutant is caught when a test fails on it or it runs out of time (a hang the tests reach).
caught = ("killed", "timeout")
print(f"mutmut 3, sample {sample} per file, seed {seed}, {len(status)} mutants, {elapsed} s\n")
print("| file | killed/total | % | survived | no tests | timeout | other |")
print("| --- | --- | --- | --- | --- | --- | --- |")
total = Counter()
for file, c in sorted(by_file.items()):
    total += c
    n, k = sum(c.values()), sum(c[s] for s in caught)
    other = n - k - c["survived"] - c["no tests"]
    print(f"| {file} | {k}/{n} | {100 * k / n:.0f} % | {c['survived']} | {c['no tests']} | {c['timeout']} | {other} |")
n, k = sum(total.values()), sum(total[s] for s in caught)
print(f"| all | {k}/{n} | {100 * k / max(n, 1):.0f} % | {total['survived']} | {total['no tests']} |"
      f" {total['timeout']} | {n - k - total['survived'] - total['no tests']} |")
others = sorted(f"{name}: {st}" for name, st in status.items() if st not in caught + ("survived",))
if others:
    print("\nnot killed, not survived:\n" + "\n".join(others))
EOF
cat "$OUT/table.md"

# The diff of every mutant not caught, to read.
grep -E ": (survived|no tests|suspicious|skipped)$" "$OUT/results.txt" | sed 's/: .*//' | sed 's/^ *//' \
    | grep -Fxf "$OUT/sample.txt" | while read -r name; do mutmut show "$name"; echo; done > "$OUT/survivors.txt" || true
echo "survivors: $OUT/survivors.txt"
