"""A measurement: one lab test with the columns read from its file, in SI (docs/contract.md section 2).

:func:`matid.io.ingest.read.read_table` reads a test-machine export into a :class:`Table`;
:func:`matid.io.ingest.read.load_measurements` pairs each test of a study with its table.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from matid.model.study import Test
from matid.model.views import PicklesViews


@dataclass(frozen=True, eq=False)
class Table(PicklesViews):
    """The columns of one CSV file, in SI, keyed by canonical name."""

    path: Path
    columns: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    metadata: Mapping[str, str]
    sha256: str
    #: How the file was read, for messages and the report.
    encoding: str = "utf-8"
    delimiter: str = ","
    header_row: int = 1
    #: Preamble lines that are not ``key: value`` metadata, bounded.
    preamble: tuple[str, ...] = ()
    #: The file's header text of each column, for messages.
    written: Mapping[str, str] = field(default_factory=dict)
    #: The 1-based file line of each row (a ``range`` when no line between them was skipped);
    #: None for a table not read from a file.
    lines: Sequence[int] | None = None

    def __post_init__(self) -> None:
        lengths = {len(v) for v in self.columns.values()}
        if len(lengths) > 1:
            raise ValueError(f"{self.path}: columns of unequal length {sorted(lengths)}")
        columns = {name: np.array(values, dtype=float) for name, values in self.columns.items()}
        for array in columns.values():
            array.setflags(write=False)
        object.__setattr__(self, "path", Path(self.path))
        object.__setattr__(self, "columns", MappingProxyType(columns))
        for name in ("units", "metadata", "written"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        object.__setattr__(self, "preamble", tuple(self.preamble))
        if self.lines is not None and len(self.lines) != self.n_rows:
            raise ValueError(f"{self.path}: {len(self.lines)} line numbers for {self.n_rows} rows")

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: str) -> bool:
        return name in self.columns

    @property
    def n_rows(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def line(self, k: int) -> int:
        """The file line (1-based, as an editor shows it) of row ``k`` (0-based, negative from the
        end), for messages; for a table not read from a file, ``k`` counted from the row under the header."""
        k = range(self.n_rows)[k]
        return int(self.lines[k]) if self.lines is not None else self.header_row + 1 + k


@dataclass(frozen=True)
class Measurement:
    """One test of a study with the table read from its file."""

    test: Test
    table: Table

    def in_window(self) -> np.ndarray:
        """Rows inside every range of the test's ``window`` (all rows when it has none).

        A window on a column the table lacks selects nothing; the study loader
        rejects such windows at input, so this does not happen for loaded studies.
        """
        n = self.table.n_rows
        mask = np.ones(n, dtype=bool)
        for name, (low, high) in self.test.window.items():
            values = self.table.columns.get(name)
            if values is None:
                return np.zeros(n, dtype=bool)
            mask &= (values >= low) & (values <= high)
        return mask
