"""Formatting of single values for the report: numbers, run times, dates, FE and held-stiffness notes.

Pure text from values the fits report; nothing is computed here.
"""

from __future__ import annotations

from collections.abc import Mapping
from datetime import datetime

import numpy as np

from matid.model.results import TestFit
from matid.report.quantities import label_of, text_of


def fmt(x: float | None, digits: int = 5) -> str:
    if x is None or not np.isfinite(x):
        return "—"
    text = f"{x:.{digits}g}"
    if "e+" in text and abs(x) < 1e6:  # 1e+02 reads worse than 100
        text = f"{float(text):.0f}"
    return text


def format_value(value: object, *, limit: int = 300) -> str:
    """A readable one-line rendering of an info value (number, list, array, dict, text)."""
    text = _format(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _format(value: object, nested: bool = False) -> str:
    if isinstance(value, np.generic):
        value = value.item()
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return fmt(value)
    if isinstance(value, Mapping):
        items = [f"{k} = {_format(v, True)}" for k, v in value.items()]
        return "{" + ", ".join(items) + "}" if nested else "; ".join(items)
    if isinstance(value, (list, tuple, np.ndarray)):
        items = list(np.asarray(value).ravel()) if isinstance(value, np.ndarray) else list(value)
        if len(items) > 8:
            shown = [_format(v, True) for v in items[:6]]
            return f"[{', '.join(shown)}, …, {_format(items[-1], True)}] ({len(items)} values)"
        return "[" + ", ".join(_format(v, True) for v in items) + "]"
    return str(value)


def format_runtime(seconds: float) -> str:
    if seconds < 0.1:
        return f"{seconds * 1e3:.0f} ms"
    if seconds < 120:
        return f"{seconds:.1f} s"
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest} s"


def format_started(started: str) -> str:
    try:
        when = datetime.fromisoformat(started) if started else None
    except ValueError:
        when = None
    if when is None:
        return started or "not recorded"
    text = when.strftime("%Y-%m-%d %H:%M:%S")
    return f"{text} {when.strftime('%Z') or when.strftime('%z')}".strip()


def fe_notes(fit: TestFit) -> tuple[str, ...]:
    """One line per distinct ``extra["fe"]`` of the estimates ("FE mesh and solver for E_s: ...")."""
    groups: dict[str, list[str]] = {}
    for estimate in fit.estimates:
        fe = estimate.extra.get("fe")
        if isinstance(fe, Mapping):
            groups.setdefault(format_fe(fe), []).append(estimate.parameter)
    return tuple(f"FE mesh and solver for {', '.join(names)}: {text}" for text, names in groups.items())


def format_fe(fe: Mapping) -> str:
    """The mesh and solver figures of a finite-element fit, in words."""
    head = " ".join(format_value(fe[k]) for k in ("elements", "element") if k in fe)
    parts = [f"{head} elements"] if head else []
    if isinstance(fe.get("discretization_error"), (int, float)):
        parts.append(f"discretisation error {fmt(fe['discretization_error'], 2)} of E_s (relative)")
    if "rod_solves" in fe:
        parts.append(f"{format_value(fe['rod_solves'])} rod solves")
    if isinstance(fe.get("runtime_s"), (int, float)):
        parts.append(f"run time {format_runtime(fe['runtime_s'])}")
    known = {"element", "elements", "discretization_error", "runtime_s", "rod_solves", "levels"}
    parts += [f"{label_of(k)}: {text_of(v)}" for k, v in fe.items() if k not in known]
    return ", ".join(parts)


def format_held(held: Mapping) -> str:
    """How the uncertainty of each held stiffness p moves into E_s (d ln E_s / d ln p and its share)."""
    parts = []
    for name, item in held.items():
        if isinstance(item, Mapping) and {"dlogEs_dlogp", "contribution"} <= item.keys():
            parts.append(
                f"{name}: d ln E_s / d ln {name} = {fmt(item['dlogEs_dlogp'], 3)}, "
                f"adds ±{fmt(100 * item['contribution'], 2)} % to E_s"
            )
        else:
            parts.append(f"{name}: {format_value(item)}")
    return "; ".join(parts)
