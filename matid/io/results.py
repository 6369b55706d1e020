"""A study's results written out as stiffness tables (docs/contract.md sections 4 and 7).

Fits produce :class:`~matid.model.results.TestFit` objects; the pipeline gathers them in a
:class:`~matid.model.results.StudyResult`; this module turns that into the rows of the stiffness
table (:func:`table_rows`), ``stiffness.csv`` and ``stiffness.json``; the
same rows feed ``stiffness.xlsx`` (:mod:`matid.io.xlsx`) and the DataFrame of
:mod:`matid.app.api`. Values are SI inside and converted once here (``--units cgs``).
"""

from __future__ import annotations

import csv
import io
import math
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from matid import __version__
from matid.io.cells import text_cell
from matid.model.results import Estimate, StudyResult, each_value
from matid.model.status import Status, choices, parameter_statuses, status_text
from matid.units import from_si


def _reported(
    est: Estimate, verdict: Status, units: str
) -> tuple[float | None, float | None, tuple | None, str]:
    """Value, stderr and 95 % interval in ``units`` (non-finite ones None; all None when the value
    is not printed: contract section 10), and the unit."""
    value, unit = from_si(est.value, est.kind, units)
    if not verdict.printed:
        return None, None, None, unit
    factor = value / est.value if est.value else from_si(1.0, est.kind, units)[0]
    stderr = None if est.stderr is None else _clean(est.stderr * factor)
    ci = None if est.ci95 is None else (_clean(est.ci95[0] * factor), _clean(est.ci95[1] * factor))
    return value, stderr, ci, unit


def _clean(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def stiffness_json(result: StudyResult, units: str = "SI") -> dict:
    """The ``stiffness.json`` document (docs/contract.md sections 4 and 7)."""
    specimens: dict[str, dict] = {}
    warns, windows = parameter_warnings(result), parameter_windows(result)
    statuses, uses, refs = parameter_statuses(result), choices(result), warning_refs(result)
    for sid, params in result.estimates().items():
        entry = {}
        for name, est in params.items():
            verdict = statuses[(sid, name)]
            value, stderr, ci, unit = _reported(est, verdict, units)
            item: dict[str, object] = {
                "value": value,
                "stderr": stderr,
                "ci95": None if ci is None else list(ci),
                "status": verdict.status,
                "status_reason": verdict.reason,
                "measure_instead": verdict.instead if not verdict.printed else "",
                "unit": unit,
                "n_points": est.n_points,
                "method": est.method,
                "warnings": warns.get((sid, name), []),
                "warning_refs": refs.get((sid, name), []),
                "window": windows.get((sid, name)),
            }
            use = uses.get((sid, name))
            if use is not None:  # one of two estimates of one stiffness: which to use, and why
                item["use"] = {"quantity": use.quantity, "parameter": use.parameter, "why": use.why}
            item.update({k: v for k, v in est.extra.items() if k != "specimen" and k not in item})
            entry[name] = item
        specimens[sid] = entry
    return {
        "matid_version": __version__,
        "unit_system": units,
        "study": result.study.name,
        "inputs": [{"file": f.path.name, "sha256": f.sha256} for f in result.inputs],
        "specimens": specimens,
        "warnings": result.warnings(),
    }


#: Columns of stiffness.csv: the value and its interval, then how it was found and what to read with it.
CSV_COLUMNS = ["specimen", "parameter", "value", "stderr", "ci95_low", "ci95_high", "unit"]
CSV_COLUMNS += ["n_points", "method", "warnings", "status"]
#: Separator of the warnings of one parameter in the ``warnings`` column.
WARNING_SEPARATOR = "; "


def parameter_warnings(result: StudyResult) -> dict[tuple[str, str], list[str]]:
    """(specimen, parameter) -> its warnings: those of the fit that gave it (a fit's warning, e.g. lack
    of fit, concerns each of its parameters: docs/contract.md section 7), then its own."""
    return each_value(result, lambda est, fit: [*(fit.warnings if fit else ()), *est.warnings])


def warning_refs(result: StudyResult) -> dict[tuple[str, str], list[int]]:
    """(specimen, parameter) -> the positions (from 0) in stiffness.json's top-level ``warnings`` of
    its warnings: a fit's warning is one fact, listed once there and referred to by each parameter
    of the fit (its ``warnings`` repeat the text, contract section 7)."""
    position = {entry: i for i, entry in reversed(list(enumerate(result.warning_list())))}

    def refs(est: Estimate, fit) -> list[int]:
        mine = [(fit.specimen, fit.kind, w) for w in fit.warnings] if fit else []
        mine += [(fit.specimen if fit else "", est.parameter, w) for w in est.warnings]
        return sorted({position[m] for m in mine if m in position})

    return each_value(result, refs)


def rows_used(result: StudyResult) -> dict[Path, int]:
    """Input file -> rows that entered a fit (files whose fit gives one series per test)."""
    used: dict[Path, int] = {}
    for fit in result.fits:
        if len(fit.series) != len(fit.tests):
            continue  # no per-file mapping: left blank rather than guessed
        for test, series in zip(fit.tests, fit.series, strict=True):
            n = len(series.x) if series.used is None else int(np.count_nonzero(series.used))
            used[test.file] = used.get(test.file, 0) + n
    return used


def parameter_windows(result: StudyResult) -> dict[tuple[str, str], dict]:
    """(specimen, parameter) -> the fit window used (SI): requested ranges, rows used and read.

    ``requested`` holds the ``window`` of each test in study.toml (file -> column ->
    [low, high], SI); ``rows_used``/``rows_read`` count the rows of the fit's files that
    entered the fit and that were read; ``fit`` holds what the fitter reports of the
    window it chose itself (``info["window"]``, or the linear range / time window).
    """
    n_read = {f.path: f.n_rows for f in result.inputs}
    out: dict[tuple[str, str], dict] = {}
    for fit in result.fits:
        requested = {
            t.file.name: {col: [float(lo), float(hi)] for col, (lo, hi) in t.window.items()}
            for t in fit.tests
            if t.window
        }
        chosen = {k: fit.info[k] for k in _WINDOW_INFO_KEYS if k in fit.info}
        read = sum(n_read.get(t.file, 0) for t in fit.tests)
        for est in fit.estimates:
            out[(fit.specimen, est.parameter)] = {
                "requested": requested,
                "rows_used": est.n_points,
                "rows_read": read,
                "fit": _jsonable(chosen),
            }
    return out


#: Keys of ``TestFit.info`` that describe the window a fitter chose.
_WINDOW_INFO_KEYS = ("window", "linear_range", "time_window_s", "unloading_rows_excluded", "excluded_points")


def _jsonable(value: object) -> object:
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return _clean(float(value))
    if isinstance(value, np.integer):
        return int(value)
    return value


def table_rows(result: StudyResult, units: str = "SI") -> list[dict[str, object]]:
    """One row per specimen and parameter, keyed by :data:`CSV_COLUMNS` (numbers as float or None).

    A ``not_identifiable`` value has no number: value, stderr and interval are None and the
    warnings say why and what to measure instead (docs/contract.md section 10).
    """
    warns, statuses = parameter_warnings(result), parameter_statuses(result)
    rows = []
    for sid, params in result.estimates().items():
        for name, est in params.items():
            verdict = statuses[(sid, name)]
            value, stderr, ci, unit = _reported(est, verdict, units)
            low, high = ci or (None, None)
            text = WARNING_SEPARATOR.join(status_text(verdict, warns.get((sid, name), [])))
            rows.append(
                dict(
                    zip(
                        CSV_COLUMNS,
                        [sid, name, value, stderr, low, high, unit, est.n_points, est.method,
                         text, verdict.status],
                        strict=True,
                    )
                )
            )  # fmt: skip
    return rows


#: CSV number formats per column (value and interval to 10 digits, stderr to 6).
_CSV_FORMATS = {"value": ".10g", "stderr": ".6g", "ci95_low": ".10g", "ci95_high": ".10g"}


def csv_text(rows: list[dict[str, object]], columns: list[str]) -> str:
    """Rows as CSV text with ``columns``; None is an empty cell, floats as in :data:`_CSV_FORMATS`,
    text never a formula (:func:`matid.io.cells.text_cell`, docs/contract.md section 11)."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([text_cell(c) for c in columns])
    for row in rows:
        writer.writerow([_csv_cell(row[c], _CSV_FORMATS.get(c)) for c in columns])
    return buffer.getvalue()


def _csv_cell(value: object, number_format: str | None) -> object:
    """None as an empty cell, a number in ``number_format`` (or as it is), text as :func:`text_cell`."""
    if value is None:
        return ""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return format(value, number_format) if number_format else value
    return text_cell(value)


def stiffness_csv(result: StudyResult, units: str = "SI") -> str:
    """The ``stiffness.csv`` text: one row per specimen and parameter, warnings then status last."""
    return csv_text(table_rows(result, units), CSV_COLUMNS)


def atomic_write(path: Path, data: str | bytes) -> None:
    """Write one file whole or not at all: a temporary name in the same folder, fsync, then rename.

    For a set of files that belong together (a report) use :func:`matid.io.publish.publish`,
    which replaces the whole folder in one step.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    mode = "wb" if isinstance(data, bytes) else "w"
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, mode, **({} if mode == "wb" else {"encoding": "utf-8"})) as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())  # the rename must never publish a file whose blocks are not on disk
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs are ordinary files
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
