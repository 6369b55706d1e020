"""What a test kind declares: the one object the reader, the pipeline, the CLI and the report need.

Each kind's fits module declares its :class:`Kind` (``KIND``) and :mod:`matid.fits.kinds`
lists them, one line each, in fit and report order. Nothing else names a kind: the study
loader reads its keys, ingest its columns, the pipeline its fitter and the parameters it
gives, the report its section title, parameters and drawings.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from matid.model.results import TestFit
from matid.model.study import PARAMETER_KINDS

#: fit(measurements, *, specimen, fixed, known) -> TestFit: all included measurements of the kind on
#: one specimen; ``fixed`` holds the study's fixed values for it (parameter -> SI value), ``known``
#: the estimates already obtained for it (earlier kinds, then fixed entries).
Fitter = Callable[..., TestFit]


@dataclass(frozen=True)
class Kind:
    """One test kind (docs/contract.md sections 1, 2 and 7)."""

    #: The ``kind`` of a ``[[test]]`` in study.toml.
    name: str
    #: The report section's title.
    title: str
    #: The data columns its fit uses -> their quantity kinds; each needs a known unit.
    columns: Mapping[str, str]
    #: Groups of alternative columns: a file needs at least one column of each group.
    required: tuple[tuple[str, ...], ...]
    #: The quantities a ``[[test]]`` of the kind must give -> their quantity kinds (positive, in SI).
    keys: Mapping[str, str]
    #: The parameters its fit gives, in report order; the first is the one the kind is for.
    parameters: tuple[str, ...]
    #: The fitter (see :data:`Fitter`).
    fit: Fitter = field(compare=False)
    #: Quantities a ``[[test]]`` may give -> their quantity kinds.
    optional: Mapping[str, str] = field(default_factory=dict)
    #: Other (text) keys of its ``[[test]]``.
    options: tuple[str, ...] = ()
    #: Columns that must be positive (tension, compression, nose travel counted positive).
    positive: tuple[str, ...] = ()
    #: The fit is skipped when every one of these is fixed (default: :attr:`parameters`).
    gives: tuple[str, ...] = ()
    #: The report's drawings of its fits, by name (:data:`matid.report.content.DRAWINGS`).
    drawings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        for name in ("columns", "keys", "optional"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        unknown = [p for p in (*self.parameters, *self.gives) if p not in PARAMETER_KINDS]
        if unknown:
            raise ValueError(f"kind {self.name}: unknown parameter {unknown[0]!r}")
        if not self.gives:
            object.__setattr__(self, "gives", self.parameters)
        missing = [c for c in (*sum(self.required, ()), *self.positive) if c not in self.columns]
        if missing:
            raise ValueError(f"kind {self.name}: column {missing[0]!r} is not one of its columns")

    @property
    def test_keys(self) -> tuple[str, ...]:
        """The keys of its ``[[test]]`` beyond those every test may carry."""
        return (*self.keys, *self.optional, *self.options)
