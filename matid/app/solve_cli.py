"""The rod commands of ``matid``: ``solve`` (forward solve of a scene) and ``design`` (experiment
design for E_s).

Registered by :func:`matid.app.cli.build_parser`; errors are mapped to exit codes by
:func:`matid.app.cli.main`. Like :mod:`matid.app.cli`, this module needs only the standard library at
import: the solver, pint and matplotlib load when a command runs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from matid.app.options import _fraction, _positive_int, add_command
from matid.errors import ConvergenceError, DataError, SlipOffError


def register_solve(subparsers) -> None:
    parser = add_command(
        subparsers,
        "solve",
        _cmd_solve,
        help="solve a rod scene (cantilever or three-point bend)",
        description="Forward solve of a scene TOML; write solution.json and shape.png into --out.",
    )
    parser.add_argument(
        "scene", metavar="SCENE.toml", type=Path, help="scene file (docs/contract.md section 6)"
    )
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


def _cmd_solve(args: argparse.Namespace) -> int:
    """Load, solve, publish solution.json and shape.png as one folder (nothing at all when the solve
    fails), as ``matid fit`` publishes its report (:mod:`matid.io.publish`): ``--out`` is checked and
    locked before the solve (a file, under a file, read-only, holding other files, or being written
    by another matid run: exit 2), and a write error (a full disk) leaves the previous outputs whole
    (exit 4)."""
    import dataclasses
    import json

    from matid.io.publish import claim_output
    from matid.rod.api import resolve_model, solve
    from matid.rod.output import shape_png, solution_json
    from matid.rod.sweeps import load_sweep

    claim = claim_output(args.out)  # checked and locked before any solving; freed on return
    scene, axes = load_sweep(args.scene)
    if args.tolerance is not None:
        scene = dataclasses.replace(scene, tolerance=args.tolerance)
    if axes is not None:
        return _solve_sweep(args, claim, scene, axes)
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
    png = shape_png(sol, name=Path(args.scene).stem)
    paths = claim.publish({"solution.json": doc, "shape.png": png})
    print(solve_summary(sol))
    for warning in sol.extra.get("warnings", []):
        print(f"warning: {warning}", file=sys.stderr)
    if not args.quiet:
        print("outputs:\n" + "\n".join(f"  {path}" for path in paths))
    return 0


def _solve_sweep(args: argparse.Namespace, claim, scene, axes) -> int:
    """A scene with [[sweep]] (contract section 13): every state solved together, sweep.csv,
    sweep.json and workspace.png published; exit 1 when a state failed (the rest still written)."""
    import json

    from matid.rod.sweep_output import sweep_csv, sweep_json, workspace_png
    from matid.rod.sweeps import rows, solve_states

    if args.model != "auto":
        raise DataError("--model: a sweep picks the model per state (auto)", file=args.scene)
    table = rows(axes, solve_states(scene, axes, elements=args.elements))
    files = {
        "sweep.csv": sweep_csv(table),
        "sweep.json": json.dumps(sweep_json(axes, table), indent=1) + "\n",
        "workspace.png": workspace_png(axes, table, name=Path(args.scene).stem),
    }
    paths = claim.publish(files)
    failed = [r for r in table if not r["converged"]]
    print(f"sweep: {len(table)} states, {len(table) - len(failed)} converged, {len(failed)} failed")
    for r in failed[:5]:
        print(f"failed: {r['reason']}", file=sys.stderr)
    if not args.quiet:
        print("outputs:\n" + "\n".join(f"  {path}" for path in paths))
    return 1 if failed else 0


def _deflection_reached(scene, exc: ConvergenceError) -> str:
    """The bend's load factor is a fraction of the largest deflection: say which deflection that is."""
    if scene.bend is None or isinstance(exc, SlipOffError) or exc.load_factor is None:
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
        if "aim" in sol.extra:
            B = ", ".join(f"{b * 1e3:.6g}" for b in sol.scene.loads.B)
            what += f"; aimed: B = ({B}) mT, tip {sol.extra['aim']['tip_direction_error_rad']:.2g} rad off"
    return (
        f"{sol.scene.kind}: {sol.model} model, {sol.elements} {sol.element} elements: {what}; "
        f"{sol.newton_iterations} Newton iterations, {sol.runtime_s:.3g} s"
    )


def register_design(subparsers) -> None:
    parser = add_command(
        subparsers,
        "design",
        _cmd_design,
        help="which spans and which bend measurement identify E_s to a given precision",
        description="Experiment design for E_s (matid.fits.design): predicted precision of E_s per span for "
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


def _cmd_design(args: argparse.Namespace) -> int:
    from matid.fits.design import design
    from matid.fits.design import summary as design_summary
    from matid.model.study import Specimen
    from matid.units import UnitError, to_si

    try:
        outer, inner = (to_si(d, "length") for d in (args.outer_diameter, args.inner_diameter))
        E_b = to_si(args.E_b, "bending_stiffness")
        E_e, E_t = (
            to_si(v, kind) if v else None
            for v, kind in [(args.E_e, "force"), (args.E_t, "bending_stiffness")]
        )
        spans = [1e-3 * float(s) for s in args.spans.split(",")]
        specimen = Specimen("design", outer, inner, args.poisson_ratio)
    except (UnitError, ValueError) as exc:
        raise DataError(f"matid design: {exc}") from exc
    if not (E_e or E_t):
        raise DataError("matid design: give --E-e or --E-t (the shear reference k G A comes from them)")
    options = design(specimen, E_b=E_b, E_e=E_e, E_t=E_t, precision=args.precision, spans=spans)
    print(design_summary(options, args.precision))
    return 0
