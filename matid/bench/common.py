"""Shared helpers of the bench: best-of-n timing, tip errors, the machine record."""

from __future__ import annotations

import os
import platform
import sys
import time
from collections.abc import Callable
from typing import TypeVar

import numpy as np

T = TypeVar("T")

#: Repeats of every timed solve; the best (smallest) run time is reported: the
#: machine is shared, so the minimum is the least disturbed measurement.
REPEATS = 3
#: Solves slower than this are timed once (repeating them says little and costs much).
REPEAT_BELOW_S = 10.0


def best_of(fn: Callable[[], T], repeats: int = REPEATS) -> tuple[T, float, int]:
    """(result, best wall time [s], runs) of ``fn()``; exceptions propagate from the first run."""
    best, result, runs = np.inf, None, 0
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        elapsed = time.perf_counter() - t0
        best, runs = min(best, elapsed), runs + 1
        if elapsed > REPEAT_BELOW_S:
            break
    return result, float(best), runs


def tip_xz(sol, length: float) -> np.ndarray:
    """Tip (x, z)/L of a planar solution in the x-z plane."""
    return np.asarray(sol.position[-1], float)[[0, 2]] / length


def tip_angle(sol) -> float:
    """Tip angle [rad] from e3 towards e_x (planar solutions)."""
    d3 = np.asarray(sol.d3[-1], float)
    return float(np.arctan2(d3[0], d3[2]))


def machine() -> dict:
    """Platform, CPU model, cores and the versions that set the numbers."""
    import scipy
    import skfem

    return {
        "platform": platform.platform(),
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "scikit-fem": getattr(skfem, "__version__", "unknown"),
    }


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def jsonable(value):
    """numpy scalars and arrays to plain Python, recursively (NaN/inf as None: JSON has neither)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        value = float(value)
        return value if np.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value
