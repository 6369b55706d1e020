"""Do two versions of the SLS extension fit give the same answers? (acceptance test of the
lmfit -> scipy.optimize port).

Run from the repository root of each checkout::

    PYTHONPATH=<old checkout> python benchmarks/extension_equivalence.py dump old.json
    PYTHONPATH=<new checkout> python benchmarks/extension_equivalence.py dump new.json
    python benchmarks/extension_equivalence.py compare old.json new.json

``dump`` records every :func:`matid.fits.extension.fit.fit_extension` call of (a) the demo
study (matid/example through :func:`matid.app.pipeline.run_study`), (b) the tests that build
extension data (run through pytest with the fit wrapped; hypothesis is derandomised by the
"ci" profile) and (c) extra cases: the coverage benchmark's i.i.d. and AR(1) ramps, exact
(noise-free) data, each parameter fixed in turn. Per call it keeps every estimate (value,
stderr, interval, its method, warnings), the correlations and the fit summary numbers.

``compare`` pairs the calls by key and checks: values within 1e-6 relative, stderrs within
1e-4 relative, interval ends within 1e-3 of the interval width, the same interval methods
and warnings, correlations within 1e-4; it prints the worst difference of each kind.

Measured 2026-11-23, lmfit 1.3.4 (commit 44616b7) against the scipy.optimize port (branch
nolmfit): 57 fits, same calls, errors, methods and warnings; worst differences value 0,
stderr 0, t and t-log intervals 0, profile interval 1.2e-12 of its width, correlation 3e-16.

Measured 2026-11-26, back on lmfit 1.3.4 (branch lmfit) against the lmfit era (74c4d56,
dumped with this script's TESTS of that layout): 57 common fits bit-identical (value,
stderr, t, t-log and profile intervals, correlations: worst difference 0). The era has
no record of one newer test, and "extra exact" differs from the era at 1747a33 already
(9c8ca1c: the difference noise's fallback). Test records are keyed by file name and test
(``_test_key``), so dumps from before and after the layout of style.md pair up.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RECORDS: dict[str, dict] = {}
_CONTEXT = {"key": "extra", "n": 0}

TESTS = [
    "tests/fits/extension/test_viscoelastic.py",
    "tests/fits/extension/test_prony.py",
    "tests/io/test_study.py",
    "tests/app/test_pipeline.py",
    "tests/example/test_example_data.py",
    "tests/io/test_results.py",
    "tests/io/test_exports.py",
]


def _plain(value):
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return None  # plot data: not compared
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value


def _record(fit) -> dict:
    info = {k: v for k, v in fit.info.items() if k != "plot_data"}
    return {
        "estimates": [
            {
                "parameter": e.parameter,
                "value": e.value,
                "stderr": e.stderr,
                "ci95": None if e.ci95 is None else list(e.ci95),
                "method": e.method,
                "ci_method": e.extra.get("ci_method"),
                "warnings": list(e.warnings),
            }
            for e in fit.estimates
        ],
        "correlation": dict(fit.correlation),
        "info": _plain(info),
    }


def _install() -> None:
    """Wrap fit_extension before anything imports it by name."""
    from matid.fits.extension import fit as extension

    original = extension.fit_extension

    def recorded(*args, **kwargs):
        key = f"{_CONTEXT['key']}#{_CONTEXT['n']}"
        _CONTEXT["n"] += 1
        try:
            fit = original(*args, **kwargs)
        except Exception as exc:
            RECORDS[key] = {"error": f"{type(exc).__name__}: {exc}"}
            raise
        RECORDS[key] = _record(fit)
        return fit

    extension.fit_extension = recorded


class _Keys:
    """pytest plugin: key the records by test id."""

    def pytest_runtest_setup(self, item):
        _CONTEXT["key"], _CONTEXT["n"] = _test_key(item.nodeid), 0


def _test_key(nodeid: str) -> str:
    """A test's key without its folder ("test_prony.py::test_x"): records dumped before the
    layout of style.md (tests/test_prony.py) pair with those after (tests/fits/extension/...)."""
    path, _, name = nodeid.partition("::")
    return f"{Path(path).name}::{name}"


def _measurements(runs):
    from matid.model import study
    from matid.model.measurement import Measurement, Table

    out = []
    for i, (t, eps, force) in enumerate(runs):
        test = study.Test("extension", "T1", Path(f"r{i}.csv"), {"gauge_length": 0.05})
        table = Table(Path(f"r{i}.csv"), {"time": t, "strain": eps, "force": force}, {}, {}, "")
        out.append(Measurement(test, table))
    return out


def _ramps(rng, k, durations, noise, phi=0.0):
    from matid.fits.stats import ar1_noise
    from matid.physics.sls import sls_ramp

    out = []
    for duration in durations:
        t = np.linspace(0.0, duration, 400)
        force = sls_ramp(t, 0.05 / duration, *k)
        e = ar1_noise(rng, t.size, phi) if phi else rng.normal(size=t.size)
        out.append((t, 0.05 * t / duration, force + noise * force.max() * e))
    return out


def _extra() -> None:
    from matid.fits.extension import fit as extension

    k = (50.0, 30.0, 300.0)
    tau = k[2] / k[1]
    cases = {}
    for seed in range(6):
        for phi in (0.0, 0.95):
            rng = np.random.default_rng(seed)
            cases[f"coverage seed {seed} phi {phi}"] = (
                _ramps(rng, k, [10 * tau, tau, 0.1 * tau], 0.003, phi),
                {},
            )
    rng = np.random.default_rng(40)
    cases["exact"] = (_ramps(rng, k, [10 * tau, tau, 0.1 * tau], 0.0), {})
    cases["nearly exact"] = (_ramps(rng, k, [10 * tau, tau, 0.1 * tau], 1e-7), {})
    for fixed in ({"E_e": 50.0}, {"sls_k2": 30.0}, {"sls_eta": 300.0}, {"sls_k1": 50.0, "sls_eta": 300.0}):
        rng = np.random.default_rng(41)
        cases[f"fixed {fixed}"] = (_ramps(rng, k, [10 * tau, tau, 0.1 * tau], 0.003), fixed)
    rng = np.random.default_rng(42)
    cases["fast tau"] = (_ramps(rng, (50.0, 30.0, 30.0 * 0.01), [100.0, 30.0, 10.0], 0.003), {})
    rng = np.random.default_rng(43)
    cases["slow tau"] = (_ramps(rng, (50.0, 30.0, 30.0 * 1e4), [10.0, 3.0, 1.0], 0.003), {})
    rng = np.random.default_rng(44)
    cases["one run"] = (_ramps(rng, k, [3 * tau], 0.003), {})
    for name, (runs, fixed) in cases.items():
        _CONTEXT["key"], _CONTEXT["n"] = f"extra {name}", 0
        try:
            extension.fit_extension(_measurements(runs), specimen="T1", fixed=fixed)
        except Exception:  # recorded by the wrapper
            pass


def dump(out: str) -> None:
    _install()
    import pytest

    from matid.app import pipeline
    from matid.io.study import load_study

    _CONTEXT["key"], _CONTEXT["n"] = "demo", 0
    pipeline.run_study(load_study(ROOT / "matid" / "example" / "study.toml"))
    _extra()
    code = pytest.main(
        ["-q", "-x", "-p", "no:cacheprovider", *[str(ROOT / t) for t in TESTS]], plugins=[_Keys()]
    )
    Path(out).write_text(json.dumps(RECORDS, indent=1, sort_keys=True, default=_plain))
    print(f"{len(RECORDS)} fits recorded to {out}; pytest exit {code}")


# --------------------------------------------------------------------------- compare


def _rel(a, b):
    if a is None or b is None:
        return 0.0 if a is b else math.inf
    return abs(a - b) / max(abs(a), 1e-300) if a != b else 0.0


def _compare_fit(key, a, b, worst, fails):
    def note(kind, diff, tol, what):
        if diff > worst[kind][0]:
            worst[kind] = (diff, f"{key}: {what}")
        if diff > tol:
            fails.append(f"{kind} {diff:.3g} > {tol:g} at {key}: {what}")

    if "error" in a or "error" in b:
        if a.get("error") != b.get("error"):
            fails.append(f"error differs at {key}: {a.get('error')} vs {b.get('error')}")
        return
    if [e["parameter"] for e in a["estimates"]] != [e["parameter"] for e in b["estimates"]]:
        fails.append(f"estimates differ at {key}")
        return
    for ea, eb in zip(a["estimates"], b["estimates"], strict=True):
        p = ea["parameter"]
        note("value", _rel(ea["value"], eb["value"]), 1e-6, p)
        note("stderr", _rel(ea["stderr"], eb["stderr"]), 1e-4, p)
        for field in ("method", "ci_method", "warnings"):
            if ea[field] != eb[field]:
                fails.append(f"{field} differs at {key} {p}: {ea[field]} vs {eb[field]}")
        if (ea["ci95"] is None) != (eb["ci95"] is None):
            fails.append(f"interval present in one only at {key} {p}")
        elif ea["ci95"] is not None:
            width = max(abs(ea["ci95"][1] - ea["ci95"][0]), 1e-300)
            diff = max(abs(x - y) for x, y in zip(ea["ci95"], eb["ci95"], strict=True)) / width
            note(f"interval ({ea['ci_method']})", diff, 1e-3, p)
    if set(a["correlation"]) != set(b["correlation"]):
        fails.append(f"correlation keys differ at {key}")
    for name in set(a["correlation"]) & set(b["correlation"]):
        note("correlation", abs(a["correlation"][name] - b["correlation"][name]), 1e-4, name)


def compare(old: str, new: str) -> int:
    a, b = json.loads(Path(old).read_text()), json.loads(Path(new).read_text())
    worst: dict = {
        k: (0.0, "")
        for k in ("value", "stderr", "interval (t)", "interval (t-log)", "interval (profile)", "correlation")
    }
    worst = __import__("collections").defaultdict(lambda: (0.0, ""), worst)
    fails: list[str] = []
    if set(a) != set(b):
        fails.append(f"calls differ: only old {sorted(set(a) - set(b))}, only new {sorted(set(b) - set(a))}")
    for key in sorted(set(a) & set(b)):
        _compare_fit(key, a[key], b[key], worst, fails)
    print(f"{len(set(a) & set(b))} fits compared")
    for kind, (diff, where) in sorted(worst.items()):
        print(f"worst {kind:20s} {diff:.3g}  ({where})")
    for line in fails:
        print("FAIL", line)
    print("EQUIVALENT" if not fails else f"{len(fails)} differences beyond tolerance")
    return 1 if fails else 0


if __name__ == "__main__":
    if sys.argv[1] == "dump":
        dump(sys.argv[2])
    else:
        sys.exit(compare(sys.argv[2], sys.argv[3]))
