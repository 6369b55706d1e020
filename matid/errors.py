"""The small exception hierarchy of matid.

MatidError is the common base. DataError means the input cannot be used
(CLI exit 2); ConvergenceError means a solver could not reach equilibrium
(it carries the last load factor reached); FitError means a fit could not be
completed (the run goes on, the parameter is reported as missing).
"""

from __future__ import annotations


class MatidError(Exception):
    """Base of every error matid raises on purpose."""


class DataError(MatidError):
    """Unusable input: names the file and, where it applies, the row or column."""

    def __init__(
        self, message: str, *, file: object | None = None, row: int | None = None, column: str | None = None
    ) -> None:
        self.file = None if file is None else str(file)
        self.row = row
        self.column = column
        self.detail = message
        parts = (
            self.file,
            None if row is None else f"row {row}",
            None if column is None else f"column '{column}'",
        )
        where = [part for part in parts if part is not None]
        super().__init__(f"{', '.join(where)}: {message}" if where else message)


class ConvergenceError(MatidError):
    """A solver could not converge; never returns a non-converged state instead."""

    def __init__(self, message: str, *, load_factor: float | None = None, **info: object) -> None:
        self.load_factor = load_factor
        self.info = info
        if load_factor is not None:
            message = f"{message} (last converged load factor {load_factor:.6g})"
        super().__init__(message)


class FitError(MatidError):
    """A fit could not be completed; the rest of the study still runs."""


class SlipOffError(ConvergenceError):
    """A three-point-bend tube end passed its support: the scene cannot go on."""

    def __init__(self, message: str, *, deflection: float) -> None:
        self.deflection = deflection
        super().__init__(f"{message} at nose deflection {deflection:.6g} m")
