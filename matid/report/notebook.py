"""How a fitted study reads in a notebook: ``result.table()`` printed, ``result`` shown in Jupyter.

``result.table()`` holds the numbers of ``stiffness.csv`` as floats; printed (terminal or
Jupyter) each row shows value and interval bounds with the digits its standard error
supports, in one power of ten per row (``6.492e-05 6.470e-05 6.513e-05``), so value and
bounds can be told apart, and long warnings cut to a line. The HTML view of the result is
page 1 of the report: status in words, value, 95 % interval, unit, the reason in one line.
Nothing is computed here; pandas is imported only when a table is made.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping

import pandas as pd

from matid.io.results import stiffness_json
from matid.model.results import StudyResult
from matid.report.summary import SUMMARY_COLUMNS, interval_text, scale_of, scaled, value_cells
from matid.report.verdict import STATUS_CLASS, reason_line, status_words

#: Columns printed with the row's power of ten and decimals.
SCALED = ("value", "ci95_low", "ci95_high")
#: Longest warnings text printed in a table cell.
WARNINGS_SHOWN = 60


def number(x: float | None, power: int, decimals: int) -> str:
    """``x`` in the row's scale: ``6.492e-05`` (power -5, 3 decimals) or ``119.970``."""
    text = scaled(x, power, decimals)
    return f"{text}e{power:+03d}" if power and text != "—" else text


def readable(frame: pd.DataFrame) -> pd.DataFrame:
    """The table as text: value and bounds in one scale per row, stderr to two figures."""
    out = frame.astype(object).copy()
    for i, row in frame.iterrows():
        value, stderr = row["value"], row["stderr"]
        if value is None or not math.isfinite(value):
            out.loc[i, [*SCALED, "stderr"]] = "—"
            continue
        known = stderr is not None and math.isfinite(stderr)
        power, decimals = scale_of(float(value), float(stderr) if known else None)
        for column in SCALED:
            out.loc[i, column] = number(row[column], power, decimals)
        out.loc[i, "stderr"] = f"{stderr:.2g}" if known else "—"
        text = str(row["warnings"] or "")
        out.loc[i, "warnings"] = text if len(text) <= WARNINGS_SHOWN else text[: WARNINGS_SHOWN - 1] + "…"
    return out


class StiffnessTable(pd.DataFrame):
    """The rows of ``stiffness.csv`` (numbers as float); printed with readable digits.

    Selections and other pandas operations return a plain DataFrame.
    """

    def __repr__(self) -> str:
        return readable(pd.DataFrame(self)).to_string(index=False)

    def _repr_html_(self) -> str:
        table = readable(pd.DataFrame(self)).to_html(index=False, na_rep="—", classes="matid-table")
        return "<style>.matid-table td{white-space:nowrap}</style>" + table


STYLE = (
    "<style>.matid td,.matid th{padding:2px 8px;text-align:left;vertical-align:top}"
    ".matid td.n{text-align:right;white-space:nowrap;font-variant-numeric:tabular-nums}"
    ".matid td.u{white-space:nowrap}"
    ".matid .st-ok{background:#eaf6ec;color:#1f6b2c}"
    ".matid .st-check{background:#fff4d6;color:#8a5a00}"
    ".matid .st-none{background:#fde2e1;color:#8a1c12}"
    ".matid td.st{white-space:nowrap;font-weight:600}</style>"
)


def result_html(result: StudyResult, warnings: list[str]) -> str:
    """Page 1 as a notebook cell: each value's status, value, 95 % interval, unit and why."""
    doc = stiffness_json(result)
    head = "".join(f"<th>{h}</th>" for h in SUMMARY_COLUMNS)
    rows = "".join(
        _row(sid, name, item) for sid, params in doc["specimens"].items() for name, item in params.items()
    )
    notes = "".join(f"<li>{html.escape(w)}</li>" for w in warnings)
    return (
        f'{STYLE}<div class="matid"><h4>{html.escape(result.study.name)}</h4>'
        f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"
        + (f"<p><b>Warnings ({len(warnings)})</b></p><ul>{notes}</ul>" if notes else "<p>No warnings.</p>")
        + "</div>"
    )


def _row(sid: str, name: str, item: Mapping) -> str:
    value, _, _, low, high, unit = value_cells(item)
    words = status_words(str(item.get("status", "ok")))
    cells = [
        f"<td>{html.escape(sid)}</td><td>{html.escape(name)}</td>",
        f'<td class="st st-{STATUS_CLASS.get(words, "")}">{words}</td>',
        f'<td class="n">{value}</td><td class="n">{interval_text(low, high)}</td>',
        f'<td class="u">{html.escape(unit)}</td><td>{html.escape(reason_line(item))}</td>',
    ]
    return "<tr>" + "".join(cells) + "</tr>"
