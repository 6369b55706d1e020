"""matid.units: pint's registry with its definitions cache, and without one."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests import ROOT

PROBE = (
    "import matid.units as u; "
    "print(u.ureg('N.m').to('mN*m').magnitude, float(u.ureg('3 Secs').to('s').magnitude))"
)


def _probe(cache_home: Path) -> str:
    env = {**os.environ, "XDG_CACHE_HOME": str(cache_home), "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_registry_builds_and_reuses_its_cache(tmp_path):
    first, second = _probe(tmp_path), _probe(tmp_path)  # writes the cache, then reads it
    assert first == second == "1000.0 3.0"
    assert any((tmp_path / "pint").iterdir())


@pytest.mark.parametrize("damage", ["not a folder", "half-written"])
def test_registry_without_a_usable_cache(tmp_path, damage):
    """A cache folder that cannot be made, or a damaged cache file: the registry is built as before."""
    if damage == "not a folder":
        home = tmp_path / "file"
        home.write_text("")
    else:
        home = tmp_path
        _probe(home)
        for cached in (home / "pint").iterdir():
            cached.write_bytes(cached.read_bytes()[:7])
    assert _probe(home) == "1000.0 3.0"


def _prony_names() -> set[str]:
    """Every parameter the Prony fit can report: those of a fit with the most arms."""
    from matid.fits.extension.prony import MAX_TERMS, PronyFit

    taus = tuple(float(i) for i in range(1, MAX_TERMS + 1))
    return set(PronyFit(MAX_TERMS, 1.0, taus, taus, np.zeros(3), 3, None).values())


@pytest.mark.parametrize("system", ["SI", "cgs"])
def test_every_parameter_has_a_unit_in_every_system(system):
    """Each reported parameter, the Prony time constants included, converts in SI and cgs, and
    the unit label pint reads back gives the SI value again."""
    from matid.model.study import PARAMETER_KINDS
    from matid.units import UNIT_SYSTEMS, from_si, to_si

    assert set(UNIT_SYSTEMS) == {"SI", "cgs"}
    assert _prony_names() <= set(PARAMETER_KINDS)
    for parameter, kind in PARAMETER_KINDS.items():
        value, unit = from_si(2.5, kind, system)
        assert to_si(f"{value!r} {unit}", kind) == pytest.approx(2.5, rel=1e-12), (parameter, unit)
