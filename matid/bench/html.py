"""bench.html: one self-contained page (plots inlined as base64 PNG) with the tables of bench.json.

The page is ``templates/bench.html`` rendered by jinja2 with autoescape on; the functions here
turn values into text and nested results into table rows, never into JSON.
"""

from __future__ import annotations

import base64
import re

from matid.report.html import template


def page(doc: dict, figures: dict[str, bytes]) -> str:
    """The page of a bench.json document ``doc`` with the PNG ``figures`` (by file name)."""
    return template("matid.bench", "bench.html").render(
        doc=doc,
        sections=doc["sections"],
        figures={name: base64.b64encode(png).decode("ascii") for name, png in figures.items()},
        fmt=fmt,
        numeric=_numeric,
        outcome_class=_outcome_class,
        with_state=_with_state,
        pairs=lambda mapping, key, value: [{key: k, value: v} for k, v in mapping.items()],
        columns=_columns,
        readable=_readable,
        rst=rst,
    )


def fmt(value, digits: int = 3) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    if isinstance(value, (list, tuple)):
        return ", ".join(fmt(v, digits) for v in value)
    if isinstance(value, dict):
        return "; ".join(f"{k}: {fmt(v, digits)}" for k, v in value.items())
    return str(value)


def _numeric(value) -> bool:
    """Numbers stay on one line, right-aligned."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _outcome_class(row: dict) -> str:
    outcome = row.get("outcome", "")
    return (
        "ok"
        if outcome == "ok"
        else "warn"
        if outcome.startswith(("raised", "refused", "inaccurate"))
        else "bad"
    )


def _with_state(rows: list[dict]) -> list[dict]:
    """Stability rows with the state check in words."""
    return [{**r, "stable / residual": _state(r.get("state_check"))} for r in rows]


def _state(check: dict | None) -> str:
    if not check:
        return "-"
    if "min_eigenvalue" in check:
        return (
            f"{'stable' if check['stable'] else 'UNSTABLE'} (min eig {check['min_eigenvalue']:.3g}), "
            f"|R| {check['residual']:.2g}"
        )
    return check.get("check", "-")


def _columns(rows: list[dict]) -> list[str]:
    """Every key of the rows, in order of appearance."""
    return list(dict.fromkeys(c for r in rows for c in r))


def _flat(value: dict, prefix: str = "") -> dict:
    """A nested mapping with its keys joined: {"3d": {"dofs": 1}} -> {"3d dofs": 1}."""
    out = {}
    for k, v in value.items():
        name = f"{prefix}{k}".replace("_", " ")
        out.update(_flat(v, name + " ") if isinstance(v, dict) else {name: v})
    return out


def _readable(value) -> dict:
    """A value of bench.json readably: mappings and lists of mappings as table rows and columns,
    anything else as paragraphs of text, never JSON."""
    if isinstance(value, dict) and value and all(isinstance(v, dict) for v in value.values()):
        rows = [{"": k, **_flat(v)} for k, v in value.items()]
    elif isinstance(value, dict):
        rows = [{"item": k.replace("_", " "), "value": v} for k, v in value.items()]
        return {"rows": rows, "columns": ["item", "value"]}
    elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        rows = [_flat(v) for v in value]
    else:
        return {"paragraphs": [fmt(v) for v in value] if isinstance(value, list) else [fmt(value, 4)]}
    return {"rows": rows, "columns": _columns(rows)}


#: Inline code in reStructuredText: :role:`target` (an optional ~ dropped) or ``literal``.
CODE = re.compile(r":\w+:`~?([^`]+)`|``([^`]+)``")


def rst(text: str) -> list[list[tuple[str, bool]]]:
    """A docstring excerpt (reStructuredText) as list items ("- " items, continuation lines joined),
    each a list of (text, is code) parts."""
    items, current = [], None
    for line in text.splitlines():
        if line.lstrip().startswith("- "):
            current = [line.lstrip()[2:]]
            items.append(current)
        elif current is not None and line.strip():
            current.append(line.strip())
        elif line.strip():
            items.append([line.strip()])
    return [_code_parts(" ".join(item)) for item in items]


def _code_parts(text: str) -> list[tuple[str, bool]]:
    parts, start = [], 0
    for match in CODE.finditer(text):
        parts += [(text[start : match.start()], False), (match.group(1) or match.group(2), True)]
        start = match.end()
    return [*parts, (text[start:], False)]
