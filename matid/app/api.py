"""The Python API for a notebook or a script: :func:`fit` and :func:`load_study`.

docs/contract.md section 8::

    import matid
    result = matid.fit("data/example")   # a study folder or its study.toml
    result.table()                       # pandas DataFrame, one row per specimen and parameter
    result.write("reports/x")            # the same files as `matid fit`
    result                               # in a notebook: the summary table and warnings as HTML

The surface of :class:`FitResult` is plain data: ``ok``, ``warnings``, ``failures``
are attributes (lists of str, bool), not methods. The fitted objects behind it
stay available as ``result.study_result`` (a :class:`matid.io.results.StudyResult`).
"""

from __future__ import annotations

import html
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # heavy imports only when used
    import pandas as pd

    from matid.io.results import StudyResult
    from matid.io.study import Study


def load_study(path: str | Path) -> Study:
    """Read and validate a study (a folder holding ``study.toml``, or the toml); DataError if unusable."""
    from matid.io.study import load_study as _load

    return _load(path)


def fit(study: str | Path | Study, *, progress: Callable[[str], None] | None = None) -> FitResult:
    """Fit every specimen and test kind of a study (a path or a loaded :class:`~matid.io.study.Study`).

    Raises :class:`~matid.errors.DataError` for unusable input; a fit that cannot be
    done is not an exception but an entry of ``failures`` (and ``ok`` is False), as
    in ``matid fit`` (docs/contract.md section 5). ``progress`` receives one line
    per step, e.g. ``print``.
    """
    from matid.app.pipeline import run_study
    from matid.io.study import Study

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
        (``ok``, ``check``, ``not_identifiable``: no value, the reason in warnings; contract section 10)."""
        import pandas as pd

        from matid.io.results import CSV_COLUMNS, table_rows

        return pd.DataFrame(table_rows(self.study_result, units), columns=CSV_COLUMNS)

    def write(self, out: str | Path, *, units: str = "SI") -> list[Path]:
        """Write the files of ``matid fit --out OUT`` (docs/contract.md sections 4, 7); returns the paths."""
        from matid.app.pipeline import write_outputs

        return write_outputs(self.study_result, Path(out), units=units)

    def __repr__(self) -> str:
        status = "ok" if self.ok else f"{len(self.failures)} failed"
        n = len(self.table())
        return f"<matid.FitResult {self.name!r}: {n} values, {status}, {len(self.warnings)} warnings>"

    def _repr_html_(self) -> str:
        """The summary table (value ± stderr, 95 % interval, unit, method) and the warnings."""
        rows = self.table()
        head = "".join(f"<th>{h}</th>" for h in ("specimen", "parameter", "value ± stderr", "95 % interval",
                                                 "unit", "method", "warnings", "status"))  # fmt: skip
        body = "".join(_html_row(r) for r in rows.to_dict("records"))
        warnings = "".join(f"<li>{html.escape(w)}</li>" for w in self.warnings)
        return (
            f"<div><h4>{html.escape(self.name)}</h4>"
            f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
            + (f"<p><b>Warnings ({len(self.warnings)})</b></p><ul>{warnings}</ul>" if warnings
               else "<p>No warnings.</p>")
            + "</div>"
        )  # fmt: skip


def _html_row(row: dict) -> str:
    def num(x) -> str:
        return "" if x is None or x != x else f"{x:.4g}"

    value = num(row["value"]) + ("" if row["stderr"] is None or row["stderr"] != row["stderr"]
                                 else f" ± {row['stderr']:.2g}")  # fmt: skip
    interval = "" if not num(row["ci95_low"]) else f"[{num(row['ci95_low'])}, {num(row['ci95_high'])}]"
    cells = (row["specimen"], row["parameter"], value, interval, row["unit"], row["method"], row["warnings"],
             row["status"])  # fmt: skip
    return "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in cells) + "</tr>"
