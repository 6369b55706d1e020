"""bench.html: one self-contained page (plots inlined as base64 PNG) with the tables of bench.json."""

from __future__ import annotations

import base64
import re
from html import escape

CSS = """body{font-family:sans-serif;margin:2em auto;max-width:1200px;padding:0 1em}
.scroll{overflow-x:auto;margin:1em 0}table{border-collapse:collapse;font-size:12px}
td,th{border:1px solid #ccc;padding:3px 6px;text-align:left;vertical-align:top}
td{max-width:24em;overflow-wrap:break-word}td.n{white-space:nowrap;text-align:right}th{background:#eee}.bad{background:#fdd;font-weight:bold}
.warn{background:#ffe9c6}.ok{background:#e8f6e8}img{max-width:100%}code{font-size:12px}
.rules li{margin:.2em 0}"""


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


def table(rows: list[dict], columns: list[str], *, classes=None, digits: int = 3) -> str:
    head = "".join(f"<th>{escape(c.replace('_', ' '))}</th>" for c in columns)
    body = []
    for row in rows:
        css = classes(row) if classes else ""
        cells = "".join(f"<td{_numeric(row.get(c))}>{escape(fmt(row.get(c), digits))}</td>" for c in columns)
        body.append(f'<tr class="{css}">{cells}</tr>')
    return f"<div class='scroll'><table><tr>{head}</tr>{''.join(body)}</table></div>"


def _numeric(value) -> str:
    """Numbers stay on one line, right-aligned."""
    return " class='n'" if isinstance(value, (int, float)) and not isinstance(value, bool) else ""


def image(title: str, png: bytes) -> str:
    data = base64.b64encode(png).decode("ascii")
    return (
        f'<figure><img alt="{escape(title)}" src="data:image/png;base64,{data}"><figcaption>{escape(title)}'
        "</figcaption></figure>"
    )


def _outcome_class(row: dict) -> str:
    outcome = row.get("outcome", "")
    return "ok" if outcome == "ok" else "warn" if outcome.startswith(("raised", "inaccurate")) else "bad"


def page(doc: dict, figures: dict[str, bytes]) -> str:
    parts = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>matid bench</title><style>{CSS}</style>"
        "</head><body><h1>matid bench</h1>",
        f"<p>{'quick' if doc['quick'] else 'full'} run, {escape(doc['created'])}, "
        f"total {doc['runtime_s']:.1f} s</p>",
        "<h2>Machine</h2>",
        table([doc["machine"]], list(doc["machine"])),
    ]
    sections = doc["sections"]
    if "convergence" in sections:
        parts.append(_convergence(sections["convergence"], figures))
    if "stability" in sections:
        parts.append(_stability(sections["stability"], figures))
    if "leave_out" in sections:
        s = sections["leave_out"]
        parts += [
            "<h2>Leave-out</h2>",
            _notes(s),
            table(
                s.get("rows", []),
                [
                    "scene",
                    "model",
                    "terms",
                    "contact",
                    "runtime_s",
                    "full_runtime_s",
                    "time_saved_s",
                    "speedup",
                    "answer_difference",
                    "note",
                ],
            ),
        ]
    if "vs_3d" in sections:
        parts.append(_vs_3d(sections["vs_3d"]))
    parts.append("</body></html>")
    return "\n".join(parts)


def _vs_3d(s: dict) -> str:
    """The vs_3d section: notes in words, then each part as a table (nested parts flattened)."""
    rows = s.get("rows") if isinstance(s.get("rows"), list) else []
    columns = list(dict.fromkeys(k for r in rows if isinstance(r, dict) for k in r))
    parts = ["<h2>Against 3D (matid.bench.vs3d)</h2>", _notes(s)]
    for key, value in s.items():
        if key not in {"rows", "notes", "quick"}:
            parts += [f"<h3>{escape(key.replace('_', ' ').capitalize())}</h3>", _any(value)]
    if rows:
        parts += ["<h3>All runs</h3>", table(rows, columns)]
    return "".join(parts)


def _flat(value: dict, prefix: str = "") -> dict:
    """A nested mapping with its keys joined: {"3d": {"dofs": 1}} -> {"3d dofs": 1}."""
    out = {}
    for k, v in value.items():
        name = f"{prefix}{k}".replace("_", " ")
        out.update(_flat(v, name + " ") if isinstance(v, dict) else {name: v})
    return out


def _any(value) -> str:
    """A value of bench.json readably: mappings and lists of mappings as tables, never JSON."""
    if isinstance(value, dict) and value and all(isinstance(v, dict) for v in value.values()):
        rows = [{"": k, **_flat(v)} for k, v in value.items()]
        return table(rows, list(dict.fromkeys(c for r in rows for c in r)), digits=4)
    if isinstance(value, dict):
        return table(
            [{"item": k.replace("_", " "), "value": v} for k, v in value.items()], ["item", "value"], digits=4
        )
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        rows = [_flat(v) for v in value]
        return table(rows, list(dict.fromkeys(c for r in rows for c in r)), digits=4)
    if isinstance(value, list):
        return "".join(f"<p>{escape(fmt(v))}</p>" for v in value)
    return f"<p>{escape(fmt(value, 4))}</p>"


def rst(text: str) -> str:
    """A docstring excerpt (reStructuredText) as HTML: ``code`` and :mod:`x` as code, "- " items as a list."""
    items, current = [], None
    for line in text.splitlines():
        if line.lstrip().startswith("- "):
            current = [line.lstrip()[2:]]
            items.append(current)
        elif current is not None and line.strip():
            current.append(line.strip())
        elif line.strip():
            items.append([line.strip()])
    html = []
    for item in items:
        text = escape(" ".join(item))
        text = re.sub(r":\w+:`~?([^`]+)`", r"<code>\1</code>", text)
        text = re.sub(r"``([^`]+)``", r"<code>\1</code>", text)
        html.append(f"<li>{text}</li>")
    return f"<ul class='rules'>{''.join(html)}</ul>"


def _notes(section: dict) -> str:
    if "status" in section and len(section) == 1:
        return f"<p class='warn'>{escape(section['status'])}</p>"
    return "".join(f"<p>{escape(n)}</p>" for n in section.get("notes", []))


def _convergence(s: dict, figures: dict[str, bytes]) -> str:
    if "rows" not in s:
        return "<h2>Convergence</h2>" + _notes(s)
    parts = ["<h2>Convergence</h2>", _notes(s)]
    parts += [
        image(t, figures[k])
        for k, t in (
            ("convergence_error_vs_time.png", "Error against run time"),
            ("convergence_error_vs_elements.png", "Error against elements"),
        )
        if k in figures
    ]
    parts += [
        "<h3>Observed orders</h3>",
        table(
            s["orders"],
            ["scene", "element", "quadrature", "observed_order", "levels", "local_orders", "note"],
        ),
        f"<h3>Time to reach {s['time_to_target'][0]['target']:g}</h3>" if s["time_to_target"] else "",
        table(s["time_to_target"], ["scene", "element", "quadrature", "elements", "runtime_s"]),
        "<h3>P2 and the cubic Hermite: error against run time</h3>",
        table(
            s.get("p2_vs_hermite", []),
            ["scene", "elements", "P2_error", "P2_runtime_s", "Hermite_error", "Hermite_runtime_s"],
        ),
        "<h3>References</h3>",
        table([{"scene": k, "check": v} for k, v in s["references"].items()], ["scene", "check"], digits=8),
        "<h3>All levels</h3>",
        table(
            s["rows"],
            [
                "scene",
                "model",
                "element",
                "quadrature",
                "elements",
                "runtime_s",
                "error",
                "newton_iterations",
                "load_steps",
                "status",
                "reference",
            ],
        ),
    ]
    return "".join(parts)


def _stability(s: dict, figures: dict[str, bytes]) -> str:
    if "rows" not in s:
        return "<h2>Stability</h2>" + _notes(s)
    wrong = s.get("wrong", [])
    bad = s.get("not_acceptable", wrong)
    alarm = (
        f"<p class='bad'>WRONG answers (converged outside tolerance): {escape(', '.join(wrong) or 'none')}. "
        f"Every case without an acceptable outcome: {escape(', '.join(bad))}</p>"
        if bad
        else "<p class='ok'>Every case ok, raised ConvergenceError, or flagged inaccurate.</p>"
    )
    rows = [{**r, "stable / residual": _state(r.get("state_check"))} for r in s["rows"]]
    parts = [
        "<h2>Stability</h2>",
        alarm,
        f"<p>Outcome counts: {escape(fmt(s['outcomes']))}</p>",
        "<p>Every case gets one outcome:</p>" + rst(s["outcome_rules"]) if s.get("outcome_rules") else "",
        table(
            rows,
            [
                "family",
                "case",
                "parameters",
                "converged",
                "newton_iterations",
                "load_steps",
                "runtime_s",
                "error",
                "tolerance",
                "outcome",
                "stable / residual",
                "message",
                "reference",
                "tolerance_basis",
            ],
            classes=_outcome_class,
        ),
    ]
    if "stability_raw_penalty.png" in figures:
        parts.append(
            image(
                "Raw-quaternion penalty: error and Newton iterations against c_u",
                figures["stability_raw_penalty.png"],
            )
        )
    return "".join(parts)


def _state(check: dict | None) -> str:
    if not check:
        return "-"
    if "min_eigenvalue" in check:
        return (
            f"{'stable' if check['stable'] else 'UNSTABLE'} (min eig {check['min_eigenvalue']:.3g}), "
            f"|R| {check['residual']:.2g}"
        )
    return check.get("check", "-")
