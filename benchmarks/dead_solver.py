"""The dead-solver check: which tests still pass when matid's Newton solver raises at entry?

    PYTHONPATH=$PWD python benchmarks/dead_solver.py [pytest arguments, default: tests]

runs pytest with this file as a plugin (``-p dead_solver``, ``benchmarks/`` on PYTHONPATH).
The plugin replaces each function of :data:`TARGETS` (the public solvers of matid.rod.newton and
matid.rod.batch),
wherever a matid module holds it (``from matid.rod.newton import newton`` included), by one
that counts the call and raises ConvergenceError at entry. A test that reached the dead solver
and still passed accepts a failure it did not expect, unless it expects that very error with
``pytest.raises`` (read from its source). The script lists both groups and exits 1 when the
first is not empty. Missing targets (a module renamed) are skipped and named; none found is an
error. Tests that run matid in a child process are not seen (the plugin lives in this process).
"""

from __future__ import annotations

import importlib
import inspect
import json
import os
import pkgutil
import re
import subprocess
import sys
from pathlib import Path

import pytest

#: (module, function) pairs made to raise; any one may be missing after a rename.
TARGETS = [
    ("matid.rod.newton", "newton"),
    ("matid.rod.newton", "follow"),
    ("matid.rod.batch", "newton"),  # the stacked Newton of many scenes (solve_many, sweeps)
    ("matid.rod.batch", "follow"),
]
#: Matches a test that expects the solver's error: pytest.raises(ConvergenceError or a subclass).
EXPECTS = re.compile(r"pytest\.raises\(\s*\(?[\w., ]*\b(ConvergenceError|SlipOffError)\b")
REPORT_ENV = "MATID_DEAD_SOLVER_REPORT"

calls = 0
_reached: dict[str, int] = {}
_passed: set[str] = set()
_expects: dict[str, bool] = {}
_patched: list[str] = []
_missing: list[str] = []


def _dead(name: str):
    from matid.errors import ConvergenceError

    def dead(*args, **kwargs):
        global calls
        calls += 1
        raise ConvergenceError(f"dead solver: {name} made to raise at entry", load_factor=0.0)

    dead.__name__ = name
    return dead


def _import_all_of_matid() -> None:
    import matid

    for info in pkgutil.walk_packages(matid.__path__, "matid."):
        if info.name.endswith("__main__"):
            continue
        try:
            importlib.import_module(info.name)
        except Exception:  # noqa: BLE001 - an optional module that cannot load holds no alias
            pass


def pytest_configure(config: pytest.Config) -> None:
    _import_all_of_matid()
    originals = {}
    for module, name in TARGETS:
        fn = getattr(sys.modules.get(module), name, None)
        if fn is None:
            _missing.append(f"{module}.{name}")
        else:
            originals[id(fn)] = (fn, _dead(name))
    if not originals:
        raise pytest.UsageError(f"dead_solver: none of {TARGETS} found")
    for mod_name, mod in list(sys.modules.items()):
        if not (mod_name == "matid" or mod_name.startswith("matid.")) or mod is None:
            continue
        for attr, value in list(vars(mod).items()):
            if id(value) in originals and originals[id(value)][0] is value:
                setattr(mod, attr, originals[id(value)][1])
                _patched.append(f"{mod_name}.{attr}")


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem):
    before = calls
    try:
        return (yield)
    finally:
        if calls > before:
            _reached[item.nodeid] = calls - before
            fn = getattr(item, "function", None)
            try:
                source = inspect.getsource(fn) if fn is not None else ""
            except (OSError, TypeError):
                source = ""
            _expects[item.nodeid] = bool(EXPECTS.search(source))


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    if report.when == "call" and report.passed:
        _passed.add(report.nodeid)


def _groups() -> tuple[list[str], list[str]]:
    passed = sorted(n for n in _reached if n in _passed)
    return [n for n in passed if not _expects[n]], [n for n in passed if _expects[n]]


def pytest_terminal_summary(terminalreporter) -> None:
    wrong, expected = _groups()
    write = terminalreporter.write_line
    write(f"dead solver: patched {', '.join(_patched)}; missing {', '.join(_missing) or 'none'}")
    write(f"dead solver: {len(_reached)} tests reached it; {len(wrong) + len(expected)} of them passed")
    write(f"dead solver: {len(expected)} pass expecting the error with pytest.raises")
    write(f"dead solver: {len(wrong)} pass without expecting it:")
    for nodeid in wrong:
        write(f"  {nodeid}")
    if os.environ.get(REPORT_ENV):
        doc = {"patched": _patched, "missing": _missing, "reached": _reached}
        doc.update({"passed_unexpected": wrong, "passed_expecting_the_error": expected})
        Path(os.environ[REPORT_ENV]).write_text(json.dumps(doc, indent=1))


def main(argv: list[str]) -> int:
    here = Path(__file__).resolve().parent
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(here), env.get("PYTHONPATH", "")) if p)
    report = Path(env.setdefault(REPORT_ENV, str(Path.cwd() / "dead_solver.json")))
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "dead_solver"]
    subprocess.run([*command, *(argv or ["tests"])], env=env, check=False)
    doc = json.loads(report.read_text())
    print(
        f"{len(doc['reached'])} tests reached the dead solver; "
        f"{len(doc['passed_unexpected'])} still pass without expecting its error, "
        f"{len(doc['passed_expecting_the_error'])} pass expecting it (pytest.raises); report: {report}"
    )
    return 1 if doc["passed_unexpected"] else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
