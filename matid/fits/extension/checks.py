"""Identifiability of the SLS parameters and the cautions on E_e (:mod:`matid.fits.extension.fit`).

k2 and eta can be told apart only when tau = eta / k2 lies inside the observed time window
of some run (no shorter than ``_MIN_TAU_SAMPLES`` sample intervals, no longer than
``_MAX_TAU_RUNS`` x the longest run), they are not too correlated and their standard errors
are finite and small; otherwise the fit says why instead of printing a bare number.

The reasons name the thresholds, not the fitted tau or standard errors: where k2 and eta are
not identifiable the fit ends anywhere along a flat valley, so those digits are not set by
the data (one force reading moved by one ulp moved tau from 4.4e3 s to 4.31e3 s and the
relative standard error of k2 from 9494 % to 9296 %); the values and their standard errors
are in the estimates.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from matid.fits.extension.lsq import _PARAM_NAMES
from matid.fits.extension.runs import _Run

#: Identifiability thresholds (see :func:`_unidentifiable`).
_MIN_TAU_SAMPLES = 3.0
_MAX_TAU_RUNS = 5.0
_MAX_CORR = 0.98
_MAX_REL_STDERR = 0.5


def _unidentifiable(k, se, corr, runs: Sequence[_Run], fixed: Mapping[str, float]) -> list[str]:
    """Why k2 and eta cannot be told apart from these runs (empty list: they can)."""
    if "k2" in fixed and "eta" in fixed:
        return []
    tau = k["eta"] / k["k2"]
    dt = min(run.dt for run in runs)
    longest = max(run.duration for run in runs)
    reasons = []
    if tau < _MIN_TAU_SAMPLES * dt:
        reasons.append(
            f"the fitted relaxation time tau is shorter than {_MIN_TAU_SAMPLES:g} sample "
            f"intervals ({dt:.3g} s) in every run"
        )
    if tau > _MAX_TAU_RUNS * longest:
        reasons.append(
            f"the fitted relaxation time tau is longer than {_MAX_TAU_RUNS:g} x the longest "
            f"run ({longest:.3g} s)"
        )
    r = corr.get("sls_k2|sls_eta")
    if r is not None and abs(r) > _MAX_CORR:
        reasons.append(f"k2 and eta are correlated (r = {r:.3f})")
    for name in ("k2", "eta"):
        if name in fixed:
            continue
        if se[name] is None:
            reasons.append(f"no standard error for {_PARAM_NAMES[name]} (singular fit)")
        elif se[name] > _MAX_REL_STDERR * k[name]:
            reasons.append(f"{_PARAM_NAMES[name]} relative standard error above {_MAX_REL_STDERR:.0%}")
    return reasons


def _k1_warnings(k, se, runs: Sequence[_Run], unresolved: bool) -> tuple[str, ...]:
    """Cautions on E_e = k1: a relaxation slower than the runs would hide in it."""
    tau = k["eta"] / k["k2"]
    longest = max(run.duration for run in runs)
    dashpot = tau < _MIN_TAU_SAMPLES * min(run.dt for run in runs)  # k1 is then clean
    out = []
    if tau > _MAX_TAU_RUNS * longest or (unresolved and not dashpot):
        out.append(
            f"no relaxation is resolved within the runs (longest {longest:.3g} s): E_e is the "
            "stiffness on that time scale and includes any slower-relaxing part; add a slower "
            "run or a hold to confirm it"
        )
    if se["k1"] is None or se["k1"] > _MAX_REL_STDERR * k["k1"]:
        out.append("E_e is poorly determined (relative standard error above 50 %)")
    return tuple(out)
