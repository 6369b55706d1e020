"""``matid bench``: run the sections, write bench.json, bench.html and the plots.

:func:`register` adds the subcommand to the ``matid`` parser; :func:`run_bench`
does the work and returns the exit code: 0 when every section ran and every
stability case ended acceptably (ok, raised ConvergenceError, or flagged
inaccurate), 1 otherwise (a "wrong" or timed-out case, or a section that
failed: the files are still written and say which).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import sys
import time
import traceback
from collections.abc import Iterable
from pathlib import Path

from matid.bench import convergence, leave_out, peers, stability, vs3d
from matid.bench.common import jsonable, machine
from matid.bench.html import page
from matid.bench.plots import convergence_figure, penalty_figure

#: The sections in their order, each a module with ``run(quick) -> dict``.
SECTIONS = {
    "convergence": convergence,
    "stability": stability,
    "vs_3d": vs3d,
    "leave_out": leave_out,
    "peers": peers,
}
DEFAULT_OUT = Path("reports/bench")


def register(subparsers) -> argparse.ArgumentParser:
    """Add ``matid bench`` to the ``matid`` subparsers (``args.command(args)`` runs it)."""
    parser = subparsers.add_parser(
        "bench",
        help="measure accuracy, cost and robustness of the rod solver",
        description="Run the bench sections; write bench.json, bench.html and the plots into --out.",
    )
    parser.add_argument(
        "--out", metavar="DIR", type=Path, default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})"
    )
    parser.add_argument("--quick", action="store_true", help="fewer mesh levels and cases (under a minute)")
    parser.add_argument(
        "--sections",
        default=",".join(SECTIONS),
        help=f"comma-separated subset of {','.join(SECTIONS)} (default: all)",
    )
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    parser.set_defaults(command=_cmd_bench)
    return parser


def _cmd_bench(args: argparse.Namespace) -> int:
    return run_bench(args.out, quick=args.quick, sections=args.sections, quiet=args.quiet)


def parse_sections(sections: str | Iterable[str] | None) -> list[str]:
    """The requested sections in canonical order; ValueError naming ``sections`` for an unknown one."""
    if sections is None:
        return list(SECTIONS)
    names = [s.strip() for s in (sections.split(",") if isinstance(sections, str) else sections) if s.strip()]
    unknown = [n for n in names if n not in SECTIONS]
    if unknown or not names:
        raise ValueError(
            f"sections: unknown {', '.join(unknown) or '(none given)'}; choose from {', '.join(SECTIONS)}"
        )
    return [s for s in SECTIONS if s in names]


def run_bench(
    out: str | Path, quick: bool = False, sections: str | Iterable[str] | None = None, *, quiet: bool = True
) -> int:
    """Run ``sections`` (all by default) and write the outputs into ``out``; returns the exit code."""
    names = parse_sections(sections)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    results, times = {}, {}
    for name in names:
        _say(quiet, f"matid bench: {name} ...")
        start = time.perf_counter()
        results[name] = _run_section(name, quick)
        times[name] = time.perf_counter() - start
        if name == "peers" and results[name].get("rows"):
            _say(quiet, peers.table(results[name]))
        if name == "convergence" and results[name].get("p2_vs_hermite"):
            _say(quiet, convergence.side_by_side_table(results[name]["p2_vs_hermite"]))
        _say(quiet, f"matid bench: {name} done in {times[name]:.1f} s")
    doc = {
        "created": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "quick": quick,
        "sections_requested": names,
        "machine": machine(),
        "runtime_s": time.perf_counter() - t0,
        "section_runtime_s": times,
        "sections": results,
    }
    doc = jsonable(doc)
    figures = _figures(doc["sections"])
    for filename, png in figures.items():
        (out / filename).write_bytes(png)
    (out / "bench.json").write_text(json.dumps(doc, indent=1), encoding="utf-8")
    (out / "bench.html").write_text(page(doc, figures), encoding="utf-8")
    _say(quiet, f"matid bench: wrote {out / 'bench.json'}, {out / 'bench.html'} ({doc['runtime_s']:.1f} s)")
    return 1 if _failed(doc["sections"]) else 0


def _run_section(name: str, quick: bool) -> dict:
    try:
        return SECTIONS[name].run(quick)
    except Exception as exc:  # noqa: BLE001 - one failing section must not hide the others
        return {"status": f"failed: {type(exc).__name__}: {exc}", "traceback": traceback.format_exc()}


def _figures(sections: dict) -> dict[str, bytes]:
    figures = {}
    rows = sections.get("convergence", {}).get("rows")
    if rows:
        figures["convergence_error_vs_time.png"] = convergence_figure(rows, "runtime_s")
        figures["convergence_error_vs_elements.png"] = convergence_figure(rows, "elements")
    rows = sections.get("stability", {}).get("rows")
    png = penalty_figure(rows) if rows else None
    if png is not None:
        figures["stability_raw_penalty.png"] = png
    return figures


def _failed(sections: dict) -> bool:
    """A section failed, or a stability case ended neither ok, raised, nor flagged inaccurate."""
    failed = any(str(s.get("status", "")).startswith("failed") for s in sections.values())
    return failed or bool(sections.get("stability", {}).get("not_acceptable"))


def _say(quiet: bool, message: str) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)
