"""The ``matid`` command line: ``matid fit | demo | solve | design | bench``.

Each subcommand is registered by its own ``_register_<name>(subparsers)`` and
runs in a ``_cmd_<name>(args) -> int`` function: ``fit`` and ``demo`` here,
``solve`` and ``design`` in :mod:`matid.app.solve_cli`, ``bench`` in
:mod:`matid.bench.cli`; the options they share are in :mod:`matid.app.options`.
:func:`main` maps errors to exit codes (docs/contract.md section 5):

- 0: all fits done (solve: the scene converged);
- 1: some fits failed (the rest written, reasons printed), a warning under
  ``--strict``, or another MatidError (solve: no convergence, nothing written);
- 2: the input cannot be used (DataError; also argparse usage errors);
- 3: an unexpected error (a bug): a short message, the traceback with ``--debug``;
- 4: the outputs could not be written (a full disk, an I/O error): the previous outputs are
  unchanged;
- 130 / 143: stopped by SIGINT (Ctrl-C) / SIGTERM (:class:`matid.app.batch.Terminated`).

Messages are printed with control characters escaped (an ESC in a file name never
reaches the terminal raw).

Progress goes to stderr (unless ``--quiet``); the summary of the stiffnesses,
the warnings and the output paths go to stdout.

Imports are lazy: this module needs only the standard library to build the
parser, and each command imports the numerical stack it uses when it runs
(``import matid.app.cli`` stays well under a second; the bench, the rod solver and
the fits load only for the commands that need them).
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from matid import __version__
from matid.app.options import _positive_int, add_command, add_units_and_strict
from matid.app.outcome import error_message, exit_code, study_code
from matid.app.solve_cli import register_design, register_solve
from matid.errors import MatidError

if TYPE_CHECKING:
    from matid.model.results import Failure, StudyResult

#: Parameters left out of the console summary (sls_k1 is E_e); the files hold them all.
_SUMMARY_SKIP = {"sls_k1"}


def run() -> None:
    """The console script ``matid``: :func:`main`, then exit with its code."""
    sys.exit(main())


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``matid`` with ``argv`` (default: the process arguments); returns the exit code."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else 2
    if not hasattr(args, "command"):
        parser.print_help(sys.stderr)
        return 2
    return _guarded(args)


#: The help line of ``matid bench`` (matid.bench.cli) in ``matid --help``, without loading the bench.
BENCH_HELP = "measure accuracy, cost and robustness of the rod solver"


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``matid`` parser; with ``argv``, ``bench`` loads its module only when it is the command."""
    parser = argparse.ArgumentParser(
        prog="matid",
        description="Stiffness identification of catheter tubes for Cosserat rod models. "
        "Inputs and outputs are specified in docs/contract.md.",
    )
    parser.add_argument("--version", action="version", version=f"matid {__version__}")
    subparsers = parser.add_subparsers(title="commands", metavar="COMMAND")
    _register_fit(subparsers)
    _register_demo(subparsers)
    register_solve(subparsers)
    register_design(subparsers)
    if argv is None or next((a for a in argv if not a.startswith("-")), None) == "bench":
        from matid.bench.cli import register

        register(subparsers)
    else:  # listed in --help; never selected, since "bench" in argv loads the real one
        subparsers.add_parser("bench", help=BENCH_HELP, add_help=False)
    return parser


def _register_fit(subparsers) -> None:
    parser = add_command(
        subparsers,
        "fit",
        _cmd_fit,
        help="fit one or more studies and write the reports and stiffness tables",
        description="Fit every specimen of a study; write report.html, report.pdf, stiffness.csv, "
        "stiffness.json and stiffness.xlsx into --out (docs/contract.md sections 4 and 7). "
        "With several studies, each goes into --out/<study folder name>/, and --out gets "
        "summary.csv, summary.xlsx and the comparison page summary.html (section 8).",
    )
    parser.add_argument("paths", nargs="+", metavar="STUDY", help="study folder or its study.toml")
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        help="output folder (default: reports/<study folder> for one study, reports/ for several)",
    )
    parser.add_argument(
        "--jobs",
        metavar="N",
        type=_positive_int,
        help="several studies: fit N at a time in local processes (default: the number of cores)",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="several studies: run them on the Dask cluster at ADDRESS, e.g. tcp://host:8786 "
        "(needs matid[dask]; the workers must see the study folders and --out by the same paths)",
    )
    add_units_and_strict(parser)


def _cmd_fit(args: argparse.Namespace) -> int:
    if len(args.paths) > 1:
        return fit_many(args)
    from matid.io.study import resolve_study_path

    source = resolve_study_path(args.paths[0])
    out = args.out or Path("reports") / source.resolve().parent.name
    if args.scheduler and not args.quiet:
        print("matid: one study: fitted here, not on the --scheduler", file=sys.stderr)
    return fit_and_write(source, out, units=args.units, quiet=args.quiet, strict=args.strict)


def fit_many(args: argparse.Namespace) -> int:
    """``matid fit A B C``: each study into --out/<folder>/, then the summary; exit code the worst."""
    from matid.app.batch import Progress, run_batch
    from matid.toml import escaped

    out = args.out or Path("reports")
    progress = Progress(len(args.paths), quiet=args.quiet)
    try:
        batch = run_batch(
            args.paths, out, units=args.units, jobs=args.jobs, scheduler=args.scheduler,
            strict=args.strict, on_done=progress,
        )  # fmt: skip
    finally:
        progress.close()
    for o in batch.outcomes:
        if o.error:
            error = o.error if args.debug else o.error.split("\n")[0]
            print(escaped(f"matid: {o.name}: error: {error}"), file=sys.stderr)
        for failure in o.failures:
            print(escaped(f"matid: {o.name}: fit failed: {failure}"), file=sys.stderr)
    print(escaped(batch_summary(batch)))
    print("outputs:")
    for o in batch.outcomes:
        if o.paths:
            print(escaped(f"  {Path(o.paths[0]).parent}/"))
    for path in batch.paths:
        print(escaped(f"  {path}"))
    return batch.code


def batch_summary(batch) -> str:
    """Per study: exit code and counts; per parameter and section: mean ± sd across specimens of the
    values with status ok, and the values left out; then the warnings."""
    from matid.app.compare import geometry_of, left_out_text, statistics_by_parameter, summary_rows

    lines = [
        f"{o.name}: exit {o.code}, {len(o.rows)} values, {len(o.warnings)} warnings" for o in batch.outcomes
    ]
    for s in statistics_by_parameter(summary_rows(batch.outcomes), geometry_of(batch.outcomes)):
        where = f"{s['parameter']} ({s['geometry']})" if s["geometry"] else s["parameter"]
        left = left_out_text(s)
        left = f"; left out: {left}" if left else ""
        if s["mean"] is None:
            lines.append(f"{where}: no value with status ok to pool{left}")
            continue
        sd = "" if s["sd"] is None else f" ± {s['sd']:.2g}"
        pooled = f"mean ± sd of {s['n']} specimens" if s["n"] > 1 else "one specimen"
        lines.append(f"{where}: {s['mean']:.5g}{sd} {s['unit']} ({pooled}, status ok){left}")
    lines += _warning_lines([f"{o.name}: {w}" for o in batch.outcomes for w in o.warnings])
    return "\n".join(lines)


def _warning_lines(warnings: Sequence[str]) -> list[str]:
    """The warnings block printed at the end of a run (docs/contract.md section 7)."""
    if not warnings:
        return ["warnings: none"]
    return [f"warnings ({len(warnings)}):"] + [f"  - {w}" for w in warnings]


def _register_demo(subparsers) -> None:
    parser = add_command(
        subparsers,
        "demo",
        _cmd_demo,
        help="fit the embedded synthetic demo study",
        description="Fit the synthetic demo study shipped with matid (matid.example).",
    )
    parser.add_argument(
        "--out", metavar="DIR", type=Path, default=Path("reports/demo"),
        help="output folder (default reports/demo)",
    )  # fmt: skip
    add_units_and_strict(parser)


def demo_study_path() -> Path:
    """study.toml of the embedded demo study (the package ``matid.example``)."""
    from importlib import resources

    path = resources.files("matid.example") / "study.toml"
    if not isinstance(path, Path):
        raise MatidError("the demo study is not installed as plain files; reinstall matid")
    return path


def _cmd_demo(args: argparse.Namespace) -> int:
    return fit_and_write(demo_study_path(), args.out, units=args.units, quiet=args.quiet, strict=args.strict)


def fit_and_write(source: Path, out: Path, *, units: str, quiet: bool, strict: bool = False) -> int:
    """Load, fit, write; print progress, failures, the summary and the warnings.

    0 if every fit was done (and, with ``strict``, nothing warned); else 1.
    """
    from matid.app import pipeline
    from matid.io.publish import claim_output
    from matid.io.study import load_study
    from matid.toml import escaped

    clock = time.perf_counter()

    def progress(message: str) -> None:
        if not quiet:
            print(f"[{time.perf_counter() - clock:6.1f} s] {message}", file=sys.stderr, flush=True)

    claim = claim_output(out)  # noqa: F841 -- --out checked and locked before any fitting; freed on return
    study = load_study(source)
    result = pipeline.run_study(study, progress=progress)
    progress(f"rendering the report and tables into {out}")
    paths = pipeline.write_outputs(result, out, units=units)
    progress("done")
    for failure in result.failures:
        print(f"matid: fit failed: {_what(failure)}: {failure.reason}", file=sys.stderr)
    print(escaped(summary(result, units=units)))  # control characters never reach the terminal raw
    print(escaped("\n".join(_warning_lines(fit_warnings(result)))))
    print("outputs:")
    for path in paths:
        print(f"  {path}")
    return study_code(result, strict)




def fit_warnings(result: StudyResult) -> list[str]:
    """The warnings of the fits done (failures and tests not fitted are listed in the summary)."""
    import dataclasses

    apart = set(dataclasses.replace(result, fits=()).warnings())
    return [w for w in result.warnings() if w not in apart]


def summary(result: StudyResult, *, units: str = "SI") -> str:
    """A compact table of the stiffnesses (status in words, value, 95 % interval, unit, method:
    page 1's, from stiffness.json), which of two estimates of one stiffness to use, then what was
    not fitted."""
    from matid.io.results import stiffness_json
    from matid.report.verdict import STATUS_WORDS, use_lines

    doc = stiffness_json(result, units)
    rows = [("specimen", "parameter", "status", "value", "95 % interval", "unit", "method")]
    for sid, params in doc["specimens"].items():
        for name, item in params.items():
            if name in _SUMMARY_SKIP:
                continue
            shown = item["value"] is not None
            value = f"{item['value']:.5g}" if shown else "no value"
            ci = item["ci95"]
            interval = f"{ci[0]:.4g} to {ci[1]:.4g}" if shown and ci is not None else ""
            status = STATUS_WORDS[item["status"]]
            rows.append((sid, name, status, value, interval, item["unit"], item["method"]))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip() for row in rows]
    uses = use_lines(doc)
    lines += ["which value to use (a stiffness estimated twice):", *(f"  - {u}" for u in uses)] if uses else []
    lines += [f"{_what(f)}: could not be fitted: {f.reason}" for f in result.failures]
    lines += [f"{_what(p)}: not yet fitted ({p.reason})" for p in result.pending]
    return "\n".join(lines)


def _what(failure: Failure) -> str:
    """The specimen, the parameter the failed kind is for (its first) and the kind."""
    from matid.fits.kinds import BY_NAME  # the fits are loaded by then: a summary follows a fit

    kind = BY_NAME.get(failure.kind)
    parameter = kind.parameters[0] if kind else failure.kind
    return f"{failure.specimen} {parameter} ({failure.kind.replace('_', ' ')})"


def _guarded(args: argparse.Namespace) -> int:
    """Run the command; map errors to exit codes and one-line messages."""
    try:
        return args.command(args)
    except KeyboardInterrupt as exc:  # SIGINT; SIGTERM during a batch (matid.app.batch.Terminated)
        print("matid: interrupted", file=sys.stderr)
        return getattr(exc, "exit_code", 130)
    except Exception as exc:
        from matid.toml import escaped

        code = exit_code(exc)
        hint = " (rerun with --debug for the traceback)" if code == 3 and not args.debug else ""
        if args.debug:
            traceback.print_exception(exc, file=sys.stderr)
        print(f"matid: error: {escaped(error_message(exc) + hint)}", file=sys.stderr)
        return code
