"""matid.units: pint's registry with its definitions cache, and without one."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

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
