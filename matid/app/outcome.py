"""What a run of one study ends with: its exit code, what ``matid`` says of an error, and the
outcome a batch gathers (docs/contract.md section 5).

Exit codes: 0 done; 1 some fits could not be done (or another MatidError); 2 unusable input
(DataError); 3 a bug; 4 the outputs could not be written (OutputError).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from matid.errors import DataError, MatidError

#: The files a batch writes into its --out beside the study folders (no study folder may take one).
SUMMARY_NAMES = ("summary.csv", "summary.xlsx", "summary.html")


def exit_code(exc: Exception) -> int:
    """The exit code of an error (see the module docstring): 2, 4, 1 for another MatidError, 3 for a bug."""
    from matid.io.publish import OutputError

    if isinstance(exc, DataError):
        return 2
    if isinstance(exc, OutputError):
        return 4
    return 1 if isinstance(exc, MatidError) else 3


def error_message(exc: Exception) -> str:
    """What ``matid`` says of an error: its message, or for a bug its type and message."""
    return str(exc) if isinstance(exc, MatidError) else f"internal error: {type(exc).__name__}: {exc}"


def study_code(result, strict: bool = False) -> int:
    """The exit code of a fitted study: 0 if every fit was done and, with ``strict``, no value has a
    warning or a status other than ``ok`` (a not-identifiable value may have no warning); else 1.
    ``result`` is a :class:`matid.model.results.StudyResult` (imported on use: the CLI stays light)."""
    from matid.model.status import parameter_statuses

    if not result.ok:
        return 1
    if strict and (result.warnings() or any(s.status != "ok" for s in parameter_statuses(result).values())):
        return 1
    return 0


@dataclass(frozen=True)
class StudyOutcome:
    """What one study's task hands back (picklable, plain data)."""

    source: str  # the path as given
    name: str  # the study folder name: DIR/<name>/
    code: int  # exit code of this study alone (docs/contract.md section 5)
    rows: list[dict] = field(default_factory=list)  # stiffness table rows, as stiffness.csv
    warnings: list[str] = field(default_factory=list)
    error: str = ""  # why the study stopped (code 2, 3, or a MatidError)
    failures: list[str] = field(default_factory=list)  # fits that could not be done (code 1)
    paths: list[str] = field(default_factory=list)
    runtime_s: float = 0.0
