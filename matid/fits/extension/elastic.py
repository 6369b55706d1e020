r"""E_e where no relaxation time lies inside the record: the line of the SLS's two limits.

The Maxwell arm (k2, tau) of the standard linear solid (:mod:`matid.fits.extension.fit`) has two
limits a record cannot tell from a solid without relaxation: tau far below the sampling (the arm
is a dashpot, ``f2 = eta eps'``) and tau far beyond the record (a spring that slowly gives way,
``f2 = k2 eps - (k2 / tau) int_0^t eps dt + O(1 / tau^2)``). Both together, with a force offset
c_j per run, are linear in their coefficients::

    F = c_j + S eps + d eps' - g int_0^t eps dt

The rate and the integral restart after a gap in time (:func:`pieces`), with a force offset of their
own: a record logged in bursts is not bridged by straight lines. S is the stiffness on the record's
time scale (k1 in the fast limit, k1 + k2 in the slow one), d a dashpot (a loop between loading and
unloading) and g the rate of a relaxation slower than the record (N/s: held at strain eps, the force
falls by g eps per second). A relaxing model (the SLS, or the Prony series BIC prefers) resolves a
relaxation only when it describes the runs better than this line by more than ``BIC_MARGIN``
(:func:`resolves`: BIC on the effective number of residuals, AR(1), of the relaxing model, both
weighted by the same run noise); otherwise its equilibrium stiffness is an extrapolation (an elastic
composite cycled from rest: a tare and a drift of the force read as a relaxation put k1 5 % below
the slope of every cycle; records of fatigue machines logged in bursts: 50 % below) and E_e is S.

:func:`choose` gives E_e this way (method ``elastic-line``) and, for a single ramp whose SLS
resolves no relaxation, as the ramp's line (``ramp-line``). A single ramp at one rate is the line
alone (:func:`line` with ``single``): eps' is constant
there (one more offset) and int eps grows as eps^2, a curvature an elastic bend makes as well.
The slope's standard error is the AR(1) sandwich of :func:`matid.fits.stats.ar1_covariance`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import integrate

from matid.fits import stats
from matid.fits.extension.checks import cycled, single_ramps
from matid.fits.extension.runs import _Run
from matid.fits.stats import interval
from matid.model.results import Estimate

#: BIC decrease a relaxing model needs below the line to count as resolving a relaxation (strong
#: evidence, Kass & Raftery 1995; the Prony comparison's margin).
BIC_MARGIN = 10.0


@dataclass(frozen=True)
class Line:
    """``F = c_j + S eps (+ d eps' - g int eps dt)`` over the used rows of the runs."""

    slope: float  # S [N]
    se: float
    dof: float
    dashpot: float  # d [N s]; 0 for a single ramp
    drift: float  # g [N/s]; 0 for a single ramp
    residual: np.ndarray  # weighted, every used row in recording order
    n_params: int
    relaxing: tuple[np.ndarray, ...]  # per run, over all rows: d eps' - g int eps (zeros for a ramp)
    offsets: tuple[float, ...]  # c_j per run

    def bic(self, n_eff: float) -> float:
        return bic(self.residual, self.n_params, n_eff)


def bic(residual: np.ndarray, n_params: int, n_eff: float) -> float:
    """BIC of weighted residuals with the information of ``n_eff`` independent ones."""
    return stats.bic(float(residual @ residual), residual.size, n_params, n_eff)


#: A step in time longer than this many median sampling intervals is a gap in the record (a fatigue
#: machine logging in bursts): the strain history inside is unknown, so the line restarts there
#: (its rate and time integral, with a force offset of its own). Real sampling jitters to 2.3x its
#: median (Instron WaveMatrix: 0.002 to 0.028 s around 0.012 s). On records generated with that
#: jitter and 36 s gaps (tests/fits/extension/test_gaps.py, g = 167 N/s, seeds 0-5) every factor
#: from 3 to 1000 cuts the same 10 stretches and gives g = 120 to 193 N/s (156 without gaps);
#: bridging the gaps gives 541 to 560, and a factor of 1.5 cuts at the jitter (-227 to 1544).
GAP_FACTOR = 10.0


def pieces(t: np.ndarray) -> list[slice]:
    """The stretches of ``t`` between gaps (steps longer than ``GAP_FACTOR`` median steps)."""
    dt = np.diff(t)
    cuts = np.flatnonzero(dt > GAP_FACTOR * float(np.median(dt))) + 1 if dt.size else np.zeros(0, int)
    bounds = [0, *cuts.tolist(), t.size]
    return [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def _columns(run: _Run, single: bool) -> list[np.ndarray]:
    """eps, and unless ``single`` eps' and -int eps dt (both within each stretch between gaps), over
    all rows of the run."""
    if single:
        return [run.eps]
    rate, drift = np.zeros(run.t.size), np.zeros(run.t.size)
    for p in pieces(run.t):
        t, eps = run.t[p], run.eps[p]
        rate[p] = np.gradient(eps, t) if t.size > 1 else 0.0
        drift[p] = -integrate.cumulative_trapezoid(eps, t, initial=0.0)
    return [run.eps, rate, drift]


def _offsets(run: _Run, single: bool) -> list[np.ndarray]:
    """Indicator columns of the run's force offsets: one, or one per stretch between gaps."""
    cut = [slice(0, run.t.size)] if single else pieces(run.t)
    out = []
    for p in cut:
        col = np.zeros(run.t.size)
        col[p] = 1.0
        out.append(col)
    return out


def line(runs: Sequence[_Run], sigma: Sequence[float] | None = None, *, single: bool = False) -> Line:
    """The line (module docstring) over the used rows, each run weighted by its noise (``sigma``,
    default each run's own), with a force offset per run and per stretch after a gap in time
    (:func:`pieces`). Raises ValueError or LinAlgError when the rows cannot give it."""
    sigma = [run.noise for run in runs] if sigma is None else list(sigma)
    columns = [_columns(run, single) for run in runs]
    offsets = [[c for c in _offsets(run, single) if c[run.used].any()] for run in runs]
    k, n_off = len(columns[0]), sum(len(o) for o in offsets)
    blocks, ys, at = [], [], k
    for run, cols, offs, s in zip(runs, columns, offsets, sigma, strict=True):
        design = np.zeros((int(run.used.sum()), k + n_off))
        for i, col in enumerate([*cols, *offs]):
            design[:, i if i < k else at + i - k] = col[run.used] / s
        at += len(offs)
        blocks.append(design)
        ys.append(run.force[run.used] / s)
    design, y = np.vstack(blocks), np.concatenate(ys)
    scale = np.linalg.norm(design, axis=0)
    if np.any(scale <= 0):
        raise ValueError("a column of the line is zero over the rows used")
    coef, *_ = np.linalg.lstsq(design / scale, y, rcond=None)
    residual = design / scale @ coef - y
    segments = [int(o[run.used].sum()) for run, offs in zip(runs, offsets, strict=True) for o in offs]
    cov = stats.ar1_covariance(design / scale, residual, segments)
    coef = coef / scale
    relaxing, first, at = [], [], k
    for run, cols, offs in zip(runs, columns, offsets, strict=True):
        c = coef[at : at + len(offs)]
        at += len(offs)
        part = sum((a * col for a, col in zip(coef[1:k], cols[1:], strict=True)), np.zeros(run.t.size))
        # the offsets of the stretches after a gap, less the run's first: their unknown history
        relaxing.append(part + sum(((a - c[0]) * o for a, o in zip(c[1:], offs[1:], strict=True)), 0.0))
        first.append(float(c[0]))
    return Line(
        float(coef[0]),
        float(cov.stderr[0] / scale[0]),
        cov.dof,
        float(coef[1]) if k > 1 else 0.0,
        float(coef[2]) if k > 1 else 0.0,
        residual,
        design.shape[1],
        tuple(relaxing),
        tuple(first),
    )


def resolves(relaxing: np.ndarray, n_params: int, fit: Line, segments: Sequence[int]) -> tuple[bool, float]:
    """(whether the relaxing model's weighted residuals ``relaxing``, of ``n_params`` parameters,
    beat the line's by more than ``BIC_MARGIN``, and BIC of the line less that of the model). Both
    are scored on the effective number of residuals of the relaxing model."""
    n_eff = stats.effective_n(relaxing, segments, n_params)
    gain = fit.bic(n_eff) - bic(relaxing, n_params, n_eff)
    return gain > BIC_MARGIN, float(gain)


# --------------------------------------------------------------------------- E_e from the line


#: Why E_e is the ramp's line (:func:`ramp_line`).
_RAMP_LINE = (
    "a single ramp at one rate cannot tell relaxation from the elastic response, and the standard "
    "linear solid resolves none here (its k2 and eta stay undetermined): E_e is the slope of the line "
    "force = c + E_e strain over the rows used, the stiffness at this rate (any relaxing part is in "
    "it: the equilibrium stiffness may be lower); a hold or a second rate would part them, and a "
    "window on strain where the force is straight gives the small-strain value"
)


def ramp_line(e_e: Estimate, runs) -> tuple[Estimate, Line | None]:
    """(E_e as the slope of the force over the used rows of single-ramp runs whose SLS resolves no
    relaxation, the line): there k1 lies anywhere along a valley of k1 + k2 (a slow arm is a spring
    over the ramp), while the slope is what the record determines (:func:`line`). (e_e, None) when
    the rows cannot give the line."""
    try:
        fit = line(runs, single=True)
    except (ValueError, np.linalg.LinAlgError):
        return e_e, None
    return _line_estimate(e_e, fit, "ramp-line", (_RAMP_LINE,)), fit


def _line_estimate(e_e: Estimate, fit: Line, method: str, warnings) -> Estimate:
    return replace(
        e_e,
        value=fit.slope,
        stderr=fit.se,
        ci95=interval(fit.slope, fit.se, fit.dof),
        method=method,
        warnings=tuple(warnings),
        extra={"ci_method": "t"},
    )


def _compared(gain: float) -> str:
    """The BIC comparison by its threshold, not its digits: a model the data do not determine
    (k2 and eta along a flat valley) moves its BIC with the last bits of the data."""
    if gain <= 0:
        return "the line's BIC is lower"
    return f"its BIC is less than {BIC_MARGIN:g} below the line's, the margin a relaxation needs"


def _unresolved(model: str, gain: float, fit: Line, longest: float) -> str:
    """Why E_e is the line's slope (:func:`_elastic_line`), and how far the record's drift reaches.
    The unresolved model's own equilibrium stiffness is not printed: it is an extrapolation whose
    digits hang on the last bits of the data (tests/fits/extension/test_sls_independent.py)."""
    text = (
        "no relaxation time is resolved inside the record: the line force = c + E_e strain + d "
        "strain rate - g (time integral of strain), the limits of the standard linear solid for a "
        "relaxation far faster than the sampling (a dashpot d) or far slower than the record (a "
        f"drift g), describes the runs as well as {model} ({_compared(gain)}), so that model's "
        "equilibrium stiffness is an extrapolation: E_e is the stiffness on the record's time scale"
    )
    if fit.drift > 0:
        low = fit.slope - fit.drift * longest
        text += (
            f"; held at a strain the force falls by g = {fit.drift:.4g} N/s per unit strain, "
            f"{fit.drift * longest:.4g} N of stiffness over the longest run ({longest:.3g} s): "
            f"the interval reaches down to {low:.4g} N and the equilibrium stiffness may be lower"
        )
    return text + "; a hold longer than the relaxation would give the equilibrium value"


def _elastic_line(e_e: Estimate, runs, sigma, compared: tuple[str, np.ndarray, int]):
    """(E_e, the line) when the relaxing model that gave E_e (``compared``: its name, weighted
    residuals on every used row, parameters) does not describe the runs better than the line
    of :mod:`matid.fits.extension.elastic`, else (e_e, None)."""
    try:
        fit = line(runs, sigma)
    except (ValueError, np.linalg.LinAlgError):
        return e_e, None
    model, resid, params = compared
    resolved, gain = resolves(resid, params, fit, [int(run.used.sum()) for run in runs])
    if resolved:
        return e_e, None
    longest = max(run.duration for run in runs)
    out = _line_estimate(e_e, fit, "elastic-line", (_unresolved(model, gain, fit, longest),))
    if fit.drift > 0 and out.ci95 is not None:
        out = replace(out, ci95=(min(out.ci95[0], fit.slope - fit.drift * longest), out.ci95[1]))
    return out, fit


def choose(
    e_e: Estimate, runs, sigma, unresolved: bool, compared
) -> tuple[Estimate, Line | None, tuple[float, ...] | None]:
    """(E_e, the line of :func:`_elastic_line` or None, the force offsets of the line that gave E_e
    or None): the ramp's line for single ramps whose SLS resolves no relaxation (``unresolved``);
    for runs that unload or hold (:func:`cycled`), the line where the relaxing model does not
    describe them better than it; else E_e as the relaxing model gave it. A line's offsets are
    those E_e's warnings state (the unresolved SLS's move with where along its valley it landed:
    -0.0002 to -0.116 N on a single ramp with a slack toe, tests/fits/extension/test_sls_independent.py)."""
    if single_ramps(runs):
        if not unresolved:
            return e_e, None, None
        e_e, ramp = ramp_line(e_e, runs)
        return e_e, None, (ramp.offsets if ramp is not None else None)
    if cycled(runs):
        e_e, fit = _elastic_line(e_e, runs, sigma, compared)
        return e_e, fit, (fit.offsets if fit is not None else None)
    return e_e, None, None


def unresolved_arm(est: Estimate) -> Estimate:
    said = (
        "k2 and eta are not identifiable: no relaxation time is resolved inside the record (E_e is "
        "the line's slope; see its warning)"
    )
    return replace(est, warnings=(said, *est.warnings))
