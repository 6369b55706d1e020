"""The tests of a report block: each record's file, checksum, set-up, units as written, metadata.

Text only, from the study and the inputs read; file and column names as written.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from matid.fits.kinds import BY_NAME
from matid.model.results import InputFile
from matid.model.study import Test
from matid.report.formats import format_value

#: Set-up values shown in a unit of their own: kind -> (factor from SI, unit).
SETUP_UNITS = {"length": (1e3, "mm"), "moment": (1.0, "A m^2")}


@dataclass(frozen=True)
class TestView:
    """One test of a block: its file and how it was set up."""

    file: str
    sha256: str
    details: tuple[str, ...]  # "Set-up: ...", "Note: ...", "Units as written: ...", those given
    exclude: bool
    metadata: tuple[tuple[str, str], ...]
    n_rows: int | None

    @property
    def sha_short(self) -> str:
        return self.sha256[:12] if self.sha256 else "not read"


def record_view(test: Test, inputs: tuple[InputFile, ...]) -> TestView:
    source = _input_of(test, inputs)
    details = (("Set-up", _setup(test)), ("Note", test.note), ("Units as written", _units_written(source)))
    return TestView(
        file=test.file.name,
        sha256=source.sha256 if source else "",
        details=tuple(f"{name}: {text}" for name, text in details if text),
        exclude=test.exclude,
        metadata=tuple((str(k), str(v)) for k, v in source.metadata.items()) if source else (),
        n_rows=source.n_rows if source else None,
    )


def _units_written(source: InputFile | None) -> str:
    """Each column of a record in words with its "[unit]" or "(no unit)"."""
    units = source.units.items() if source else ()
    return ", ".join(f"{str(k).replace('_', ' ')} {f'[{v}]' if str(v) else '(no unit)'}" for k, v in units)


def _input_of(test: Test, inputs: tuple[InputFile, ...]) -> InputFile | None:
    target = _resolved(test.file)
    match = next((f for f in inputs if _resolved(f.path) == target), None)
    if match is None:
        by_name = [f for f in inputs if f.path.name == test.file.name]
        match = by_name[0] if len(by_name) == 1 else None
    return match


def _resolved(path: Path) -> str:
    try:
        return str(Path(path).resolve())
    except OSError:
        return str(path)


def _setup(test: Test) -> str:
    """The set-up of a test in readable units: lengths in mm, the rest in SI."""
    kind = BY_NAME.get(test.kind)
    kinds = {**kind.keys, **kind.optional} if kind else {}
    parts = []
    for key, value in test.params.items():
        shown = SETUP_UNITS.get(kinds.get(key))
        text = f"{value * shown[0]:.4g} {shown[1]}" if shown else format_value(value)
        parts.append(f"{key.replace('_', ' ')} {text}")
    return ", ".join(parts)
