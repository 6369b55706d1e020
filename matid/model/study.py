"""What a study is: specimens, lab tests and fixed stiffnesses, in SI (docs/contract.md sections 1, 3, 7, 10).

:func:`matid.io.study.load_study` reads them from ``study.toml`` and checks every input
there (a DataError naming the file, the entry and the key); the checks here are the
records' own invariants.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

from matid.model.views import PicklesViews
from matid.physics.moduli import Section

#: Where a three-point bend's deflection is measured: at the nose (crosshead) or the centreline.
DEFLECTION_AT = ("nose", "centreline")

#: Quantity kind of every parameter matid reports (for unit conversion); ``prony_*``: the n-term Prony
#: (generalised Maxwell) solid of matid.fits.extension.prony.
PARAMETER_KINDS: dict[str, str] = {
    "E_e": "force",
    "sls_k1": "force",
    "sls_k2": "force",
    "sls_eta": "viscosity",
    "E_b": "bending_stiffness",
    "E_t": "bending_stiffness",
    "E_s": "force",
    "E_s_torsion": "force",
    **{f"prony_k{i}": "force" for i in range(4)},
    **{f"prony_tau{i}": "time" for i in range(1, 4)},
}
#: Parameters a study may fix, with their quantity kinds (docs/contract.md section 3).
PARAMETERS = {p: PARAMETER_KINDS[p] for p in ("E_e", "E_b", "E_t", "E_s", "sls_k1", "sls_k2", "sls_eta")}


@dataclass(frozen=True)
class Specimen:
    """A specimen and its section (docs/contract.md section 10); lengths in m.

    A tube gives ``outer_diameter`` and ``inner_diameter`` (0: a rod), an open
    tube also ``slit = True``; a rectangular coupon gives ``width`` and ``height``
    (height along the bending load) and no diameters.
    """

    id: str
    outer_diameter: float = 0.0
    inner_diameter: float = 0.0
    #: Poisson's ratio for the shear coefficient of E_s from torsion (None: stated default range).
    poisson_ratio: float | None = None
    width: float = 0.0
    height: float = 0.0
    slit: bool = False

    def __post_init__(self) -> None:
        if not self.id:
            raise ValueError("specimen id must not be empty")
        rectangle = bool(self.width or self.height)
        if not rectangle and not (self.outer_diameter > self.inner_diameter >= 0.0):
            raise ValueError(
                f"specimen {self.id}: need outer_diameter > inner_diameter >= 0, got "
                f"{self.outer_diameter} m and {self.inner_diameter} m"
            )
        if rectangle and self.slit:
            raise ValueError(f"specimen {self.id}: slit = true is a tube's key, not a rectangle's")
        try:
            self.section  # noqa: B018 - checks the section's own invariants
        except ValueError as exc:
            raise ValueError(f"specimen {self.id}: {exc}") from None

    @property
    def section(self) -> Section:
        """The cross-section the moduli and E_s_torsion use."""
        if self.width or self.height:
            return Section("rectangle", width=self.width, height=self.height)
        return Section("slit" if self.slit else "tube", self.outer_diameter, self.inner_diameter)


@dataclass(frozen=True)
class Test(PicklesViews):
    """One lab test: a CSV file of one kind on one specimen, with its set-up in SI."""

    __test__ = False  # not a pytest class

    kind: str
    specimen: str
    file: Path
    params: Mapping[str, float] = field(default_factory=dict, hash=False)
    exclude: bool = False
    note: str = ""
    index: int = 0  #: position in study.toml, for messages
    #: matid column name -> (low, high) in SI: only rows inside every range enter the fit
    #: (docs/contract.md section 7, ``window``); rows outside are shown, marked.
    window: Mapping[str, tuple[float, float]] = field(default_factory=dict, hash=False)
    #: three_point_bend: where deflection is measured, "nose" (crosshead) or "centreline".
    deflection_at: str = "nose"
    #: matid column name -> the file's header text, or its column number, 1 = the first
    #: (section 7 ``columns``).
    columns: Mapping[str, str | int] = field(default_factory=dict, hash=False)
    #: matid column name -> unit text overriding the file's (section 7 ``units``).
    units: Mapping[str, str] = field(default_factory=dict, hash=False)
    #: matid columns whose sign is flipped on reading (section 7 ``negate``).
    negate: tuple[str, ...] = ()
    #: Text encoding of the file; None: detected.
    encoding: str | None = None

    def __post_init__(self) -> None:
        for name in ("params", "window", "columns", "units"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        object.__setattr__(self, "negate", tuple(self.negate))
        if self.deflection_at not in DEFLECTION_AT:
            raise ValueError(f"deflection_at must be 'nose' or 'centreline', got {self.deflection_at!r}")


@dataclass(frozen=True)
class Fixed:
    """A known stiffness used instead of a fit."""

    specimen: str
    parameter: str
    value: float

    def __post_init__(self) -> None:
        if self.parameter not in PARAMETERS:
            raise ValueError(f"unknown parameter {self.parameter!r} (one of {', '.join(PARAMETERS)})")
        if not (math.isfinite(self.value) and self.value > 0):
            raise ValueError(f"fixed {self.parameter} must be positive and finite")


@dataclass(frozen=True)
class Study:
    name: str
    source: Path
    specimens: tuple[Specimen, ...]
    tests: tuple[Test, ...]
    fixed: tuple[Fixed, ...] = ()
    temperature: str = ""

    def specimen(self, specimen_id: str) -> Specimen:
        for spec in self.specimens:
            if spec.id == specimen_id:
                return spec
        raise KeyError(specimen_id)

    def fixed_value(self, specimen_id: str, parameter: str) -> float | None:
        return next(
            (f.value for f in self.fixed if (f.specimen, f.parameter) == (specimen_id, parameter)), None
        )

    def tests_of(self, kind: str, specimen_id: str, *, included: bool = True) -> list[Test]:
        return [
            t
            for t in self.tests
            if t.kind == kind and t.specimen == specimen_id and not (included and t.exclude)
        ]
