"""What a fit returns: estimates, the series it plots, test fits, a study's result (contract sections 4, 7).

Fits produce :class:`TestFit` objects; the pipeline gathers them in a
:class:`StudyResult`. Values are SI; :mod:`matid.io.results` writes them out
(``stiffness.csv``, ``stiffness.json``) and :mod:`matid.report` presents them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import numpy as np

from matid.model.study import PARAMETER_KINDS, Study, Test
from matid.model.views import PicklesViews

T = TypeVar("T")

#: Order of parameters in tables.
PARAMETER_ORDER = ["E_b", "E_t", "E_s", "E_s_torsion", "E_e", "sls_k1", "sls_k2", "sls_eta"]
PARAMETER_ORDER += ["prony_k0", "prony_k1", "prony_tau1", "prony_k2", "prony_tau2", "prony_k3", "prony_tau3"]


@dataclass(frozen=True)
class Estimate:
    """One fitted (or fixed) parameter of one specimen, in SI."""

    parameter: str
    value: float
    stderr: float | None
    ci95: tuple[float, float] | None
    n_points: int
    method: str  # "sls", "prony", "linear", "ramp-line", "elastic-line", "cosserat-fe", "shear-coefficient",
    # "fixed"
    warnings: tuple[str, ...] = ()
    extra: Mapping[str, object] = field(default_factory=dict, hash=False)
    #: Why no value can be given, and what to measure instead ("": a value is given). A withheld
    #: estimate's value is NaN and never printed (status ``not_identifiable``, contract section 10).
    withheld: str = ""

    def __post_init__(self) -> None:
        if self.parameter not in PARAMETER_KINDS:
            raise ValueError(f"unknown parameter {self.parameter!r}")
        if not math.isfinite(self.value) and not self.withheld:
            raise ValueError(f"{self.parameter}: value is not finite ({self.value})")

    @property
    def kind(self) -> str:
        return PARAMETER_KINDS[self.parameter]


@dataclass(frozen=True)
class Series:
    """One data set of a fit, for plots: measured y against x, the model, the points used."""

    label: str
    x: np.ndarray
    y: np.ndarray
    y_fit: np.ndarray | None = None
    used: np.ndarray | None = None  # bool mask of the points in the fit (None: all)

    @property
    def residual(self) -> np.ndarray | None:
        return None if self.y_fit is None else self.y - self.y_fit


@dataclass(frozen=True)
class TestFit:
    """The fit of all tests of one kind on one specimen.

    Axis labels are written ``"name [SI unit]"`` (the report converts that unit
    for ``--units cgs``). ``info`` holds fit figures for the report as text, and
    under ``info["figures"]`` extra figures as (title, PNG bytes) pairs.
    """

    __test__ = False  # not a pytest class

    kind: str
    specimen: str
    tests: tuple[Test, ...]
    estimates: tuple[Estimate, ...]
    series: tuple[Series, ...]
    x_label: str  # axis labels with SI units, e.g. "tip angle / free length [rad/m]"
    y_label: str
    correlation: Mapping[str, float] = field(default_factory=dict, hash=False)  # "a|b" -> r
    warnings: tuple[str, ...] = ()
    info: Mapping[str, object] = field(default_factory=dict, hash=False)  # fit window, noise, ...

    def estimate(self, parameter: str) -> Estimate | None:
        return next((e for e in self.estimates if e.parameter == parameter), None)


@dataclass(frozen=True)
class Failure:
    """A fit that could not be done, with the reason shown to the user."""

    kind: str
    specimen: str
    reason: str


@dataclass(frozen=True)
class InputFile(PicklesViews):
    path: Path
    sha256: str
    metadata: Mapping[str, str] = field(default_factory=dict, hash=False)
    units: Mapping[str, str] = field(default_factory=dict, hash=False)  # column -> unit as written
    n_rows: int = 0


@dataclass(frozen=True)
class StudyResult:
    study: Study
    inputs: tuple[InputFile, ...]
    fits: tuple[TestFit, ...]
    failures: tuple[Failure, ...] = ()
    pending: tuple[Failure, ...] = ()  # tests present but not fitted by design (not an error)
    fixed: tuple[Estimate, ...] = ()  # [[fixed]] entries as estimates (method "fixed")
    started: str = ""
    runtime_s: float = 0.0
    versions: Mapping[str, str] = field(default_factory=dict, hash=False)

    @property
    def ok(self) -> bool:
        return not self.failures

    def warnings(self) -> list[str]:
        """Every warning of the study, prefixed by where it arose."""
        return [f"{specimen} {concerns}: {text}" for specimen, concerns, text in self.warning_list()]

    def warning_list(self, failed: str = "") -> list[tuple[str, str, str]]:
        """Every warning as (specimen, the test kind or parameter it concerns, text): failures
        first (their reason after ``failed``), then tests not fitted, fits, values."""
        out = [(f.specimen, f.kind, failed + f.reason) for f in self.failures]
        out += [(p.specimen, p.kind, f"not fitted: {p.reason}") for p in self.pending]
        for fit in self.fits:
            out += [(fit.specimen, fit.kind, w) for w in fit.warnings]
            for est in fit.estimates:
                out += [(fit.specimen, est.parameter, w) for w in est.warnings]
        return out

    def estimates(self) -> dict[str, dict[str, Estimate]]:
        """specimen -> parameter -> estimate; fixed entries stand where no fit gives the parameter."""
        table: dict[str, dict[str, Estimate]] = {s.id: {} for s in self.study.specimens}
        for (sid, name), est in each_value(self, lambda est, fit: est).items():
            table[sid][name] = est
        return {
            k: dict(sorted(v.items(), key=lambda kv: PARAMETER_ORDER.index(kv[0]))) for k, v in table.items()
        }


def each_value(result: StudyResult, of: Callable[[Estimate, TestFit | None], T]) -> dict[tuple[str, str], T]:
    """(specimen, parameter) -> ``of(estimate, fit that gave it)`` for every value of the study;
    a [[fixed]] value (fit None) only where no fit gives the parameter."""
    out: dict[tuple[str, str], T] = {}
    for fit in result.fits:
        for est in fit.estimates:
            out[(fit.specimen, est.parameter)] = of(est, fit)
    for est in result.fixed:
        out.setdefault((str(est.extra.get("specimen")), est.parameter), of(est, None))
    return out
