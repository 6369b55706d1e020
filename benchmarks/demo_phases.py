"""Where ``matid demo`` spends its time: imports, each fit kind, the report, the tables.

Run from the repository root: ``python benchmarks/demo_phases.py`` (or with
``PYTHONPATH=<another checkout>`` to compare two versions; run them interleaved, the machine
may be shared). Prints wall and CPU seconds per phase, the CPU of the process that renders the
report's figures beside the PDF (matid.report.imagejob), and the total without the E_s fit
(three_point_bend), whose solver is measured by ``matid bench``.
"""

from __future__ import annotations

import resource
import time

START = (time.perf_counter(), time.process_time())


def _lap(name: str, since: tuple[float, float]) -> tuple[float, float]:
    wall, cpu = time.perf_counter() - since[0], time.process_time() - since[1]
    print(f"{name:26s} wall {wall:6.3f} s  cpu {cpu:6.3f} s", flush=True)
    return time.perf_counter(), time.process_time()


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    import matid.app.cli as cli

    clock = _lap("import matid.app.cli", START)
    cli.build_parser(["demo"]).parse_args(["demo"])
    clock = _lap("build the parser", clock)
    from matid.app import pipeline
    from matid.io.study import load_study

    clock = _lap("import matid.app.pipeline", clock)
    fits: dict[str, list[float]] = {}
    for kind, fitter in list(pipeline.FITTERS.items()):

        def timed(*args, _fitter=fitter, _kind=kind, **kwargs):
            wall, cpu = time.perf_counter(), time.process_time()
            try:
                return _fitter(*args, **kwargs)
            finally:
                spent = fits.setdefault(_kind, [0.0, 0.0])
                spent[0] += time.perf_counter() - wall
                spent[1] += time.process_time() - cpu

        pipeline.FITTERS[kind] = timed
    result = pipeline.run_study(load_study(cli.demo_study_path()))
    clock = _lap("read and fit", clock)
    for kind, (wall, cpu) in fits.items():
        print(f"  {kind:24s} wall {wall:6.3f} s  cpu {cpu:6.3f} s")
    from matid.report import render_report

    children = _children_cpu()
    render_report(result, units="SI")
    clock = _lap("report (HTML and PDF)", clock)
    print(f"  figures rendered beside it: cpu {_children_cpu() - children:6.3f} s")
    from matid.io.results import stiffness_csv, stiffness_json
    from matid.io.xlsx import stiffness_xlsx

    stiffness_csv(result, "SI"), stiffness_json(result, "SI"), stiffness_xlsx(result, "SI")
    _lap("tables (csv, json, xlsx)", clock)
    wall, cpu = time.perf_counter() - START[0], time.process_time() - START[1] + _children_cpu()
    shear = fits.get("three_point_bend", [0.0, 0.0])
    print(f"{'total (cpu with the child)':26s} wall {wall:6.3f} s  cpu {cpu:6.3f} s")
    print(f"{'total without the E_s fit':26s} wall {wall - shear[0]:6.3f} s  cpu {cpu - shear[1]:6.3f} s")


if __name__ == "__main__":
    main()
