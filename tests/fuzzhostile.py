"""The hostile classes of the fuzzer (issue 20, docs/contract.md section 11), beside tests/fuzzkit.py.

- **text**: hostile text (formula leads, control characters, bidi overrides, 100 000
  characters, unicode) in every field a study carries into its outputs: the study's
  name and temperature, the specimen id, a test's note, the data file's name, a CSV
  column header and a ``#`` metadata line;
- **paths**: a test's file outside the study (``../``, absolute, a link leading out, a
  link loop), with and without ``[study] allow_outside``;
- **nesting**: study and scene TOML nested around :data:`matid.limits.MAX_TOML_DEPTH`
  and far past it (arrays, inline tables, dotted keys, table names);
- **signals**: SIGINT, SIGTERM or SIGKILL at a random moment of a ``matid fit`` of one
  study or of a batch, run as a process in a session of its own.

Besides the outcome rules of fuzzkit, a case is bad when a written CSV holds a text cell
starting with a formula lead or an XLSX sheet holds a formula (``<f>``), when a file
outside the study was read, and, for signals, when the run does not end within
:data:`STOP_S` of the signal, exits with a code other than 0-2, 130, 143 or by the signal,
leaves a process of its session alive :data:`STOP_S` later, changes its output folder
after the signal (or, for a killed parent, after its death; compared with a snapshot taken
as soon as the signal is sent), or leaves a study's folder half-written.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

from hypothesis import strategies as st

from tests import ROOT, fuzzkit

#: Seconds within which a signalled run must end, and after which no process of it may live.
STOP_S = 5.0
FORMULA_LEADS = ("=", "+", "-", "@", "\t", "\r")
#: Text a hostile user writes into a field.
HOSTILE_TEXT = [
    "=cmd|' /C calc'!A0", '=HYPERLINK("http://evil.example","x")', "+1+1", "-1+1", "@SUM(1)", "\t=1",
    "\r=1", "x\r=1+1", "#N/A", "T\x1b[31m1", "bell\x07", "nul\x00x", "del\x7f", "c1\x85", "\u202etxt.exe",
    "x" * 100_000, "漢字", "'", '"', "a,b", "a;b", "line\nbreak", "../up", "/etc/passwd", "-1", "-1e-3",
]  # fmt: skip
#: Where a study case puts hostile text.
TEXT_FIELDS = ["name", "temperature", "id", "note", "file", "header", "meta"]


def session_pids(sid: int) -> list[int]:
    """Living (not zombie) processes of the session ``sid`` (a run started with start_new_session)."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if int(fields[3]) == sid and fields[0] not in ("Z", "X"):
            pids.append(int(entry.name))
    return pids


def snapshot(out: Path) -> dict[str, tuple[int, int]]:
    """Every visible file under ``out`` (hidden temp folders and locks left out): inode and mtime."""
    if not out.is_dir():
        return {}
    files = {}
    # os.walk, not rglob: a hidden temp folder the run removes while it is walked is skipped, where
    # rglob descended into it and raised FileNotFoundError (seen once in a batch signal test)
    for root, dirs, names in os.walk(out):
        dirs[:] = [d for d in dirs if not d.startswith(".")]
        for name in [*dirs, *names]:
            if name.startswith("."):
                continue
            path = Path(root) / name
            try:
                info = path.stat()
            except FileNotFoundError:
                continue
            files[str(path.relative_to(out))] = (info.st_ino, info.st_mtime_ns)
    return files


def half_written(out: Path, batch: bool) -> list[str]:
    """Study folders under ``out`` (or ``out`` itself) missing an output a whole report has."""
    folders = [p for p in out.iterdir() if p.is_dir() and not p.name.startswith(".")] if batch else [out]
    want = {"report.html", "report.pdf", "stiffness.csv", "stiffness.json", "stiffness.xlsx"}
    return [str(f) for f in folders if f.is_dir() and not want <= {p.name for p in f.iterdir()}]


def formula_cells(out: Path) -> list[str]:
    """Formula-leading text cells of every CSV and formulas of every XLSX sheet under ``out``."""
    bad = []
    for path in out.rglob("*.csv") if out.is_dir() else []:
        text = path.read_bytes().decode("utf-8", "replace")
        if "\r" in text:
            bad.append(f"{path.name}: a lone CR")
        for row in csv.reader(io.StringIO(text)):
            bad += [f"{path.name}: {c[:40]!r}" for c in row if c.startswith(FORMULA_LEADS) and not _number(c)]
    for path in out.rglob("*.xlsx") if out.is_dir() else []:
        with zipfile.ZipFile(path) as book:
            for name in book.namelist():
                if name.startswith("xl/worksheets/") and re.search(rb"<f[ >]", book.read(name)):
                    bad.append(f"{path.name}/{name}: <f>")
    return bad


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _default_sigint() -> None:
    """In the child: SIGINT as a terminal sends it. A shell without job control starts a background
    job with SIGINT ignored, and Python then installs no KeyboardInterrupt handler: a fuzz run started
    with ``&`` would find every SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def run_signalled(argv: list[str], out: Path, sig: int, *, after: float | None = None,
                  on_publish: bool = False, batch: bool = False) -> dict:  # fmt: skip
    # batch: ``out`` holds study folders (each checked whole); else the caller checks ``out`` itself
    """Run ``python -m matid`` + ``argv`` in a new session; send ``sig`` ``after`` seconds in, or once
    the first output is published (``on_publish``); what followed (see the module docstring)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    clock = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "matid", *argv], cwd=ROOT, env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            preexec_fn=_default_sigint)  # fmt: skip
    first = snapshot(out)
    while proc.poll() is None and time.monotonic() - clock < 600:
        if (after is not None and time.monotonic() - clock >= after) or (
            on_publish and snapshot(out).keys() - first.keys()
        ):
            break
        time.sleep(0.02)
    sent = proc.poll() is None
    if sent:
        proc.send_signal(sig)
    before = snapshot(out)  # right after the signal: a publication the signal found half-way may land
    try:
        code: int | str = proc.wait(STOP_S if sent else 600)
    except subprocess.TimeoutExpired:
        code = "hang"
        proc.kill()
        proc.wait()
    stopped_s = time.monotonic() - clock
    deadline = time.monotonic() + STOP_S
    while session_pids(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    alive = session_pids(proc.pid)
    for pid in alive:  # leave nothing behind for the next case
        os.kill(pid, signal.SIGKILL)
    err = proc.stderr.read().decode("utf-8", "replace")
    proc.stderr.close()
    changed = sorted(set(snapshot(out).items()) ^ set(before.items())) if sent else []
    half = half_written(out, True) if batch and out.is_dir() else []
    return {"sent": sent, "code": code, "seconds": stopped_s, "alive": alive, "changed": changed[:5],
            "half": half, "message": err[-500:]}  # fmt: skip


def signal_problem(result: dict, sig: int) -> str | None:
    """None when a signalled run behaved (module docstring), else what went wrong."""
    allowed = {0, 1, 2, 130 if sig == signal.SIGINT else 143, -sig}
    if result["code"] == "hang":
        return f"no exit within {STOP_S} s of signal {sig}"
    if result["code"] not in allowed:
        return f"exit {result['code']} after signal {sig}: {result['message'][-300:]}"
    if result["alive"]:
        return f"{len(result['alive'])} processes alive {STOP_S} s after the run ended"
    if result["changed"]:
        return f"output changed after the signal: {result['changed']}"
    if result["half"]:
        return f"half-written folders: {result['half']}"
    return None


# -- strategies ------------------------------------------------------------------


def hostile_text() -> st.SearchStrategy[str]:
    """Text from :data:`HOSTILE_TEXT`, or any short text behind a formula lead."""
    led = st.tuples(st.sampled_from(FORMULA_LEADS), st.text(max_size=30)).map("".join)
    return st.sampled_from(HOSTILE_TEXT) | led


@st.composite
def text_cases(draw):
    """A torsion study case of fuzzkit's form with hostile text in one field (and its label)."""
    field, text = draw(st.sampled_from(TEXT_FIELDS)), draw(hostile_text())
    tests = [dict(t) for t in fuzzkit.TEMPLATES["torsion"]["tests"]]
    doc = {"study": dict(fuzzkit.HEADER), "specimen": [dict(fuzzkit.SPECIMEN)], "test": tests}
    files = {t["file"]: (fuzzkit.DEMO / t["file"]).read_text(encoding="utf-8") for t in tests}
    if field in ("name", "temperature"):
        doc["study"][field] = text
    elif field == "id":
        doc["specimen"][0]["id"] = text
        for t in tests:
            t["specimen"] = text
    elif field == "note":
        tests[0]["note"] = text
    elif field == "file":  # a "/" makes a folder: the paths class covers names that lead elsewhere
        files[text.replace("/", "_")] = files.pop(tests[0]["file"])
        tests[0]["file"] = text.replace("/", "_")
    else:
        name = tests[0]["file"]
        lines = files[name].split("\n")
        at = next(i for i, line in enumerate(lines) if not line.startswith("#"))
        if field == "header":
            lines[at] = lines[at].replace("torque", text.replace(",", " ")[:200] + " torque", 1)
        else:
            lines.insert(0, f"# operator: {text}")
        files[name] = "\n".join(lines)
    full = fuzzkit._one_in(max(fuzzkit.FULL_ONE_IN // 5, 1), field, text)
    return "torsion", fuzzkit.toml_dumps(doc), files, [f"text {field}: {text[:30]!r}"], full


def _write_safely(folder: Path, name: str, content: str | bytes) -> bool:
    """Write a data file under a hostile name when the file system takes the name; False otherwise."""
    try:
        path = folder / name
        if not path.resolve().is_relative_to(folder.resolve()) or "\x00" in name:
            return False
        path.parent.mkdir(parents=True, exist_ok=True)
        fuzzkit._write(path, content)
        return True
    except (OSError, ValueError):
        return False


def run_text_case(case, work: Path) -> fuzzkit.Outcome:
    """fuzzkit's study run, with hostile file names written where possible, then the cells checked."""
    kind, toml, files, labels, full = case
    safe = {n: c for n, c in files.items() if _write_safely(work / "probe", n, c)}
    shutil.rmtree(work / "probe", ignore_errors=True)
    outcome = fuzzkit.run_study_case((kind, toml, safe, labels, full), work)
    bad = formula_cells(work / "out") if outcome.stage == "full" else []
    if bad:
        outcome.code, outcome.message = "formula", "; ".join(bad[:3])
    return outcome


@st.composite
def path_cases(draw):
    """(study folder builder, label, allowed outside?): a test file that may lie outside the study."""
    how = draw(
        st.sampled_from(["parent", "absolute", "link_out", "link_in", "loop", "inside_abs", "dotdot_in"])
    )
    allow = draw(st.booleans())
    return how, allow


def run_path_case(case, work: Path) -> fuzzkit.Outcome:
    """Build the study of a path case and load it and its files: outside without leave is exit 2."""
    from matid.errors import DataError
    from matid.io.ingest.read import load_measurements
    from matid.io.study import load_study

    how, allow = case
    shutil.rmtree(work, ignore_errors=True)
    study, secret = work / "study", work / "secret.csv"
    study.mkdir(parents=True)
    body = (fuzzkit.DEMO / "torsion_T1_L60.csv").read_text(encoding="utf-8")
    secret.write_text("# api_key: SECRET-20\n" + body, encoding="utf-8")
    (study / "in.csv").write_text(body, encoding="utf-8")
    name = {"parent": "../secret.csv", "absolute": str(secret), "link_out": "out.csv", "link_in": "lin.csv",
            "loop": "loop.csv", "inside_abs": str(study / "in.csv"),
            "dotdot_in": "../study/in.csv"}[how]  # fmt: skip
    if how == "link_out":
        (study / "out.csv").symlink_to(secret)
    elif how == "link_in":
        (study / "lin.csv").symlink_to(study / "in.csv")
    elif how == "loop":
        (study / "loop.csv").symlink_to(study / "loop.csv")
    head = {**fuzzkit.HEADER, "allow_outside": allow}
    test = {"kind": "torsion", "specimen": "T1", "file": name, "length": "60 mm"}
    doc = {"study": head, "specimen": [dict(fuzzkit.SPECIMEN)], "test": [test]}
    (study / "study.toml").write_text(fuzzkit.toml_dumps(doc), encoding="utf-8")
    clock = time.perf_counter()
    outside = how in ("parent", "absolute", "link_out")
    try:
        tables = load_measurements(load_study(study))
        code, message = 0, ""
        read = [m.table.metadata for m in tables]
        if outside and not allow:
            code, message = "outside", f"read a file outside the study: {read}"
    except DataError as exc:
        code, message = 2, str(exc)
        if outside and not allow and "file" not in message:
            code = "unnamed"
        if not outside and how != "loop":
            code, message = "refused", f"refused a file inside the study: {message}"
    except Exception as exc:  # noqa: BLE001
        code, message = 3, f"{type(exc).__name__}: {exc}"
    return fuzzkit.Outcome(code, "input", time.perf_counter() - clock, message)


@st.composite
def nesting_cases(draw):
    """(target "study" or "scene", TOML text, label): nesting near and far past MAX_TOML_DEPTH."""
    from matid.limits import MAX_TOML_DEPTH

    depth = draw(st.integers(1, 2 * MAX_TOML_DEPTH + 2) | st.sampled_from([400, 1000, 5000, 20_000]))
    form = draw(st.sampled_from(["array", "inline", "dotted", "header", "mixed"]))
    if form == "array":
        text = "x = " + "[" * depth + "1" + "]" * depth
    elif form == "inline":
        text = "x = " + "{a = " * depth + "1" + "}" * depth
    elif form == "dotted":
        text = ".".join(["a"] * depth) + " = 1"
    elif form == "header":
        text = "[" + ".".join(["a"] * depth) + "]\nx = 1"
    else:
        text = "x = " + "[{a = " * (depth // 2) + "1" + "}]" * (depth // 2)
    target = draw(st.sampled_from(["study", "scene"]))
    base = fuzzkit.SCENES[0].read_text(encoding="utf-8") if target == "scene" else fuzzkit.toml_dumps(
        {"study": dict(fuzzkit.HEADER), "specimen": [dict(fuzzkit.SPECIMEN)],
         "test": [dict(t) for t in fuzzkit.TEMPLATES["torsion"]["tests"]]})  # fmt: skip
    return target, text + "\n" + base if form != "header" else base + "\n" + text + "\n", f"{form} {depth}"


def run_nesting_case(case, work: Path) -> fuzzkit.Outcome:
    target, text, label = case
    if target == "scene":
        return fuzzkit.run_scene_case((fuzzkit.SCENES[0].stem, text, {}, [label], False), work)
    files = {t["file"]: (fuzzkit.DEMO / t["file"]).read_text(encoding="utf-8")
             for t in fuzzkit.TEMPLATES["torsion"]["tests"]}  # fmt: skip
    return fuzzkit.run_study_case(("torsion", text, files, [label], False), work)


def log(record: dict) -> None:
    """Append a hostile case's record to $MATID_FUZZ_LOG (JSON lines) when set."""
    path = os.environ.get("MATID_FUZZ_LOG")
    if path:
        with open(path, "a", encoding="utf-8") as handle:
            handle.write(json.dumps(record, default=str) + "\n")
