"""What the report shows, as plain strings and tables, shared by the HTML and PDF renderers.

The report computes nothing: every number comes from the :class:`StudyResult`, and the
stiffness values go through :func:`matid.io.results.stiffness_json` so that the report and
``stiffness.json`` / ``stiffness.csv`` agree digit for digit. This module only formats.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

from matid import __version__
from matid.fits.kinds import BY_NAME, KINDS
from matid.io.results import stiffness_json
from matid.model.results import Failure, InputFile, StudyResult, TestFit
from matid.model.status import INSEPARABLE_R, STRONG_R
from matid.report.bend import bend_drawings
from matid.report.diagnostics import glossary, lack_of_fit_table, model_choice_table
from matid.report.figures import Drawing, ExtraFigure, axis_unit, extra_figures, has_plot
from matid.report.formats import fe_notes, format_fe, format_held, format_runtime, format_started
from matid.report.holds import hold_drawings
from matid.report.quantities import Cell, info_cell
from matid.report.records import TestView, record_view
from matid.report.summary import (
    FIT_COLUMNS,
    FIT_NUMERIC,
    SUMMARY_COLUMNS,
    SUMMARY_NUMERIC,
    Note,
    interval_text,
    mark_text,
    marks_of,
    merged_names,
    moduli_intro,
    moduli_rows,
    notes_of,
    value_cells,
)
from matid.report.verdict import (
    STATUS_LEGEND,
    in_units,
    reason_line,
    status_words,
    summary_intro,
    use_lines,
    use_words,
)

#: Section titles and the parameters each test kind gives, in report order (from the registry).
SECTIONS: dict[str, tuple[str, tuple[str, ...]]] = {k.name: (k.title, k.parameters) for k in KINDS}
PARAMETER_TEST_KIND = {p: kind for kind, (_, params) in SECTIONS.items() for p in params}
#: The drawings a kind may name (:attr:`matid.model.kind.Kind.drawings`) -> what draws them.
DRAWINGS = {"bend": bend_drawings, "force_time": hold_drawings}

MODULI_COLUMNS = ("specimen", "modulus", "from", "value", "± standard error (1σ)", "unit", "check")
MODULI_NUMERIC = (False, False, False, True, True, False, False)
#: Info items not shown in the details table: figures and the arrays the figures are drawn from.
HIDDEN_INFO = ("figures", "plot_data", "force_time")
#: What a correlation of the estimates at least this strong (|r|) means for reading them.
CORRELATION_WORDS = (
    (INSEPARABLE_R, "inseparable: the data fix only a combination (not identifiable)"),
    (STRONG_R, "strong: read the two together (check it)"),
)
#: Info items whose mapping reads in words or as a table of its own: key -> (label, cell or None).
MAPPING_INFO = {
    "fe": ("FE mesh and solver", format_fe),
    "held_stiffness_propagation": (
        "uncertainty of the held stiffnesses in E_s",
        lambda v: format_held(v) or "none",
    ),
    "lack_of_fit": ("lack of fit", lack_of_fit_table),
    "model_choice": ("relaxation model compared", model_choice_table),
}


@dataclass(frozen=True)
class Table:
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    numeric: tuple[bool, ...]  # right-aligned columns


@dataclass(frozen=True)
class Block:
    """One specimen within one test-kind section (without a fit: its messages and tests only)."""

    specimen: str
    anchor: str
    messages: tuple[tuple[str, str], ...]  # (status, text), status "failed" | "pending" | "none"
    tests: tuple[TestView, ...]
    fit: TestFit | None = None
    plot: bool = False
    parameters: Table | None = None
    correlation: Table | None = None
    fe_notes: tuple[str, ...] = ()  # mesh and solver figures behind the estimates ("E_s: FE P2, ...")
    info: tuple[tuple[str, Cell], ...] = ()  # label, quantity text or a small table
    warnings: tuple[str, ...] = ()
    drawings: tuple[Drawing, ...] = ()  # figures the report draws from info arrays (bend fits)
    extras: tuple[ExtraFigure, ...] = ()


@dataclass(frozen=True)
class Section:
    kind: str  # also the section's anchor
    title: str
    parameters: str
    blocks: tuple[Block, ...]


@dataclass(frozen=True)
class Report:
    study: str
    meta: tuple[tuple[str, str], ...]  # the run: temperature, start, run time, units, software
    matid_version: str
    units: str
    summary_intro: str  # what the summary table shows: units, interval, rounding
    status_legend: tuple[tuple[str, str], ...]  # each status word and what it asks of the reader
    summary: Table
    moduli: Table | None  # E and G from the stiffnesses and the section
    moduli_intro: str  # what E and G are computed from: the sections' dimensions
    notes: tuple[Note, ...]  # every warning of the fits, numbered as the summary marks them
    failures: tuple[str, ...]
    pending: tuple[str, ...]
    sections: tuple[Section, ...]
    provenance: Table
    glossary: tuple[tuple[str, str], ...] = ()
    #: Which of two estimates of one stiffness to use (E_s or E_s_torsion), per specimen, and why.
    use: tuple[str, ...] = ()


def build_report(result: StudyResult, units: str) -> Report:
    """Everything the report shows, formatted once for both renderers."""
    doc = stiffness_json(result, units)
    titles = {kind: title for kind, (title, _) in SECTIONS.items()}
    notes = [replace(n, text=in_units(n.text, units)) for n in notes_of(result, titles)]
    moduli = moduli_rows(result, units)
    others = dict(result.versions)
    version = others.pop("matid", __version__)
    return Report(
        study=result.study.name,
        meta=(
            ("Temperature", result.study.temperature or "not given"),
            ("Run started", format_started(result.started)),
            ("Runtime", format_runtime(result.runtime_s)),
            ("Units", units),
            ("Software", ", ".join([f"matid {version}", *(f"{k} {v}" for k, v in others.items())])),
        ),
        matid_version=version,
        units=units,
        summary_intro=summary_intro(units),
        status_legend=STATUS_LEGEND,
        summary=summary_table(result, doc, marks_of(result, notes, titles), units),
        moduli=Table(MODULI_COLUMNS, tuple(moduli), MODULI_NUMERIC) if moduli else None,
        moduli_intro=moduli_intro(result),
        notes=tuple(notes),
        failures=tuple(failure_message(f) for f in result.failures),
        pending=tuple(pending_message(p, with_specimen=True) for p in result.pending),
        sections=tuple(_sections(result, doc, units)),
        provenance=provenance_table(result.inputs),
        glossary=glossary(units),
        use=tuple(in_units(line, units) for line in use_lines(doc)),
    )


# -- formatting ------------------------------------------------------------------------------


def _param_row(name: str, item: Mapping, marks: list[int]) -> tuple[str, ...]:
    """A fit's table row: status in words, value, standard error, interval, points, method, marks."""
    value, stderr, rel, low, high, unit = value_cells(item)
    status = status_words(str(item.get("status", "ok")))
    return (name, status, value, stderr, rel, interval_text(low, high), unit, str(item["n_points"]),
            str(item["method"]), mark_text(marks))  # fmt: skip


def _summary_row(sid: str, name: str, item: Mapping, marks: list[int], units: str) -> tuple[str, ...]:
    """Page 1's row: the status in words, the value and its 95 % interval, the reason in one line."""
    value, _, _, low, high, unit = value_cells(item)
    fixed = "fixed in study.toml, not fitted" if item["method"] == "fixed" else ""
    reason = "; ".join(part for part in (use_words(name, item), in_units(reason_line(item), units) or fixed) if part)
    why = " ".join(part for part in (reason, mark_text(marks)) if part)
    status = status_words(str(item.get("status", "ok")))
    return (sid, name, status, value, interval_text(low, high), unit, why)


def _parameters_of(kind: str) -> str:
    return SECTIONS[kind][1][0] if kind in SECTIONS else kind


def failure_message(failure: Failure) -> str:
    kind = _test_kind(failure.kind)
    title = SECTIONS[kind][0].lower() if kind in SECTIONS else failure.kind
    return f"{failure.specimen}: {_parameters_of(kind)} could not be fitted ({title}): {failure.reason}"


def pending_message(pending: Failure, *, with_specimen: bool = False) -> str:
    text = f"{_parameters_of(_test_kind(pending.kind))}: not yet fitted ({pending.reason})"
    return f"{pending.specimen}: {text}" if with_specimen else text


def _test_kind(kind: str) -> str:
    """Failures name a test kind; accept a parameter name too."""
    return PARAMETER_TEST_KIND.get(kind, kind)


# -- tables ----------------------------------------------------------------------------------


def summary_table(
    result: StudyResult, doc: Mapping, marks: Mapping[tuple[str, str], list[int]], units: str = "SI"
) -> Table:
    """Specimen x parameter, from stiffness_json; warnings by number; missing parameters say why."""
    missing = [(f, "could not be fitted") for f in result.failures]
    missing += [(p, "not yet fitted") for p in result.pending]
    rows = []
    for sid, params in doc["specimens"].items():
        for name, item in merged_names(params):
            numbers = sorted({n for part in name.split(" = ") for n in marks.get((sid, part), [])})
            rows.append(_summary_row(sid, name, item, numbers, units))
        for item, status in missing:
            param = _parameters_of(_test_kind(item.kind))
            if item.specimen == sid and param not in params:
                rows.append((sid, param, status, "no value", "—", "—", in_units(item.reason, units)))
    return Table(SUMMARY_COLUMNS, tuple(rows), SUMMARY_NUMERIC)


def provenance_table(inputs: tuple[InputFile, ...]) -> Table:
    rows = tuple((f.path.name, str(f.n_rows), f.sha256, str(f.path)) for f in inputs)
    return Table(("file", "rows", "sha256", "path"), rows, (False, True, False, False))


def _fit_parameters(fit: TestFit, doc: Mapping) -> tuple[Table, tuple[str, ...]]:
    """The fit's parameter table and its numbered warnings: the fit's own, then each parameter's
    (as stiffness.json gives them), once each; the table's warnings column refers to them by
    number, so a long warning is read once, in full width, below the table."""
    items = doc["specimens"].get(fit.specimen, {})
    mine = {e.parameter: items[e.parameter] for e in fit.estimates if e.parameter in items}
    listed = list(dict.fromkeys(fit.warnings))
    for _, item in merged_names(mine):
        listed += [w for w in item.get("warnings") or () if w not in listed]
    rows = tuple(
        _param_row(name, item, sorted({listed.index(w) + 1 for w in item.get("warnings") or ()}))
        for name, item in merged_names(mine)
    )
    return Table(FIT_COLUMNS, rows, FIT_NUMERIC), tuple(listed)


def _correlation(fit: TestFit) -> Table | None:
    if not fit.correlation:
        return None
    rows = []
    for pair, r in fit.correlation.items():
        a, _, b = str(pair).partition("|")
        strength = next((words for least, words in CORRELATION_WORDS if abs(r) >= least), "")
        rows.append((a, b or "—", f"{r:+.3f}", strength))
    return Table(("parameter", "with", "r", ""), tuple(rows), (False, False, True, False))


# -- sections --------------------------------------------------------------------------------


def _sections(result: StudyResult, doc: Mapping, units: str) -> list[Section]:
    """A section per test kind with anything to show, a block per specimen."""
    sections = []
    for kind, (title, params) in SECTIONS.items():
        specimens = _specimens_of(result, kind)
        if specimens:
            blocks = (
                _block(result, doc, kind, sid, f"{kind}-{i + 1}", units) for i, sid in enumerate(specimens)
            )
            sections.append(Section(kind, title, ", ".join(params), tuple(blocks)))
    return sections


def _specimens_of(result: StudyResult, kind: str) -> list[str]:
    """Specimens with anything to show for ``kind``, in study order (then any others)."""
    seen = [t.specimen for t in result.study.tests if t.kind == kind]
    seen += [f.specimen for f in result.fits if f.kind == kind]
    seen += [f.specimen for f in (*result.failures, *result.pending) if _test_kind(f.kind) == kind]
    order = [s.id for s in result.study.specimens]
    unique = list(dict.fromkeys(seen))
    return sorted(unique, key=lambda s: order.index(s) if s in order else len(order))


def _drawings(fit: TestFit, units: str) -> tuple[tuple[Drawing, ...], tuple[ExtraFigure, ...]]:
    """The drawings of ``fit``, or why they cannot be drawn (as a failed extra figure)."""
    names = BY_NAME[fit.kind].drawings if fit.kind in BY_NAME else ()
    try:
        return tuple(d for name in names for d in DRAWINGS[name](fit, units)), ()
    except (KeyError, TypeError, ValueError, IndexError) as exc:  # malformed plot data: say so, go on
        return (), (ExtraFigure("Figures from the fit data", None, f"{type(exc).__name__}: {exc}"),)


def _block(result: StudyResult, doc: Mapping, kind: str, sid: str, anchor: str, units: str) -> Block:
    fit = next((f for f in result.fits if f.kind == kind and f.specimen == sid), None)
    mine = [f for f in result.failures if _test_kind(f.kind) == kind and f.specimen == sid]
    messages = [("failed", failure_message(f)) for f in mine]
    mine = [p for p in result.pending if _test_kind(p.kind) == kind and p.specimen == sid]
    messages += [("pending", pending_message(p)) for p in mine]
    tests = result.study.tests_of(kind, sid, included=False)
    if fit is None:
        messages = messages or [("none", f"{_parameters_of(kind)}: no fit result")]
        return Block(sid, anchor, tuple(messages), tuple(record_view(t, result.inputs) for t in tests))
    known = {(t.file, t.index) for t in tests}
    tests += [t for t in fit.tests if (t.file, t.index) not in known]
    parameters, warnings = _fit_parameters(fit, doc)
    drawings, problems = _drawings(fit, units)
    return Block(
        specimen=sid,
        anchor=anchor,
        messages=tuple(messages),
        tests=tuple(record_view(t, result.inputs) for t in tests),
        fit=fit,
        plot=has_plot(fit),
        parameters=parameters,
        correlation=_correlation(fit),
        fe_notes=fe_notes(fit),
        info=_info(fit, units),
        warnings=tuple(in_units(w, units) for w in warnings),
        drawings=drawings,
        extras=(*extra_figures(fit), *problems),
    )


def _info(fit: TestFit, units: str) -> tuple[tuple[str, Cell], ...]:
    shown = [e.extra["fe"] for e in fit.estimates if isinstance(e.extra.get("fe"), Mapping)]
    x, y = axis_unit(fit.x_label, units), axis_unit(fit.y_label, units)
    axes = {"x": (x.unit, x.factor), "y": (y.unit, y.factor)}
    rows: list[tuple[str, Cell]] = []
    for key, value in fit.info.items():
        if key in HIDDEN_INFO or key == "fe" and value in shown:  # fe: under the parameters already
            continue
        label, make = MAPPING_INFO.get(key, ("", None))
        cell = make(value) if make is not None and isinstance(value, Mapping) else None
        rows.append((label, cell) if cell is not None else info_cell(str(key), value, units, axes))
    return tuple(rows)
