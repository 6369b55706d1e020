"""The fit pipeline: study -> measurements -> fits -> StudyResult -> files.

:func:`run_study` reads every file of a study, then fits each specimen and test
kind in the order of :data:`matid.fits.kinds.KINDS` with the fitter registered in
:data:`FITTERS`. Later kinds see what earlier ones gave: the shear fit of a
three-point bend needs E_b and E_e of the same specimen, so extension and
bending run first and every fitter receives ``known``, the estimates obtained so
far (fitted or fixed) for its specimen.

- A :class:`~matid.errors.DataError` anywhere propagates (the input is unusable).
- A fit that cannot be done (:class:`~matid.errors.FitError`, a solver's
  :class:`~matid.errors.ConvergenceError`) becomes a :class:`Failure` and the
  run goes on.
- A kind whose parameters are all fixed in ``[[fixed]]`` is not fitted.

:func:`write_outputs` renders everything in memory first and then publishes the
files as one folder in one atomic step (:mod:`matid.io.publish`), so a failed or
killed run never leaves a half report or a mix of old and new files
(docs/contract.md section 5).
"""

from __future__ import annotations

import json
import platform
import time
from collections.abc import Callable, Mapping, Sequence
from datetime import datetime
from importlib import metadata
from pathlib import Path

import numpy as np

from matid import __version__
from matid.errors import ConvergenceError, DataError, FitError
from matid.fits.kinds import KINDS
from matid.io.ingest.read import load_measurements
from matid.io.publish import publish
from matid.io.results import stiffness_csv, stiffness_json
from matid.io.xlsx import stiffness_xlsx
from matid.model.kind import Kind
from matid.model.measurement import Measurement
from matid.model.results import Estimate, Failure, InputFile, StudyResult, TestFit
from matid.model.study import Specimen, Study

Progress = Callable[[str], None]

#: Numerical failures inside a fit that mean "this fit could not be done", not a bug.
FIT_FAILURES = (FitError, ConvergenceError, np.linalg.LinAlgError, FloatingPointError)

VERSION_PACKAGES = ("numpy", "scipy", "lmfit", "scikit-fem", "pint", "matplotlib")


#: kind name -> its fitter (:data:`matid.model.kind.Fitter`), from the registry; replace an entry to
#: plug in a fit.
FITTERS: dict[str, Callable[..., TestFit]] = {kind.name: kind.fit for kind in KINDS}


def versions() -> dict[str, str]:
    """Versions of matid, its numerical dependencies and Python, for the report."""
    out = {"matid": __version__}
    for name in VERSION_PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    out["python"] = platform.python_version()
    return out


def input_file(m: Measurement) -> InputFile:
    table = m.table
    return InputFile(table.path, table.sha256, table.metadata, table.units, table.n_rows)


def fixed_estimates(study: Study) -> tuple[Estimate, ...]:
    """The ``[[fixed]]`` entries as estimates (method "fixed"); E_e and sls_k1 must agree."""
    for spec in study.specimens:
        e_e, k1 = study.fixed_value(spec.id, "E_e"), study.fixed_value(spec.id, "sls_k1")
        if e_e is not None and k1 is not None and not np.isclose(e_e, k1, rtol=1e-12, atol=0):
            raise DataError(
                f"[[fixed]] of specimen {spec.id}: E_e and sls_k1 are the same parameter "
                f"but differ ({e_e:g} N and {k1:g} N)",
                file=study.source,
            )
    return tuple(
        Estimate(f.parameter, f.value, None, None, 0, "fixed", extra={"specimen": f.specimen})
        for f in study.fixed
    )


def run_study(study: Study, *, progress: Progress | None = None) -> StudyResult:
    """Read and fit every specimen and test kind of ``study``; see the module docstring."""
    say = progress or (lambda _: None)
    started = datetime.now().astimezone()
    clock = time.perf_counter()
    fixed = fixed_estimates(study)
    say(f"reading {len(study.tests)} files of study '{study.name}'")
    measurements = load_measurements(study)
    fits: list[TestFit] = []
    failures: list[Failure] = []
    pending: list[Failure] = []
    for spec in study.specimens:
        known = {e.parameter: e for e in fixed if e.extra.get("specimen") == spec.id}
        for kind in KINDS:
            outcome = _fit_kind(study, measurements, spec, kind, known, say)
            if isinstance(outcome, TestFit):
                fits.append(outcome)
                known.update({e.parameter: e for e in outcome.estimates})
            elif outcome is not None:
                failed, item = outcome
                (failures if failed else pending).append(item)
    return StudyResult(
        study=study,
        inputs=tuple(input_file(m) for m in measurements),
        fits=tuple(fits),
        failures=tuple(failures),
        pending=tuple(pending),
        fixed=fixed,
        started=started.isoformat(timespec="seconds"),
        runtime_s=time.perf_counter() - clock,
        versions=versions(),
    )


def _fit_kind(
    study: Study,
    measurements: Sequence[Measurement],
    spec: Specimen,
    kind: Kind,
    known: Mapping[str, Estimate],
    say: Progress,
) -> TestFit | tuple[bool, Failure] | None:
    """One kind on one specimen: a TestFit, (failed?, Failure) or None (nothing to do)."""
    name = kind.name
    all_tests = study.tests_of(name, spec.id, included=False)
    if not all_tests:
        return None
    fixed = {f.parameter: f.value for f in study.fixed if f.specimen == spec.id}
    fixed_names = set(fixed) | ({"sls_k1"} if "E_e" in fixed else set())
    if all(p in fixed_names for p in kind.gives):
        say(f"{name} {spec.id}: {', '.join(kind.gives)} fixed in study.toml, not fitted")
        return None
    wanted = {id(t) for t in all_tests if not t.exclude}
    mine = [m for m in measurements if id(m.test) in wanted]
    if not mine:
        reason = f"all {len(all_tests)} of its tests are excluded in study.toml"
        return False, Failure(name, spec.id, reason)
    files = ", ".join(m.test.file.name for m in mine)
    say(f"fitting {name} {spec.id} ({len(mine)} test{'s' * (len(mine) > 1)}: {files})")
    clock = time.perf_counter()
    try:
        fit = FITTERS[name](mine, specimen=spec, fixed=fixed, known=dict(known))
    except FIT_FAILURES as exc:
        say(f"{name} {spec.id}: FAILED: {exc}")
        return True, Failure(name, spec.id, str(exc) or type(exc).__name__)
    say(f"{name} {spec.id}: done in {time.perf_counter() - clock:.1f} s")
    return fit


def render_report(result: StudyResult, *, units: str = "SI") -> dict[str, bytes]:
    """:func:`matid.report.render_report`, imported on first use (fitting alone does not need
    matplotlib and reportlab)."""
    from matid.report import render_report as render

    return render(result, units=units)


def output_files(result: StudyResult, *, units: str = "SI") -> dict[str, bytes | str]:
    """Every output file of docs/contract.md section 4, rendered in memory: name -> content."""
    return {
        **render_report(result, units=units),
        "stiffness.csv": stiffness_csv(result, units),
        "stiffness.json": json.dumps(stiffness_json(result, units), indent=2) + "\n",
        "stiffness.xlsx": stiffness_xlsx(result, units),  # docs/contract.md section 7
    }


def write_outputs(result: StudyResult, out: Path, *, units: str = "SI") -> list[Path]:
    """Render every output file (:func:`output_files`) in memory, then publish them as the folder
    ``out`` whole; returns the paths.

    The old contents of ``out`` stay whole until the new folder replaces them in
    one step (:func:`matid.io.publish.publish`); a write error raises OutputError.
    """
    return publish(output_files(result, units=units), Path(out))
