"""The status of every reported value, decided from what its fit reports (docs/contract.md section 10).

``ok`` (use it), ``check`` (a warning applies: read it) or ``not_identifiable``
(the data do not determine it: no value is printed, only the reason and what
to measure instead). :func:`status` reads the estimate and the fit that gave it;
it computes nothing new, so a value's status can always be traced to a figure
the fit already reports (stiffness.json, the report).

The correlation thresholds match the report's "strong: not separately identifiable"
label (:data:`STRONG_R`) and a ridge so flat that the data fix only a combination
of the two parameters (:data:`INSEPARABLE_R`: the marginal interval of either is
then at least 22x its conditional one, 1/sqrt(1 - r^2)).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

from matid.model.results import Estimate, StudyResult, TestFit, each_value

STATUSES = ("ok", "check", "not_identifiable")
#: |r| from which two parameters are read together (status ``check``).
STRONG_R = 0.95
#: |r| from which two parameters cannot be told apart (status ``not_identifiable``).
INSEPARABLE_R = 0.999
#: A fit's own words for a parameter the data do not determine.
_NOT_IDENTIFIABLE = re.compile(r"\bnot (separately )?identifiable\b", re.IGNORECASE)

#: What to measure instead when a parameter is not identifiable, by parameter.
MEASURE_INSTEAD: Mapping[str, str] = {
    "E_e": "extension runs at more rates, or a ramp and a hold longer than the relaxation",
    "E_b": "magnetic bending at more free lengths or larger tip angles",
    "E_t": "a torsion record with a longer linear range",
    "E_s": 'centreline deflection (deflection_at = "centreline") at short spans, or E_s_torsion',
    "E_s_torsion": "E_s from a three-point bend with centreline deflection",
    "viscoelastic": "a ramp and a hold lasting several relaxation times, sampled faster than the "
    "fastest one (or fix the parameter with [[fixed]])",
}


@dataclass(frozen=True)
class Status:
    """A value's status, why (empty for ``ok``), and what to measure instead (``not_identifiable``)."""

    status: str
    reason: str = ""
    instead: str = ""

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status must be one of {', '.join(STATUSES)}, got {self.status!r}")
        if self.status != "ok" and not self.reason:
            raise ValueError(f"a {self.status} status needs its reason")

    @property
    def printed(self) -> bool:
        """Whether the value is printed (not for ``not_identifiable``)."""
        return self.status != "not_identifiable"


def status(est: Estimate, fit: TestFit | None = None) -> Status:
    """The status of ``est`` from ``fit`` (None: a [[fixed]] value). Routes, first that applies:

    ================  ===================  ===============================================
    status            route                what the fit reports
    ================  ===================  ===============================================
    not_identifiable  withheld             ``Estimate.withheld``: the section or the fit
                                           cannot give it (an open tube's E_s_torsion)
    not_identifiable  stated               a warning of the value says it is not
                                           identifiable (SLS k2/eta, E_s by shear share)
    not_identifiable  no interval          a fitted value without standard error and
                                           interval, or with an unbounded one
    not_identifiable  interval holds zero  the 95 % interval reaches 0 or below
    not_identifiable  inseparable          |r| >= INSEPARABLE_R with another parameter
    check             warning              any warning of the value or of its fit
                                           (misfit, drift between spans, bias, ...)
    check             misfit               ``info["lack_of_fit"]["misfit"]`` without a
                                           warning text
    check             correlated           |r| >= STRONG_R with another parameter
    ok                -                    none of the above
    ================  ===================  ===============================================
    """
    warnings = [*(fit.warnings if fit else ()), *est.warnings]
    instead = _instead(est.parameter)
    if est.withheld:
        return Status("not_identifiable", est.withheld, instead)
    stated = next((w for w in est.warnings if _NOT_IDENTIFIABLE.search(w)), None)
    if stated:
        return Status("not_identifiable", stated, instead)
    if est.method != "fixed":
        interval = _interval_problem(est)
        if interval:
            return Status("not_identifiable", interval, instead)
    lines = ("ramp-line", "elastic-line")  # E_e is a line's slope, not sls_k1
    partner, r = _strongest_correlation(est.parameter, fit, sls_k1=est.method not in lines)
    if partner and abs(r) >= INSEPARABLE_R:
        why = f"{est.parameter} and {partner} are inseparable (r = {r:+.4f}): the data fix a combination"
        return Status("not_identifiable", why, instead)
    if warnings:
        return Status("check", warnings[0])
    lof = fit.info.get("lack_of_fit") if fit else None
    if isinstance(lof, Mapping) and lof.get("misfit"):
        return Status("check", "the model does not describe the data within their noise (lack of fit)")
    if partner and abs(r) >= STRONG_R:
        why = f"{est.parameter} is strongly correlated with {partner} (r = {r:+.3f}): read the two together"
        return Status("check", why)
    return Status("ok")


def parameter_statuses(result: StudyResult) -> dict[tuple[str, str], Status]:
    """(specimen, parameter) -> its :func:`status`, for every value of the study."""
    return each_value(result, status)


def status_text(verdict: Status, warnings: list[str]) -> list[str]:
    """The warnings of a value with its status's reason first when they do not already say it."""
    if verdict.status == "not_identifiable":
        instead = f"; measure instead: {verdict.instead}" if verdict.instead else ""
        head = [f"not identifiable: {verdict.reason}{instead}"]
        return head + [w for w in warnings if w != verdict.reason]
    if verdict.status == "check" and verdict.reason not in warnings:
        return [*warnings, verdict.reason]
    return warnings


def _instead(parameter: str) -> str:
    if parameter.startswith(("sls_", "prony_")):
        return MEASURE_INSTEAD["viscoelastic"]
    return MEASURE_INSTEAD.get(parameter, "")


def _interval_problem(est: Estimate) -> str:
    """Why the value's interval does not bound it ("" when it does)."""
    if est.ci95 is None:
        if est.stderr is None or not math.isfinite(est.stderr):
            return "the fit gives no standard error and no interval for it (its covariance is singular)"
        return ""
    low, high = est.ci95
    if not (math.isfinite(low) and math.isfinite(high)):
        return f"its 95 % interval is unbounded ({low:.4g} to {high:.4g})"
    if low <= 0.0:
        return f"its 95 % interval ({low:.4g} to {high:.4g}) reaches zero: the data do not bound it below"
    return ""


def _strongest_correlation(
    parameter: str, fit: TestFit | None, *, sls_k1: bool = True
) -> tuple[str | None, float]:
    """The fitted parameter most correlated with ``parameter`` in ``fit.correlation`` ("a|b" -> r);
    E_e's are sls_k1's unless ``sls_k1`` is false (E_e from a line, not from the SLS)."""
    best: tuple[str | None, float] = (None, 0.0)
    for pair, r in (fit.correlation if fit else {}).items():
        a, _, b = str(pair).partition("|")
        names = {a: b, b: a}
        if parameter in names and math.isfinite(r) and abs(r) > abs(best[1]):
            best = (names[parameter], float(r))
        if sls_k1 and parameter == "E_e" and "sls_k1" in names and math.isfinite(r) and abs(r) > abs(best[1]):
            best = (names["sls_k1"], float(r))  # E_e is k1 of the SLS
    return best


#: One stiffness estimated two ways: the name of the quantity, then its estimates (first: the default).
ESTIMATES_OF = {"k G A (shear stiffness)": ("E_s", "E_s_torsion")}
#: What each estimate is, in the words of the ``use`` reason.
SOURCE_WORDS = {"E_s": "the three-point bend", "E_s_torsion": "torsion and the section's shear coefficient"}


@dataclass(frozen=True)
class Use:
    """Which of a specimen's estimates of one stiffness to use (``parameter``; None: neither), and why."""

    quantity: str
    parameter: str | None
    why: str


def choices(result: StudyResult) -> dict[tuple[str, str], Use]:
    """(specimen, parameter) -> :class:`Use`, for every parameter that is one of two estimates of one
    stiffness of a specimen that has both (E_s from the bend, E_s_torsion from torsion). Decided from
    the statuses only (:func:`status`): the estimate that is ``ok`` when the other is not; of two
    ``ok`` ones (a disagreement the fits saw is a warning, so a ``check``) the narrower relative
    interval; neither when none is ``ok``."""
    statuses = parameter_statuses(result)
    out: dict[tuple[str, str], Use] = {}
    for sid, params in result.estimates().items():
        for quantity, names in ESTIMATES_OF.items():
            if not all(n in params for n in names):
                continue
            choice = choose(quantity, {n: (params[n], statuses[(sid, n)]) for n in names})
            out.update({(sid, n): choice for n in names})
    return out


def choose(quantity: str, found: Mapping[str, tuple[Estimate, Status]]) -> Use:
    ok = [n for n, (_, s) in found.items() if s.status == "ok"]
    others = [n for n in found if n not in ok]
    if not ok:
        why = "; ".join(f"{n} is {_words(found[n][1])}: {_head(found[n][1].reason)}" for n in others)
        return Use(quantity, None, f"neither estimate of {quantity} is ok ({why}); read the warnings")
    if len(ok) == 1:
        name, (other,) = ok[0], others
        why = (f"{name} (from {SOURCE_WORDS[name]}) is ok; {other} (from {SOURCE_WORDS[other]}) is "
               f"{_words(found[other][1])}: {_head(found[other][1].reason)}")  # fmt: skip
        return Use(quantity, name, why)
    rel = {n: _relative_width(found[n][0]) for n in ok}
    name = min(ok, key=lambda n: rel[n])
    widths = ", ".join(f"{n} {100 * rel[n]:.2g} %" for n in ok)
    why = f"both are ok; {name} has the narrower 95 % interval (half-width relative to the value: {widths})"
    return Use(quantity, name, why)


def _words(verdict: Status) -> str:
    return {"check": "to check", "not_identifiable": "not identifiable"}.get(verdict.status, verdict.status)


def _head(reason: str) -> str:
    """The first clause of a reason (up to ": " or "; " outside brackets)."""
    depth = 0
    for i, char in enumerate(reason):
        depth += {"(": 1, ")": -1}.get(char, 0)
        if depth == 0 and reason[i : i + 2] in (": ", "; ") and i > 10:
            return reason[:i]
    return reason


def _relative_width(est: Estimate) -> float:
    if est.ci95 is None or not est.value:
        return math.inf
    return (est.ci95[1] - est.ci95[0]) / 2 / abs(est.value)
