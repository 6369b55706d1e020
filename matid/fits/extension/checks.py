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

import math
from collections.abc import Mapping, Sequence

import numpy as np

from matid.fits import branch, stats
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


#: A hold ends a run: its trailing rows whose strain stays within this fraction of the run's
#: strain range of the last value, at least ``_HOLD_ROWS`` of them.
_HOLD_STRAIN = 1e-3
_HOLD_ROWS = 20
#: E_e above the end of a hold by more than this many standard errors of the difference.
_ABOVE_SE = 3.0


def end_of_hold(
    runs: Sequence[_Run], e_e: float, se_e: float | None, offsets: Sequence[float] | None = None
) -> tuple[str, float] | None:
    """(warning, lower end of E_e's interval) when E_e lies above the stiffness a run measured at
    the end of its hold, else None.

    A relaxing solid's force at constant strain falls towards k0 eps, so G = F / eps at the end
    of a hold is an upper bound of the equilibrium stiffness. A model whose k0 lies above it
    misses the end of the record, which still relaxes (an elastomer relaxes as a power of time):
    E_e's interval from the noise alone would exclude the values the record allows. G over the
    last half of the hold, ``G = a + b ln s`` (s: time since the hold began), gives G_end at the
    end and b, the fall per e-fold of time; the interval then reaches down to where one more
    decade of hold at that rate would bring it, ``G_end + b ln 10`` (to G_end less its 95 % error
    when G no longer falls). A run with a force offset c (slack or preload, ``offsets``) reads
    ``G = (F - c) / eps``.
    """
    found = None
    for run, c in zip(runs, offsets if offsets is not None else [0.0] * len(runs), strict=True):
        eps, force, t = run.eps, run.force, run.t
        tol = _HOLD_STRAIN * float(np.ptp(eps))
        moved = np.flatnonzero(~(np.abs(eps - eps[-1]) <= tol) | ~run.used)
        start = int(moved[-1]) + 1 if moved.size else 0
        if t.size - start < _HOLD_ROWS or eps[-1] <= 0 or start == 0:
            continue
        s = t[start:] - t[start - 1]
        last = s >= s[-1] / 2.0
        if last.sum() < _HOLD_ROWS:
            continue
        g = (force[start:][last] - c) / eps[start:][last]
        design = np.column_stack([np.ones(int(last.sum())), np.log(s[last] / s[-1])])
        coef, *_ = np.linalg.lstsq(design, g, rcond=None)
        resid = g - design @ coef
        f, _ = stats.variance_factor(resid, n_params=2)
        cov = f * float(resid @ resid) / (resid.size - 2) * np.linalg.inv(design.T @ design)
        g_end, b, se_g = float(coef[0]), float(coef[1]), math.sqrt(cov[0, 0])  # at s = s[-1]
        if e_e - g_end <= _ABOVE_SE * math.hypot(se_g, se_e or 0.0):
            continue
        low = g_end + min(b, 0.0) * math.log(10.0) - 1.96 * se_g
        warning = (
            f"E_e = {e_e:.4g} N lies above the stiffness {run.name} measured at the end of its hold, "
            f"force / strain = {g_end:.4g} N after {s[-1]:.3g} s, where it still falls by "
            f"{-b * math.log(10.0):.3g} N per decade of time: the model misses the end of the record "
            f"and the equilibrium stiffness is below {g_end:.4g} N; the interval reaches down to "
            f"{low:.4g} N, where one more decade of hold would bring it at that rate; a longer hold "
            "would show where it settles"
        )
        if found is None or low < found[1]:
            found = (warning, low)
    return found


#: The elastic tangent differs between the ends of the strain range by more than this share of
#: E_e (and significantly) for the record to count as not linear in strain.
_NONLINEAR_SHARE = 0.05
#: t-statistic of the curvature (AR(1)-corrected) above which it is significant.
_NONLINEAR_T = 3.0


def single_ramps(runs: Sequence[_Run]) -> bool:
    """Whether every run's used rows are one ramp at one rate: strain never held or reversed
    (:func:`matid.fits.branch.branch`), one run or all at the same rate within 10 %. Such
    records cannot tell relaxation from an elastic curve that bends with strain (both bend the
    ramp; a hold, an unloading or a second rate would part them)."""
    for run in runs:
        eps, force = run.eps[run.used], run.force[run.used]
        if eps.size < 3 or any(mask.any() for mask in branch.branch(eps, force).values()):
            return False
    rates = [run.rate for run in runs]
    return max(rates) <= 1.1 * min(rates)


#: A run is cycled or held when its unloading and hold rows are at least this share of its used rows
#: (a few rows a noisy extensometer moves back make no cycle).
_CYCLED_SHARE = 0.05


def cycled(runs: Sequence[_Run]) -> bool:
    """Whether some run's used rows unload or hold (:func:`matid.fits.branch.branch`) on at least
    ``_CYCLED_SHARE`` of them: rows where the strain rate differs from the loading's, which part a
    dashpot and a slow drift from a force that bends with strain (:mod:`.elastic`)."""
    for run in runs:
        eps, force = run.eps[run.used], run.force[run.used]
        if eps.size < 3:
            continue
        other = sum(int(mask.sum()) for mask in branch.branch(eps, force).values())
        if other >= _CYCLED_SHARE * eps.size:
            return True
    return False


def nonlinear(
    runs: Sequence[_Run],
    relaxing: Sequence[np.ndarray],
    e_e: float,
    what: str = "the elastic tangent (force less the model's relaxing part)",
) -> tuple[str, float, float] | None:
    """(warning, low, high) when the force is not linear in strain over the record, else None.

    The elastic part of the force, the measured force less the model's relaxing part
    (``relaxing``: per run, over all rows), is a line in strain for a linear solid. A cubic in
    strain over the used rows gives the tangent at the low and high ends of the strain range
    (2nd and 98th percentiles); when its quadratic or cubic term is significant (standard
    errors inflated for AR(1) residuals) and the tangents differ by more than
    ``_NONLINEAR_SHARE`` of E_e, E_e is a mean over that range: the warning states the range
    and the tangents, and E_e's interval spans them.
    """
    eps = np.concatenate([run.eps[run.used] for run in runs])
    elastic = np.concatenate([(run.force - f)[run.used] for run, f in zip(runs, relaxing, strict=True)])
    if eps.size < 10 or np.ptp(eps) <= 0:
        return None
    lo, hi = (float(q) for q in np.percentile(eps, [2.0, 98.0]))
    if hi <= lo:
        return None
    u = (eps - lo) / (hi - lo)
    design = np.column_stack([np.ones_like(u), u, u**2, u**3])
    coef, *_ = np.linalg.lstsq(design, elastic, rcond=None)
    resid = elastic - design @ coef
    f, _ = stats.variance_factor(resid, [int(run.used.sum()) for run in runs], 4)
    cov = f * float(resid @ resid) / (resid.size - 4) * np.linalg.inv(design.T @ design)
    if not np.any(np.abs(coef[2:]) > _NONLINEAR_T * np.sqrt(np.diag(cov)[2:])):
        return None
    t_lo, t_hi = coef[1] / (hi - lo), (coef[1] + 2.0 * coef[2] + 3.0 * coef[3]) / (hi - lo)  # dF/deps
    if abs(t_hi - t_lo) <= _NONLINEAR_SHARE * e_e:
        return None
    warning = (
        f"the force is not linear in strain over the record: {what} "
        f"is {t_lo:.4g} N at strain {lo:.3g} and {t_hi:.4g} N at strain "
        f"{hi:.3g}; E_e = {e_e:.4g} N is a mean over strain {lo:.3g} to {hi:.3g} and its interval "
        "spans the tangents; for the small-strain value, give the test a window on strain where "
        "the tangent holds"
    )
    return warning, float(min(t_lo, t_hi)), float(max(t_lo, t_hi))
