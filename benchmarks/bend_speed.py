"""Speed of the three-point bend and the E_s fit (issue 13), with the answers to compare checkouts.

    PYTHONPATH=<checkout> python benchmarks/bend_speed.py [--repeat N] [--json OUT] [--only rows,...]

Measures, in one process of the checkout on PYTHONPATH:

- ``load point``: one warm load point of the demo bend (span 10 mm, 24 elements,
  30-point curve to d = 1 mm): the path solved once with sensitivities, then again at
  E_s + 1 % from it (warm start, as the E_s fit does); its time / 30, best of N;
- ``E_s fit``: ``fit_three_point_bend`` on a 30-point curve of the rod model
  (96 elements, 0.2 % noise, seed 1), best of N;
- ``rows``: ``fit_three_point_bend`` on a 3000-row record of the rod model (48 elements,
  d to 1 mm, 0.2 % noise, seed 1) and on its 30 evenly spread rows, interleaved
  (30, 3000, 30, ...), process CPU, best of N; E_s and its standard error of both, the
  ratio, and the knots (issue 19.7: cost independent of the rows); ``rows_centreline``:
  the same on centreline deflection (96 elements, to 0.5 mm of nose travel);
- ``demo``: every three-point-bend fit of the demo study (``matid demo``), its
  time, with E_s, its interval and warnings;
- ``tube3d``: the continuum tube of ``tests/data/tube3d`` (spans 8 and 20 mm, nose
  travel and centreline): E_s, interval, warnings.

Counts: model paths (``BendModel.solve`` calls) and Newton iterations per fit.
Answers go to ``--json`` so two checkouts can be compared (values within 0.1 % of
the interval width). Timings: only ratios from alternated runs on the same
machine mean anything (run both checkouts in turn, a few times).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from matid.example.forward import bend_centreline, bend_force
from matid.fits.shear import fit as shear
from matid.io.study import load_study
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.model.results import Estimate
from matid.rod import bend

E_B, E_S, E_E = 6.5e-5, 21.0, 120.0  # demo tube T1
RIG = {"span": 0.01, "specimen_length": 0.03, "support_radius": 2e-3, "nose_radius": 2e-3}


class Counter:
    """Counts BendModel.solve calls and their Newton iterations (wraps the method)."""

    def __init__(self) -> None:
        self.paths = self.iterations = 0
        self._solve = bend.BendModel.solve

        def solve(model, *args, **kwargs):
            path = self._solve(model, *args, **kwargs)
            self.paths += 1
            self.iterations += path.newton_iterations
            return path

        bend.BendModel.solve = solve

    def reset(self) -> tuple[int, int]:
        out = (self.paths, self.iterations)
        self.paths = self.iterations = 0
        return out


def load_point(repeat: int) -> dict:
    geometry = bend.BendGeometry(**RIG, outer_diameter=2.4e-3)
    model = bend.BendModel(geometry, elements=24)
    d = np.linspace(0.0, 1e-3, 30)
    names = ("E_s", "E_b", "E_e")
    best, cold, cpu, its = np.inf, np.inf, np.inf, 0
    for _ in range(repeat):
        t0 = time.perf_counter()
        path = model.solve(E_B, E_S, E_E, d, sensitivities=names)
        cold = min(cold, time.perf_counter() - t0)
        t0, c0 = time.perf_counter(), time.process_time()
        warm = model.solve(E_B, 1.01 * E_S, E_E, d, sensitivities=names, start=path)
        best, cpu = min(best, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
        its = warm.newton_iterations
    return {
        "warm_ms_per_point": 1e3 * best / d.size,
        "warm_cpu_ms_per_point": 1e3 * cpu / d.size,
        "warm_newton_iterations": its,
        "cold_path_ms": 1e3 * cold,
        "cold_newton_iterations": path.newton_iterations,
        "force_N": warm.force.tolist(),
    }


def _measurement(d, F, span, at="nose", name="3pb.csv", **rig) -> Measurement:
    params = {**RIG, "span": span, **rig}
    test = study.Test("three_point_bend", "T", Path(name), params, deflection_at=at)
    return Measurement(
        test, Table(Path(name), {"deflection": np.asarray(d), "force": np.asarray(F)}, {}, {}, "")
    )


def _answer(fit) -> dict:
    est = fit.estimate("E_s")
    return {"E_s": est.value, "ci95": list(est.ci95), "warnings": list(est.warnings)}


def es_fit(repeat: int, counter: Counter) -> dict:
    d = np.linspace(0.0, 1e-3, 30)
    F = bend_force(d, E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=2.4e-3, **RIG)
    F = F + np.random.default_rng(1).normal(0.0, 0.002 * F.max(), F.size)
    known = {
        "E_b": Estimate("E_b", E_B, 0.0, None, 0, "linear"),
        "E_e": Estimate("E_e", E_E, 0.0, None, 0, "sls"),
    }
    spec = study.Specimen("T", 2.4e-3, 1.6e-3)
    best = cpu = np.inf
    for _ in range(repeat):
        counter.reset()
        t0, c0 = time.perf_counter(), time.process_time()
        fit = shear.fit_three_point_bend(
            [_measurement(d, F, 0.01)],
            specimen=spec,
            known=known,
            local_compliance=(0.0, 0.0),
            model_form=0.0,
        )
        best, cpu = min(best, time.perf_counter() - t0), min(cpu, time.process_time() - c0)
        paths, its = counter.reset()
    return {"seconds": best, "cpu_seconds": cpu, "paths": paths, "newton_iterations": its, **_answer(fit)}


def record(at: str) -> tuple[np.ndarray, np.ndarray]:
    """3000 rows of the rod model (every row solved), 0.2 % noise, seed 1: nose travel to 1 mm
    (48 elements), or the centreline deflection to 0.5 mm of nose travel (96 elements)."""
    if at == "centreline":
        d, F = bend_centreline(
            np.linspace(0.0, 5e-4, 3000), E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=2.4e-3, **RIG
        )
    else:
        d = np.linspace(0.0, 1e-3, 3000)
        geometry = bend.BendGeometry(**RIG, outer_diameter=2.4e-3)
        F = bend.BendModel(geometry, elements=48).solve(E_B, E_S, E_E, d).force
    return d, F + np.random.default_rng(1).normal(0.0, 0.002 * F.max(), F.size)


def rows(repeat: int, counter: Counter, at: str = "nose") -> dict:
    d, F = record(at)
    few = np.round(np.linspace(0, d.size - 1, 30)).astype(int)
    known = {
        "E_b": Estimate("E_b", E_B, 0.0, None, 0, "linear"),
        "E_e": Estimate("E_e", E_E, 0.0, None, 0, "sls"),
    }
    spec = study.Specimen("T", 2.4e-3, 1.6e-3)
    out: dict = {30: {"cpu_seconds": np.inf}, 3000: {"cpu_seconds": np.inf}}
    for _ in range(repeat):
        for n, rows in ((30, few), (3000, slice(None))):
            counter.reset()
            c0 = time.process_time()
            fit = shear.fit_three_point_bend(
                [_measurement(d[rows], F[rows], 0.01, at=at)],
                specimen=spec,
                known=known,
                local_compliance=(0.0, 0.0),
                model_form=0.0,
            )
            cpu = time.process_time() - c0
            paths, its = counter.reset()
            if cpu < out[n]["cpu_seconds"]:
                est = fit.estimate("E_s")
                every_row = {"rows": est.n_points, "knots": est.n_points, "error_N": 0.0}  # before 19.7
                (interp,) = fit.info["fe"].get("interpolation", [every_row])
                out[n] = {
                    "cpu_seconds": cpu,
                    "paths": paths,
                    "newton_iterations": its,
                    "E_s": est.value,
                    "stderr": est.stderr,
                    "rows": interp["rows"],
                    "knots": interp["knots"],
                    "interpolation_error_N": interp["error_N"],
                }
    out["ratio"] = out[3000]["cpu_seconds"] / out[30]["cpu_seconds"]
    return out


def demo(counter: Counter) -> dict:
    from matid.app import pipeline
    from matid.app.cli import demo_study_path

    out, original = {}, pipeline.FITTERS["three_point_bend"]

    def timed(measurements, **kwargs):
        counter.reset()
        t0 = time.perf_counter()
        fit = original(measurements, **kwargs)
        paths, its = counter.reset()
        out[kwargs["specimen"].id] = {
            "seconds": time.perf_counter() - t0,
            "paths": paths,
            "newton_iterations": its,
            **_answer(fit),
        }
        return fit

    pipeline.FITTERS["three_point_bend"] = timed
    try:
        pipeline.run_study(load_study(demo_study_path()))
    finally:
        pipeline.FITTERS["three_point_bend"] = original
    out["total_seconds"] = sum(v["seconds"] for v in out.values())
    return out


def tube3d(counter: Counter) -> dict:
    spec = study.Specimen("T", 2.4e-3, 1.6e-3)
    known = {
        "E_b": Estimate("E_b", 6.5345e-5, 0.0, None, 0, "linear"),
        "E_e": Estimate("E_e", 125.66, 0.0, None, 0, "sls"),
    }
    out, folder = {}, Path(shear.__file__).resolve().parents[3] / "tests" / "data" / "tube3d"
    for span_mm in (8, 20):
        rows = json.loads((folder / f"T{span_mm}.json").read_text())["rows"]
        F = np.r_[0.0, [r["F"] for r in rows]]
        for at, column in (("nose", "delta"), ("centreline", "delta_centroid")):
            d = np.r_[0.0, [r[column] for r in rows]] * 1e-3
            m = _measurement(d, F, span_mm * 1e-3, at=at, specimen_length=span_mm * 1e-3 + 8e-3)
            counter.reset()
            t0 = time.perf_counter()
            fit = shear.fit_three_point_bend([m], specimen=spec, known=known)
            paths, its = counter.reset()
            out[f"T{span_mm} {at}"] = {
                "seconds": time.perf_counter() - t0,
                "paths": paths,
                "newton_iterations": its,
                **_answer(fit),
            }
    return out


def _line(v: dict) -> str:
    low, high = v["ci95"]
    return (
        f"{v['seconds']:.3f} s, {v['paths']} paths, {v['newton_iterations']} Newton its; "
        f"E_s {v['E_s']:.6g} [{low:.6g}, {high:.6g}], {len(v['warnings'])} warnings"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--json", type=Path)
    parser.add_argument("--only", default="load_point,es_fit,rows,rows_centreline,demo,tube3d")
    args = parser.parse_args(argv)
    counter = Counter()
    parts = args.only.split(",")
    doc = {"matid": str(Path(shear.__file__).resolve().parents[3])}
    print(f"matid {doc['matid']}")
    if "load_point" in parts:
        doc["load_point"] = lp = load_point(args.repeat)
        print(
            f"load point (warm, 24 el.): {lp['warm_ms_per_point']:.2f} ms "
            f"(CPU {lp['warm_cpu_ms_per_point']:.2f}), {lp['warm_newton_iterations']} Newton its / 30 pts; "
            f"cold path {lp['cold_path_ms']:.1f} ms ({lp['cold_newton_iterations']} its)"
        )
    if "es_fit" in parts:
        doc["es_fit"] = f = es_fit(max(1, args.repeat // 2 + 1), counter)
        print(f"E_s fit, 30 points: {_line(f)} (CPU {f['cpu_seconds']:.3f} s)")
    for at in ("nose", "centreline"):
        part = "rows" if at == "nose" else "rows_centreline"
        if part not in parts:
            continue
        doc[part] = rw = rows(args.repeat, counter, at)
        for n in (30, 3000):
            v = rw[n]
            print(
                f"E_s fit, {at}, {n} rows: CPU {v['cpu_seconds']:.3f} s, {v['paths']} paths, "
                f"{v['newton_iterations']} Newton its, {v['knots']} knots of {v['rows']} rows "
                f"(interpolation error <= {v['interpolation_error_N']:.2g} N); "
                f"E_s {v['E_s']:.6g} +- {v['stderr']:.3g}"
            )
        print(f"E_s fit, {at}: CPU 3000 / 30 rows: {rw['ratio']:.2f}")
    if "demo" in parts:
        doc["demo"] = dm = demo(counter)
        for k, v in dm.items():
            if k != "total_seconds":
                print(f"demo {k}: {_line(v)}")
        print(f"demo E_s fits total: {dm['total_seconds']:.3f} s")
    if "tube3d" in parts:
        doc["tube3d"] = tb = tube3d(counter)
        for k, v in tb.items():
            print(f"tube3d {k}: {_line(v)}")
    if args.json:
        args.json.write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
