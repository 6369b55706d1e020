"""The ``matid`` command line: ``matid fit | demo | solve``.

Each subcommand is registered by its own ``_register_<name>(subparsers)`` and
runs in a ``_cmd_<name>(args) -> int`` function; :func:`main` maps errors to
exit codes (data-contract section 5):

- 0: all fits done (solve: the scene converged);
- 1: some fits failed (the rest written, reasons printed), or another MatidError
  (solve: no convergence, nothing written);
- 2: the input cannot be used (DataError; also argparse usage errors);
- 3: an unexpected error (a bug): a short message, the traceback with ``--debug``.

Progress goes to stderr (unless ``--quiet``); the summary of the stiffnesses and
the output paths go to stdout.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
import traceback
from collections.abc import Sequence
from importlib import resources
from pathlib import Path

from matid import __version__
from matid.bench.cli import register as _register_bench
from matid.errors import ConvergenceError, DataError, MatidError, SlipOffError
from matid.pipeline import run_study, write_outputs
from matid.publish import claim_output
from matid.results import Failure, StudyResult, atomic_write, stiffness_json
from matid.rod.api import resolve_model, solve
from matid.rod.output import shape_png, solution_json
from matid.rod.scenes import load_scene
from matid.study import load_study, resolve_study_path
from matid.units import UNIT_SYSTEMS

#: Parameters left out of the console summary (sls_k1 is E_e); the files hold them all.
_SUMMARY_SKIP = {"sls_k1"}
#: The parameter each test kind is for, to name what a failure costs.
_KIND_PARAMETER = {
    "extension": "E_e",
    "magnetic_bending": "E_b",
    "torsion": "E_t",
    "three_point_bend": "E_s",
}


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``matid`` with ``argv`` (default: the process arguments); returns the exit code."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else 2
    if not hasattr(args, "command"):
        parser.print_help(sys.stderr)
        return 2
    return _guarded(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="matid",
        description="Stiffness identification of catheter tubes for Cosserat rod models.",
    )
    parser.add_argument("--version", action="version", version=f"matid {__version__}")
    subparsers = parser.add_subparsers(title="commands", metavar="COMMAND")
    _register_fit(subparsers)
    _register_demo(subparsers)
    _register_solve(subparsers)
    _register_bench(subparsers)
    _register_design(subparsers)
    return parser


def _common() -> argparse.ArgumentParser:
    """Options every command takes."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    common.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return common


def _add_units(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--units",
        choices=sorted(UNIT_SYSTEMS),
        default="SI",
        help="unit system of the reported stiffnesses (default SI: N, N m^2, N s; cgs: dyn, dyn cm^2, dyn s)",
    )


def _register_fit(subparsers) -> None:
    parser = subparsers.add_parser(
        "fit",
        parents=[_common()],
        help="fit a study and write the report and stiffness tables",
        description="Fit every specimen of a study; write report.html, report.pdf, "
        "stiffness.csv and stiffness.json into --out.",
    )
    parser.add_argument("path", metavar="PATH", help="study folder or its study.toml")
    parser.add_argument(
        "--out", metavar="DIR", type=Path, help="output folder (default reports/<study folder>)"
    )
    _add_units(parser)
    parser.set_defaults(command=_cmd_fit)


def _cmd_fit(args: argparse.Namespace) -> int:
    source = resolve_study_path(args.path)
    out = args.out or Path("reports") / source.resolve().parent.name
    return fit_and_write(source, out, units=args.units, quiet=args.quiet)


def _register_demo(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo",
        parents=[_common()],
        help="fit the embedded synthetic demo study",
        description="Fit the synthetic demo study shipped with matid (matid.example).",
    )
    parser.add_argument(
        "--out", metavar="DIR", type=Path, default=Path("reports/demo"),
        help="output folder (default reports/demo)",
    )  # fmt: skip
    _add_units(parser)
    parser.set_defaults(command=_cmd_demo)


def demo_study_path() -> Path:
    """study.toml of the embedded demo study (the package ``matid.example``)."""
    path = resources.files("matid.example") / "study.toml"
    if not isinstance(path, Path):
        raise MatidError("the demo study is not installed as plain files; reinstall matid")
    return path


def _cmd_demo(args: argparse.Namespace) -> int:
    return fit_and_write(demo_study_path(), args.out, units=args.units, quiet=args.quiet)


def _register_solve(subparsers) -> None:
    parser = subparsers.add_parser(
        "solve",
        parents=[_common()],
        help="solve a rod scene (cantilever or three-point bend)",
        description="Forward solve of a scene TOML; write solution.json and shape.png into --out.",
    )
    parser.add_argument("scene", metavar="SCENE.toml", type=Path, help="scene file (data contract section 6)")
    parser.add_argument("--out", metavar="DIR", type=Path, required=True, help="output folder")
    parser.add_argument(
        "--elements",
        metavar="N",
        type=_positive_int,
        help="number of elements (three-point bend: of the half model); overrides the scene",
    )
    parser.add_argument(
        "--tolerance",
        metavar="T",
        type=_fraction,
        help="relative discretisation error to reach when no element count is given: "
        "the mesh is doubled until the Richardson estimate is below it "
        "(default: the scene's, else 1e-6); overrides the scene's",
    )
    parser.add_argument(
        "--model",
        choices=("auto", "planar", "full"),
        default="auto",
        help="rod model (default auto: planar when every load lies in one plane)",
    )
    parser.set_defaults(command=_cmd_solve)


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _fraction(text: str) -> float:
    value = float(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be in (0, 1), got {value}")
    return value


def _cmd_solve(args: argparse.Namespace) -> int:
    """Load, solve, write solution.json and shape.png whole (nothing at all when the solve fails)."""
    scene = load_scene(args.scene)
    if args.tolerance is not None:
        scene = dataclasses.replace(scene, tolerance=args.tolerance)
    try:
        resolve_model(scene, args.model)
    except ValueError as exc:
        raise DataError(f"--model {args.model}: {exc}", file=args.scene) from exc
    try:
        sol = solve(scene, elements=args.elements, model=args.model)
    except DataError as exc:  # scene content the solver cannot take: name the file
        raise exc if exc.file else DataError(exc.detail, file=args.scene) from exc
    except ConvergenceError as exc:
        reached = _deflection_reached(scene, exc)
        raise ConvergenceError(f"{args.scene}: no equilibrium: {exc}{reached}") from exc
    doc = json.dumps(solution_json(sol), indent=1) + "\n"
    png = shape_png(sol)
    json_path, png_path = args.out / "solution.json", args.out / "shape.png"
    atomic_write(json_path, doc)
    atomic_write(png_path, png)
    print(solve_summary(sol))
    if not args.quiet:
        print(f"outputs:\n  {json_path}\n  {png_path}")
    return 0


def _deflection_reached(scene, exc: ConvergenceError) -> str:
    """The bend's load factor is a fraction of the largest deflection: say which deflection that is."""
    if scene.kind != "three_point_bend" or isinstance(exc, SlipOffError) or exc.load_factor is None:
        return ""
    return f" = nose deflection {exc.load_factor * max(scene.bend.deflections) * 1e3:.6g} mm"


def solve_summary(sol) -> str:
    """One line: model, elements, the tip position in mm (or the force at the largest deflection), cost."""
    if sol.three_point_bend is not None:
        d, F = sol.three_point_bend["deflection"][-1], sol.three_point_bend["force"][-1]
        what = f"nose force {F:.6g} N at {d * 1e3:.6g} mm"
    else:
        x, y, z = (v * 1e3 for v in sol.tip["position"])
        what = f"tip at ({x:.6g}, {y:.6g}, {z:.6g}) mm"
    return (
        f"{sol.scene.kind}: {sol.model} model, {sol.elements} {sol.element} elements: {what}; "
        f"{sol.newton_iterations} Newton iterations, {sol.runtime_s:.3g} s"
    )


def fit_and_write(source: Path, out: Path, *, units: str, quiet: bool) -> int:
    """Load, fit, write; print progress, failures and the summary. 0 if every fit was done."""
    clock = time.perf_counter()

    def progress(message: str) -> None:
        if not quiet:
            print(f"[{time.perf_counter() - clock:6.1f} s] {message}", file=sys.stderr, flush=True)

    claim = claim_output(out)  # noqa: F841 -- --out checked and locked before any fitting; freed on return
    study = load_study(source)
    result = run_study(study, progress=progress)
    progress(f"rendering the report and tables into {out}")
    paths = write_outputs(result, out, units=units)
    progress("done")
    for failure in result.failures:
        print(
            f"matid: fit failed: {_what(failure)}: {failure.reason}",
            file=sys.stderr,
        )
    print(summary(result, units=units))
    print("outputs:")
    for path in paths:
        print(f"  {path}")
    return 0 if result.ok else 1


def summary(result: StudyResult, *, units: str = "SI") -> str:
    """A compact table of the stiffnesses (value ± stderr, unit), then what was not fitted."""
    doc = stiffness_json(result, units)
    rows = [("specimen", "parameter", "value", "unit", "method")]
    for sid, params in doc["specimens"].items():
        for name, item in params.items():
            if name in _SUMMARY_SKIP:
                continue
            value = f"{item['value']:.5g}"
            if item["stderr"] is not None:
                value += f" ± {item['stderr']:.2g}"
            rows.append((sid, name, value, item["unit"], item["method"]))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in rows]
    lines += [f"{_what(f)}: could not be fitted: {f.reason}" for f in result.failures]
    lines += [f"{_what(p)}: not yet fitted ({p.reason})" for p in result.pending]
    return "\n".join(lines)


def _what(failure: Failure) -> str:
    parameter = _KIND_PARAMETER.get(failure.kind, failure.kind)
    return f"{failure.specimen} {parameter} ({failure.kind.replace('_', ' ')})"


def _guarded(args: argparse.Namespace) -> int:
    """Run the command; map errors to exit codes and one-line messages."""
    try:
        return args.command(args)
    except DataError as exc:
        return _fail(args, exc, 2, str(exc))
    except MatidError as exc:
        return _fail(args, exc, 1, str(exc))
    except KeyboardInterrupt:
        print("matid: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:
        hint = "" if args.debug else " (rerun with --debug for the traceback)"
        return _fail(args, exc, 3, f"internal error: {type(exc).__name__}: {exc}{hint}")


def _fail(args: argparse.Namespace, exc: BaseException, code: int, message: str) -> int:
    if args.debug:
        traceback.print_exception(exc, file=sys.stderr)
    print(f"matid: error: {message}", file=sys.stderr)
    return code


def _register_design(subparsers) -> None:
    parser = subparsers.add_parser(
        "design",
        parents=[_common()],
        help="which spans and which bend measurement identify E_s to a given precision",
        description="Experiment design for E_s (matid.design): predicted precision of E_s per span for "
        "centreline deflection and nose travel, from the tube's section, E_b and E_e or E_t.",
    )
    parser.add_argument("--outer-diameter", required=True, help='e.g. "2.4 mm"')
    parser.add_argument("--inner-diameter", default="0 mm", help='e.g. "1.6 mm" (default solid)')
    parser.add_argument("--E-b", dest="E_b", required=True, help='bending stiffness, e.g. "6.5e-5 N m^2"')
    parser.add_argument("--E-e", dest="E_e", help='extension stiffness, e.g. "120 N"')
    parser.add_argument("--E-t", dest="E_t", help='torsion stiffness, e.g. "4.4e-5 N m^2"')
    parser.add_argument("--poisson-ratio", type=float, help="default: the range 0.3-0.5")
    parser.add_argument("--precision", type=_fraction, default=0.05, help="relative sd wanted (default 0.05)")
    parser.add_argument("--spans", default="6,8,10,15,20,30", help="spans in mm, comma-separated")
    parser.set_defaults(command=_cmd_design)


def _cmd_design(args: argparse.Namespace) -> int:
    from matid.design import design
    from matid.design import summary as design_summary
    from matid.study import Specimen
    from matid.units import UnitError, to_si

    try:
        values = {
            "outer": to_si(args.outer_diameter, "length"),
            "inner": to_si(args.inner_diameter, "length"),
            "E_b": to_si(args.E_b, "bending_stiffness"),
            "E_e": to_si(args.E_e, "force") if args.E_e else None,
            "E_t": to_si(args.E_t, "bending_stiffness") if args.E_t else None,
        }
        spans = [1e-3 * float(s) for s in args.spans.split(",")]
        specimen = Specimen("design", values["outer"], values["inner"], args.poisson_ratio)
    except (UnitError, ValueError) as exc:
        raise DataError(f"matid design: {exc}") from exc
    if not (values["E_e"] or values["E_t"]):
        raise DataError("matid design: give --E-e or --E-t (the shear reference k G A comes from them)")
    options = design(
        specimen,
        E_b=values["E_b"],
        E_e=values["E_e"],
        E_t=values["E_t"],
        precision=args.precision,
        spans=spans,
    )
    print(design_summary(options, args.precision))
    return 0
