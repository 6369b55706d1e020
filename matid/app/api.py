"""The Python API for a notebook or a script: :func:`fit`; ``matid.load_study`` is matid.io.study's.

docs/contract.md section 8::

    import matid
    result = matid.fit("data/example")   # a study folder or its study.toml
    result.table()                       # pandas DataFrame, one row per specimen and parameter
    result.write("reports/x")            # the same files as `matid fit`
    result                               # in a notebook: the summary table and warnings as HTML

The surface of :class:`FitResult` is plain data: ``ok``, ``warnings``, ``failures``
are attributes (lists of str, bool), not methods. The fitted objects behind it
stay available as ``result.study_result`` (a :class:`matid.model.results.StudyResult`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # heavy imports only when used
    import pandas as pd
    from matplotlib.figure import Figure

    from matid.model.results import StudyResult
    from matid.model.study import Study


def fit(study: str | Path | Study, *, progress: Callable[[str], None] | None = None) -> FitResult:
    """Fit every specimen and test kind of a study (a path or a loaded :class:`~matid.model.study.Study`).

    Raises :class:`~matid.errors.DataError` for unusable input; a fit that cannot be
    done is not an exception but an entry of ``failures`` (and ``ok`` is False), as
    in ``matid fit`` (docs/contract.md section 5). ``progress`` receives one line
    per step, e.g. ``print``.
    """
    from matid.app.pipeline import run_study
    from matid.io.study import load_study
    from matid.model.study import Study

    loaded = study if isinstance(study, Study) else load_study(study)
    return FitResult(run_study(loaded, progress=progress))


@dataclass(frozen=True, repr=False)
class FitResult:
    """A fitted study: its table, its warnings, and the files ``matid fit`` writes."""

    study_result: StudyResult
    #: Every warning of the study, failures first, prefixed by specimen and parameter or test kind.
    warnings: list[str] = field(init=False)
    #: One line per fit that could not be done: "<specimen> <kind>: <reason>".
    failures: list[str] = field(init=False)

    def __post_init__(self) -> None:
        res = self.study_result
        object.__setattr__(self, "warnings", [str(w) for w in res.warnings()])
        object.__setattr__(self, "failures", [f"{f.specimen} {f.kind}: {f.reason}" for f in res.failures])

    @property
    def name(self) -> str:
        """The study's name (``[study] name`` in study.toml)."""
        return self.study_result.study.name

    @property
    def ok(self) -> bool:
        """True when every fit was done (exit code 0 of ``matid fit``)."""
        return not self.failures

    def table(self, units: str = "SI") -> pd.DataFrame:
        """One row per specimen and parameter: the columns of ``stiffness.csv``, warnings then status
        (``ok``, ``check``, ``not_identifiable``: no value, the reason in warnings; contract section 10).
        ``units``: "SI" or "cgs" (another name is a ValueError naming the choices).

        The numbers are floats; printed, each row shows value and bounds with the digits its
        standard error supports (:class:`matid.report.notebook.StiffnessTable`)."""
        from matid.io.results import CSV_COLUMNS, table_rows
        from matid.report.notebook import StiffnessTable
        from matid.units import unit_system

        return StiffnessTable(table_rows(self.study_result, unit_system(units)), columns=CSV_COLUMNS)

    def plot(self, parameter: str, specimen: str, units: str = "SI") -> Figure:
        """The report's figure of the fit that gives ``parameter`` of ``specimen`` (data, model,
        residuals) as a matplotlib Figure; DataError naming the fits there are if none gives it."""
        from matid.errors import DataError
        from matid.report.figures import fit_figure
        from matid.units import unit_system

        unit_system(units)
        fits = self.study_result.fits
        names = {parameter, {"sls_k1": "E_e", "E_e": "sls_k1"}.get(parameter, parameter)}
        match = next(
            (f for f in fits if f.specimen == specimen and names & {e.parameter for e in f.estimates}), None
        )
        if match is None:
            there = sorted({f"{f.specimen} {e.parameter}" for f in fits for e in f.estimates})
            raise DataError(f"no fit gives {parameter} of specimen {specimen}; fitted: {', '.join(there)}")
        return fit_figure(match, units)

    def write(self, out: str | Path, *, units: str = "SI") -> list[Path]:
        """Write the files of ``matid fit --out OUT`` (docs/contract.md sections 4, 7); returns the paths."""
        from matid.app.pipeline import write_outputs
        from matid.units import unit_system

        return write_outputs(self.study_result, Path(out), units=unit_system(units))

    def __repr__(self) -> str:
        status = "ok" if self.ok else f"{len(self.failures)} failed"
        n = len(self.table())
        return f"<matid.FitResult {self.name!r}: {n} values, {status}, {len(self.warnings)} warnings>"

    def _repr_html_(self) -> str:
        """Page 1 of the report: each value's status, value, 95 % interval, unit, why; the warnings."""
        from matid.report.notebook import result_html

        return result_html(self.study_result, self.warnings)
