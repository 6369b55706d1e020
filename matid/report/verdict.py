"""How the report says each value's status (decided by :mod:`matid.model.status`, never here).

The status of a value comes from ``stiffness.json`` (``status``, ``status_reason``,
``measure_instead``); this module only puts it in words a lab engineer acts on:
``ok`` -> "use it", ``check`` -> "check it", ``not_identifiable`` -> "not identifiable",
the reason cut to one line (the full text is the numbered warning), and numbers inside
warning texts converted to the report's unit system (a warning is written by the fits
in SI: 19.33 N reads 1.933e6 dyn under ``--units cgs``).
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from matid.report.quantities import DISPLAY

#: The words for each status, as page 1 prints them.
STATUS_WORDS = {"ok": "use it", "check": "check it", "not_identifiable": "not identifiable"}
#: What each status asks of the reader (the legend above the summary table).
STATUS_LEGEND = (
    ("use it", "no warning applies to the value"),
    ("check it", "a warning applies: read it before using the value"),
    ("not identifiable", "the data do not determine the value: none is given, only what to measure instead"),
)
#: Longest reason printed on one line of the summary table.
ONE_LINE = 110

_NUMBER = r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
#: A number (or a range a-b) followed by an SI stiffness unit, in a warning text.
_QUANTITY = re.compile(rf"(?<![\w.])({_NUMBER})(?:(-|–| to )({_NUMBER}))? (N m\^2|N s|N|mm/N)(?![\w/^])")
#: A bracketed remark holding numbers ("(-3.1e-05 to 4.2e-05)", "(r = +0.9993)").
_BRACKETED_NUMBERS = re.compile(r"\s*\([^()]*\d[^()]*\)")
#: unit as the fits write it -> (quantity kind, factor to SI).
_KIND_OF_UNIT = {"N": ("force", 1.0), "N m^2": ("bending_stiffness", 1.0), "N s": ("viscosity", 1.0),
                 "mm/N": ("compliance", 1e-3)}  # fmt: skip


def status_words(status: str) -> str:
    """ "use it", "check it" or "not identifiable" for a status of stiffness.json."""
    return STATUS_WORDS.get(status, status.replace("_", " "))


def one_line(text: str, limit: int = ONE_LINE) -> str:
    """``text`` when short; else its head clause (up to the first ": " or "; " outside brackets),
    cut at a word before ``limit`` characters with "…"."""
    if len(text) <= limit:
        return text
    depth = 0
    for i, char in enumerate(text):
        depth += {"(": 1, ")": -1}.get(char, 0)
        if depth == 0 and char in ":;" and text[i + 1 : i + 2] == " " and i > 10:
            text = text[:i]
            break
    if len(text) <= limit:
        return text
    return text[: text.rfind(" ", 0, limit - 1)] + " …"


def reason_line(item: Mapping) -> str:
    """The one-line reason of a value's status, with what to measure instead (not identifiable)."""
    status = item.get("status", "ok")
    if status == "ok":
        return ""
    reason = str(item.get("status_reason") or "")
    if status == "not_identifiable":  # no number of a value the data do not determine
        reason = _BRACKETED_NUMBERS.sub("", reason)
    reason = one_line(reason)
    instead = item.get("measure_instead") or ""
    return f"{reason}. Measure instead: {instead}" if status == "not_identifiable" and instead else reason


def use_words(name: str, item: Mapping) -> str:
    """Page 1's pointer for one of two estimates of one stiffness (``use`` of stiffness.json): which
    one to use ("" for a parameter estimated once)."""
    use = item.get("use")
    if not isinstance(use, Mapping):
        return ""
    quantity = str(use.get("quantity", "")).split(" (")[0]
    if use.get("parameter") is None:
        return f"neither estimate of {quantity} is ok"
    if use["parameter"] == name:
        return f"the one to use for {quantity}"
    return f"use {use['parameter']} for {quantity} instead"


def use_lines(doc: Mapping) -> tuple[str, ...]:
    """One line per specimen and stiffness estimated twice: the estimate to use, its value, and why."""
    lines = []
    for sid, params in doc["specimens"].items():
        seen = set()
        for item in params.values():
            use = item.get("use")
            if not isinstance(use, Mapping) or use.get("quantity") in seen:
                continue
            seen.add(use.get("quantity"))
            chosen = params.get(use.get("parameter") or "")
            if chosen is None:
                lines.append(f"{sid}, {use['quantity']}: use neither: {use['why']}")
                continue
            low, high = chosen.get("ci95") or (None, None)
            interval = f", 95 % interval {low:.4g} to {high:.4g}" if low is not None and high is not None else ""
            value = f"{chosen['value']:.4g} {chosen['unit']}{interval}"
            lines.append(f"{sid}, {use['quantity']}: use {use['parameter']} = {value}. Why: {use['why']}.")
    return tuple(lines)


def in_units(text: str, units: str) -> str:
    """``text`` with its SI stiffnesses (``19.33 N``, ``46.6-49.2 N``, ``9e-5 N m^2``) and compliances
    (``0.063-0.17 mm/N``) in ``units``."""
    if units == "SI":
        return text

    def convert(match: re.Match) -> str:
        kind, si = _KIND_OF_UNIT[match.group(4)]
        unit, factor = DISPLAY[kind][units]
        factor *= si
        high = "" if match.group(3) is None else f"{match.group(2)}{float(match.group(3)) * factor:.4g}"
        return f"{float(match.group(1)) * factor:.4g}{high} {unit}"

    return _QUANTITY.sub(convert, text)


def summary_intro(units: str) -> str:
    """What page 1's table shows besides the status words: the units, the interval, the marks."""
    return (
        f"Values in {units} units, as in stiffness.json, stiffness.csv and stiffness.xlsx, rounded to two "
        "significant figures of their standard error. 95 % interval: the range that holds the value with "
        "95 % confidence given the fit; it need not be centred on the value (E_s is fitted on a log "
        "scale). ⚠ [n]: warning n below the table, in full."
    )


#: The colour class of each status word (HTML class, PDF cell colour).
STATUS_CLASS = {"use it": "ok", "check it": "check", "not identifiable": "none"}
