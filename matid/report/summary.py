"""The summary page: stiffnesses with their warnings beside them, and the material moduli.

Numbers of one row share a scale and a number of decimals set by the standard error (two
significant figures of it), so a column reads down evenly and no value shows digits its
error does not support. Values far from 1 carry a power of ten in the unit column
(``×10⁻⁵ N m^2``). Parameters that are the same estimate under two names (``E_e`` and
``sls_k1``) share one row. Every warning of the study is numbered once; a parameter's row
names the numbers of the warnings that concern it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from matid.model.results import StudyResult
from matid.model.status import parameter_statuses
from matid.physics.moduli import MODULUS_OF, agreement, modulus
from matid.report.quantities import DISPLAY, fmt

#: Page 1: the status of each value in words, the value and its 95 % interval, the reason.
SUMMARY_COLUMNS = ("specimen", "parameter", "status", "value", "95 % interval", "unit", "why")
SUMMARY_NUMERIC = (False, False, False, True, True, False, False)
#: A fit's own table: the same with the standard error, the points and the method.
FIT_COLUMNS = (
    "parameter",
    "status",
    "value",
    "± standard error (1σ)",
    "rel. error",
    "95 % interval",
    "unit",
    "points",
    "method",
    "warnings",
)
FIT_NUMERIC = (False, False, True, True, True, True, False, True, False, False)
SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


@dataclass(frozen=True)
class Note:
    """One numbered warning of the study."""

    number: int
    where: str  # "T1 E_b", "T1 three-point bend"
    text: str


def scale_of(value: float, stderr: float | None) -> tuple[int, int]:
    """(power of ten factored out, decimals) for the numbers of one row."""
    exponent = math.floor(math.log10(abs(value))) if value else 0
    power = exponent if exponent < -3 or exponent >= 5 else 0
    if stderr and math.isfinite(stderr) and stderr > 0:
        decimals = power - (math.floor(math.log10(stderr)) - 1)  # two significant figures of the error
    else:
        decimals = power - (exponent - 4)  # five significant figures
    return power, min(max(decimals, 0), 9)


def scaled(x: float | None, power: int, decimals: int) -> str:
    if x is None or not math.isfinite(x):
        return "—"
    return f"{x / 10.0**power:.{decimals}f}"


def power_unit(power: int, unit: str) -> str:
    return f"×10{str(power).translate(SUPERSCRIPT)} {unit}" if power else unit


def value_cells(item: Mapping) -> tuple[str, str, str, str, str, str]:
    """value, stderr, relative error, CI low, CI high, unit of one stiffness_json entry
    ("no value" and dashes for a value the data do not determine)."""
    value, stderr, ci = item["value"], item.get("stderr"), item.get("ci95") or (None, None)
    if value is None:
        return ("no value", "—", "—", "—", "—", str(item["unit"]))
    power, decimals = scale_of(value, stderr)
    rel = f"{abs(stderr / value) * 100:.2g} %" if stderr and value else "—"
    shown, error, low, high = (scaled(x, power, decimals) for x in (value, stderr, ci[0], ci[1]))
    return shown, error, rel, low, high, power_unit(power, str(item["unit"]))


def interval_text(low: str, high: str) -> str:
    """ "8.6 to 186.1" (the 95 % interval of a row), "—" when there is none."""
    return "—" if "—" in (low, high) else f"{low} to {high}"


def merged_names(params: Mapping[str, Mapping]) -> list[tuple[str, Mapping]]:
    """Parameters with their entries; one estimate under two names (E_e, sls_k1) once."""
    out: list[tuple[str, Mapping]] = []
    for name, item in params.items():
        twin = next((i for i, (_, seen) in enumerate(out) if _same(seen, item)), None)
        if twin is None:
            out.append((name, item))
        else:
            out[twin] = (f"{out[twin][0]} = {name}", out[twin][1])
    return out


def _same(a: Mapping, b: Mapping) -> bool:
    keys = ("value", "stderr", "unit", "n_points", "method")
    return all(a.get(k) == b.get(k) for k in keys)


def notes_of(result: StudyResult, kind_titles: Mapping[str, str]) -> list[Note]:
    """Every warning of the fits, numbered in report order (estimates first, then the fit's own)."""
    notes: list[Note] = []
    for fit in result.fits:
        for est in fit.estimates:
            notes += [Note(0, f"{fit.specimen} {est.parameter}", w) for w in est.warnings]
        title = kind_titles.get(fit.kind, fit.kind)
        notes += [Note(0, f"{fit.specimen} {title.lower()}", w) for w in fit.warnings]
    return [Note(i + 1, n.where, n.text) for i, n in enumerate(notes)]


def marks_of(
    result: StudyResult, notes: list[Note], kind_titles: Mapping[str, str]
) -> dict[tuple[str, str], list[int]]:
    """(specimen, parameter) -> numbers of its notes (a fit's own notes go to all its parameters)."""
    marks: dict[tuple[str, str], list[int]] = {}
    by_where = {}
    for note in notes:
        by_where.setdefault(note.where, []).append(note.number)
    for fit in result.fits:
        general = by_where.get(f"{fit.specimen} {kind_titles.get(fit.kind, fit.kind).lower()}", [])
        for est in fit.estimates:
            own = by_where.get(f"{fit.specimen} {est.parameter}", [])
            marks[(fit.specimen, est.parameter)] = [*own, *general]
    return marks


def mark_text(numbers: list[int]) -> str:
    return "⚠ " + ", ".join(f"[{n}]" for n in numbers) if numbers else ""


# -- material moduli ----------------------------------------------------------------------------


def moduli_rows(result: StudyResult, units: str) -> list[tuple[str, ...]]:
    """specimen, modulus, from, value, ± stderr, unit, note: E and G from the stiffnesses."""
    unit, factor = DISPLAY["modulus"][units]
    rows = []
    geometry = {s.id: s for s in result.study.specimens}
    statuses = parameter_statuses(result)
    for sid, params in result.estimates().items():
        spec = geometry.get(sid)
        if spec is None:
            continue
        found = {
            source: modulus(source, params[source].value, params[source].stderr, section=spec.section)
            for source in MODULUS_OF
            if source in params and statuses[(sid, source)].printed
        }
        for source, m in found.items():
            note = ""
            if source == "E_b" and "E_e" in found:
                note = agreement_text(found["E_e"], m, spec.section)
            if statuses[(sid, source)].status == "check":
                note = "; ".join(filter(None, (f"from {source}, a value to check", note)))
            section = {"E_e": "A", "E_b": "I", "E_t": "J"}[source]
            value, stderr = m.value * factor, None if m.stderr is None else m.stderr * factor
            power, decimals = scale_of(value, stderr)
            cells = (scaled(value, power, decimals), scaled(stderr, power, decimals), power_unit(power, unit))
            rows.append((sid, m.name, f"{source} / {section}", *cells, note))
    return rows


def moduli_intro(result: StudyResult) -> str:
    """What the moduli are computed from: each kind of section of the study and the dimensions it reads
    (a coupon's width and height, a tube's diameters), taken as exact."""
    shapes = {s.section.shape for s in result.study.specimens}
    words = []
    if shapes & {"tube", "slit"}:
        words.append("the outer and inner diameters of each tube")
    if "rectangle" in shapes:
        words.append("the width and height of each rectangular section")
    sizes = " and ".join(words) or "the section of each specimen"
    return f"E = E_e / A, E = E_b / I and G = E_t / J, with A, I and J from {sizes} in the study, taken as exact."


def _exact(section) -> str:
    return "width and height taken as exact" if section.shape == "rectangle" else "diameters taken as exact"


def agreement_text(from_extension, from_bending, section=None) -> str:
    check = agreement(from_extension, from_bending)
    side = "above" if check.relative_difference > 0 else "below"
    diff = f"E_b / I is {abs(check.relative_difference) * 100:.2g} % {side} E_e / A"
    if check.z is None:
        return diff + " (no standard error to compare with)"
    verdict = "agree" if check.agree else "differ"
    exact = "diameters taken as exact" if section is None else _exact(section)
    return f"{diff}: {fmt(check.z, 2)} combined standard errors, the two {verdict} ({exact})"
