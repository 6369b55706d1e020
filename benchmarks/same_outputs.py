"""Did a refactor change anything a user sees? Run matid on the demo, every example scene and a
two-study batch, and compare every output with a reference run made before the change.

    python benchmarks/same_outputs.py make  REF_DIR     # before the change (e.g. on main)
    python benchmarks/same_outputs.py check REF_DIR     # after it: exit 1 when any file differs

Compared: CSV and Markdown as text; JSON as data with run-time keys (``*runtime*``) left out;
XLSX cell by cell; HTML and PDF as text with run times and the checkout's path masked (the
'Run started' stamp and the
seconds of lines that report a run time); PNG byte for byte (matplotlib is deterministic for one
version). The runs use ``RL_invariant=1`` (reportlab's reproducible PDFs) and one job.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMED = re.compile(r"run time|Run started|runtime|elements: error|from scratch|Runtime", re.I)
RUN_TIME_FIGURE = re.compile(r'(<img src="data:image/png;base64,)[^"]*("[^>]*alt="[^"]*run time)')
#: Where runs put the batch's studies (each run's lots-in/; an older reference's temp folder): masked.
LOTS = [str(Path(tempfile.gettempdir()) / "matid-same-outputs-lots")]
SECONDS = re.compile(r"\d[\d.eE+-]*\s*(ms|s|UTC)\b|\d{4}-\d\d-\d\d \d\d:\d\d:\d\d")


def _runs(out: Path) -> list[tuple[str, list[str]]]:
    runs = [("demo", ["demo", "--out", str(out / "demo")])]
    for scene in sorted((ROOT / "examples" / "scenes").glob("*.toml")):
        runs.append((scene.stem, ["solve", str(scene), "--out", str(out / "scenes" / scene.stem)]))
    lots = out / "lots-in"  # the batch's studies (their path is masked in the views)
    for name in ("lotA", "lotB"):
        shutil.copytree(ROOT / "matid" / "example", lots / name, dirs_exist_ok=True)
    runs.append(("batch", ["fit", str(lots / "lotA"), str(lots / "lotB"), "--out", str(out / "batch"),
                           "--jobs", "1"]))
    return runs


def make(out: Path) -> None:
    """Run every case into ``out`` (emptied first); record each exit code."""
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    env = dict(os.environ, RL_invariant="1", MPLBACKEND="Agg")
    codes = {}
    for name, args in _runs(out):
        run = subprocess.run([sys.executable, "-m", "matid", *args, "--quiet"] if args[0] == "fit"
                             else [sys.executable, "-m", "matid", *args],
                             capture_output=True, text=True, env=env, cwd=tempfile.gettempdir())
        codes[name] = run.returncode
        (out / f"{name}.stdout").write_text(re.sub(SECONDS, "N", run.stdout.replace(str(out), "OUT")))
    (out / "exit_codes.json").write_text(json.dumps(codes, indent=1, sort_keys=True))


def _masked(text: str) -> str:
    """``text`` with the checkout's path and the batch studies' folder masked."""
    for lots in LOTS:
        text = text.replace(lots, "LOTS")
    text = text.replace(str(ROOT), "ROOT")
    # the demo's inputs, wherever the reference's matid ran from (a checkout, a worktree, site-packages)
    return INSTALLED.sub("ROOT/matid/", text)


INSTALLED = re.compile(r"(?:/[^/\s\"'<>]+)+?/matid/(?=example/)")


def _strip(data):
    if isinstance(data, dict):
        return {k: _strip(v) for k, v in data.items() if "runtime" not in k}
    if isinstance(data, list):
        return [_strip(v) for v in data]
    return data


def _text(path: Path) -> str:
    if path.suffix == ".pdf":
        from pypdf import PdfReader
        text = "\n".join(page.extract_text() for page in PdfReader(path).pages)
    else:
        text = path.read_text(errors="replace")
    text = _masked(text)  # the demo's inputs are named by their path in the checkout
    text = RUN_TIME_FIGURE.sub(r"\1\2", text)
    text = re.sub(r"\d[\d.]* s</td>", "N s</td>", text)  # the run-time column of summary.html
    return "\n".join(SECONDS.sub("N", line) if TIMED.search(line) else line for line in text.splitlines())


def _cells(path: Path) -> list:
    from openpyxl import load_workbook
    book = load_workbook(path)
    views = []
    for sheet in book:
        rows = [[_masked(c.value) if isinstance(c.value, str) else c.value for c in row]
                for row in sheet.iter_rows()]
        timed = [i for i, name in enumerate(rows[0] if rows else []) if "runtime" in str(name)]
        views.append((sheet.title, [[None if i in timed else v for i, v in enumerate(r)] for r in rows]))
    return views


def _view(path: Path):
    if path.suffix == ".json":
        return _strip(json.loads(_masked(path.read_text())))
    if path.suffix in {".csv", ".stdout"}:
        return _masked(path.read_text(errors="replace"))
    if path.suffix == ".xlsx":
        return _cells(path)
    if path.suffix in {".html", ".pdf"}:
        return _text(path)
    return path.read_bytes()


def check(ref: Path) -> int:
    """Run every case afresh and compare with ``ref``; print the files that differ."""
    new = Path(tempfile.mkdtemp(prefix="matid-same-outputs-"))  # concurrent checks never share it
    make(new)
    LOTS.extend([str(ref / "lots-in"), str(new / "lots-in")])
    def outputs(folder: Path) -> list[Path]:  # matid's empty lock files are not outputs
        return sorted(p.relative_to(folder) for p in folder.rglob("*")
                      if p.is_file() and not p.name.endswith(".matid-lock") and "lots-in" not in p.parts)

    files = outputs(ref)
    extra = [f for f in outputs(new) if not (ref / f).exists()]
    differ = [f for f in files if not (new / f).exists() or _view(ref / f) != _view(new / f)]
    for f in differ + extra:
        print(f"differs: {f}" if f in differ else f"new file: {f}")
    print(f"{len(differ) + len(extra)} of {len(files)} files differ")
    return 1 if differ or extra else 0


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in {"make", "check"}:
        sys.exit(__doc__)
    target = Path(sys.argv[2]).resolve()
    sys.exit(make(target) if sys.argv[1] == "make" else check(target))
