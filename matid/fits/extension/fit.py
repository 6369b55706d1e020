r"""Standard linear solid (extension test): responses and the joint fit (physics.md section 1).

A spring k1 in parallel with a Maxwell arm (spring k2 in series with a dashpot eta),
in force units against engineering strain eps, from rest::

    F(t) = k1 eps(t) + f2(t),      f2' + (k2/eta) f2 = k2 eps'(t),      f2(0) = 0

Relaxation time tau = eta / k2. For a strain history that is linear between samples
(rate r_i on [t_{i-1}, t_i], dt_i = t_i - t_{i-1}) the update is exact::

    a_i  = exp(-dt_i / tau)
    f2_i = a_i f2_{i-1} + eta r_i (1 - a_i)

and for a constant-rate ramp eps = r t::

    F = k1 r t + eta r (1 - exp(-t / tau))

The slope dF/deps tends to k1 once t >> tau, so the static extension stiffness is
E_e = k1. k2 and eta are identifiable only when tau lies inside the observed time
window of some run; otherwise the fit says so instead of printing a bare number.

The fit (:func:`fit_extension`) is a joint weighted least-squares fit over all runs of
one specimen in log-parameters. The parts: runs in SI (:mod:`matid.fits.extension.runs`),
the least squares and its starts (:mod:`matid.fits.extension.lsq`), standard errors and intervals
(:mod:`matid.fits.extension.stats`), the bin means of long records
(:mod:`matid.fits.extension.reduce`), identifiability and cautions
(:mod:`matid.fits.extension.checks`); this module assembles the estimates.

A run that takes up slack or starts at a preload (:mod:`matid.fits.extension.start`) starts where
the strip becomes taut, from rest, with a free force offset ``F = c + k1 eps + f2`` (projected out
of the least squares, :mod:`matid.fits.extension.lsq`); E_e says so. Single ramps at one rate
whose SLS resolves no relaxation (k2 and eta not identifiable) cannot fix k1 (a slow arm is a
spring over the ramp: k1 slides along a valley of k1 + k2): E_e is then the slope of the force
over the rows used, the stiffness at that rate, and says why. Runs that unload or hold, where
neither the SLS nor the preferred Prony series describes them better than the SLS's limits (a
dashpot and a relaxation slower than the record: a line with two more terms), resolve no
relaxation either: E_e is then that line's slope (:mod:`matid.fits.extension.elastic`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from matid.errors import FitError
from matid.fits.extension import elastic, lsq, prony
from matid.fits.extension.checks import _k1_warnings, _unidentifiable, end_of_hold, nonlinear, single_ramps
from matid.fits.extension.lsq import _ORDER, _PARAM_NAMES, _models, _offset, _solve, _values, n_params
from matid.fits.extension.runs import _Run, _run, _unique
from matid.fits.extension.stats import _correlation, _covariance_fit, _intervals, _misfit, _sandwich, _stderr
from matid.model.kind import Kind
from matid.model.results import Estimate, Series, TestFit

if TYPE_CHECKING:
    from matid.model.measurement import Measurement

#: Names ``fixed`` may use, and the SLS parameter each one fixes.
_FIXED_NAMES = {"E_e": "k1", "sls_k1": "k1", "sls_k2": "k2", "sls_eta": "eta"}


# --------------------------------------------------------------------------- the fit


def _fixed(fixed: Mapping[str, float]) -> dict[str, float]:
    """``fixed`` by SLS name (k1, k2, eta), validated."""
    out: dict[str, float] = {}
    for key, value in fixed.items():
        if key not in _FIXED_NAMES:
            raise ValueError(f"fixed: unknown parameter {key!r} (one of {', '.join(_FIXED_NAMES)})")
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"fixed: {key} must be positive and finite, got {value}")
        name = _FIXED_NAMES[key]
        if name in out and not math.isclose(out[name], value, rel_tol=1e-12):
            raise ValueError("fixed: E_e and sls_k1 are the same parameter but differ")
        out[name] = float(value)
    return out


def _estimate(parameter, name, k, se, ci, n, fixed, warn=()) -> Estimate:
    if name in fixed:
        return Estimate(parameter, k[name], None, None, n, "fixed")
    ci95, how = ci.get(name, (None, None))
    return Estimate(parameter, k[name], se[name], ci95, n, "sls", tuple(warn), {"ci_method": how})


def _plotted(run: _Run, model: np.ndarray) -> dict[str, np.ndarray]:
    """What a plot of the run draws: every row, or on a long record (residuals as bin means,
    :mod:`matid.fits.extension.reduce`) the bin means of the used rows, model alike; the rows
    before the strip became taut (``run.before``) first, not used and without a model."""
    rows = {"time_s": run.t, "strain": run.eps, "force_N": run.force, "model_N": model}
    if run.reduce.starts is None:
        out = {**rows, "used": run.used}
    else:
        out = {key: run.reduce.means(values) for key, values in rows.items()}
        out["used"] = np.ones(out["time_s"].size, dtype=bool)
    if run.before is None:
        return out
    t, eps, force = run.before
    first = {"time_s": t, "strain": eps, "force_N": force, "model_N": np.full(t.size, np.nan)}
    first["used"] = np.zeros(t.size, dtype=bool)
    return {key: np.concatenate([first[key], out[key]]) for key in out}


def _series(runs: Sequence[_Run], models: Sequence[np.ndarray]) -> tuple[Series, ...]:
    out = []
    for run, f in zip(runs, models, strict=True):
        p = _plotted(run, f)
        label = f"{run.name}, strain rate {run.rate:.3g} 1/s"
        if run.reduce.starts is not None:
            label += f" ({run.reduce.size} bin means of {int(run.used.sum())} rows)"
        out.append(Series(label, p["strain"], p["force_N"], p["model_N"], p["used"]))
    return tuple(out)


def _info(runs, models, k, sigma, nfree: int) -> dict[str, object]:
    """Fit summary. reduced_chi2 is measured against the model-free (second-difference)
    noise, not the residual noise used as weights, so values well above 1 flag misfit.
    ``plot_data["force_time"]`` holds, per run, time, measured and model force and the
    rows used, for a force-against-time figure of ramp-hold and relaxation runs (bin means
    on a long record: :func:`_plotted`)."""
    chi2 = sum(
        float(np.sum(((f - run.force)[run.used] / run.noise) ** 2))
        for f, run in zip(models, runs, strict=True)
    )
    return {
        "tau_s": k["eta"] / k["k2"],
        "time_window_s": [min(run.dt for run in runs), max(run.duration for run in runs)],
        "reduced_chi2": chi2 / nfree,
        "noise_N": {run.name: float(s) for run, s in zip(runs, sigma, strict=True)},
        "n_runs": len(runs),
        "left_out": {run.name: dict(run.left_out) for run in runs if run.left_out},
        "plot_data": {
            "force_time": {
                run.name: {key: v for key, v in _plotted(run, f).items() if key != "strain"}
                for run, f in zip(runs, models, strict=True)
            }
        },
    }


def _plot_prony(plot_data: dict, runs, fit: prony.PronyFit) -> None:
    """The preferred Prony series' force beside each run's SLS model (``prony_N``, bin means
    alike on a long record) and the model's name (``model``) for the force-time figure."""
    for run in runs:
        force = prony.prony_force(run.t, run.eps, fit.k0, fit.ks, fit.taus)
        force = force + _offset(run, force)
        plot_data["force_time"][run.name]["prony_N"] = _plotted(run, force)["model_N"]
    arms = len(fit.taus)
    plot_data["model"] = f"Prony series, {arms} arm{'s' if arms > 1 else ''} (preferred by BIC; gives E_e)"


def _prony(runs, sigma, k, fixed_k):
    """The Prony comparison: (choice or None, extra estimates, E_e warning, sls warning)."""
    if fixed_k:
        return None, (), None, None
    data = [
        prony.Data(r.t, r.eps, r.force, r.used, float(s), r.reduce, r.offset)
        for r, s in zip(runs, sigma, strict=True)
    ]
    choice = prony.choose(data)
    if choice is None or choice.best == 1:
        return choice, (), None, None
    longest = max(run.duration for run in runs)
    estimates, e_e, sls = prony.preferred(choice, k["k1"], longest)
    return choice, estimates, e_e, sls


def _widened(e_e: Estimate, warning: str, low: float, high: float) -> Estimate:
    ci = (min(low, e_e.ci95[0]), max(high, e_e.ci95[1])) if e_e.ci95 else None
    return replace(e_e, ci95=ci, warnings=(warning, *e_e.warnings))


def _nonlinear(e_e: Estimate, runs, k, best: prony.PronyFit | None, line: elastic.Line | None) -> Estimate:
    """E_e with its interval spanning the elastic tangents over the strain range, and why, when
    the force is not linear in strain (:func:`checks.nonlinear`); the relaxing part is that of
    the model that gave E_e (the preferred Prony series, else the SLS; the line's dashpot and
    drift for the line of :func:`_elastic_line`; none for the ramp's line)."""
    if e_e.method == "ramp-line":
        zeros = [np.zeros(run.t.size) for run in runs]
        found = nonlinear(runs, zeros, e_e.value, "the force's own tangent")
        return e_e if found is None else _widened(e_e, *found)
    if line is not None:
        what = "the force less the line's dashpot and drift"
        found = nonlinear(runs, line.relaxing, e_e.value, what)
        return e_e if found is None else _widened(e_e, *found)
    if best is None:
        relaxing = [run.history.force(0.0, k["k2"], k["eta"]) for run in runs]
    else:
        relaxing = [prony.prony_force(run.t, run.eps, 0.0, best.ks, best.taus) for run in runs]
    found = nonlinear(runs, relaxing, e_e.value)
    if found is None and single_ramps(runs):  # the relaxing part may be an elastic curve's bend
        what = (
            "a single ramp at one rate cannot tell relaxation from an elastic curve that bends "
            "with strain, and the force's own tangent"
        )
        found = nonlinear(runs, [np.zeros(run.t.size) for run in runs], e_e.value, what)
    return e_e if found is None else _widened(e_e, *found)


def _offsets(runs, k, best: prony.PronyFit | None) -> list[float]:
    """Each run's force offset (0 for a run without one) under the model that gave E_e: the
    preferred Prony series (``best``), else the SLS."""
    if best is None:
        forces = [run.history.force(k["k1"], k["k2"], k["eta"]) for run in runs]
    else:
        forces = [prony.prony_force(run.t, run.eps, best.k0, best.ks, best.taus) for run in runs]
    return [_offset(run, f) for run, f in zip(runs, forces, strict=True)]


def _below_hold(e_e: Estimate, runs, offsets: Sequence[float]) -> Estimate:
    """E_e with its interval reaching down to what a run's hold allows, and why, when it lies
    above the stiffness measured at the end of that hold (:func:`checks.end_of_hold`)."""
    found = end_of_hold(runs, e_e.value, e_e.stderr, offsets)
    if found is None:
        return e_e
    warning, low = found
    return _widened(e_e, warning, low, -math.inf)


def _started(e_e: Estimate, runs, offsets: Sequence[float]) -> Estimate:
    """E_e with a warning per run that starts at slack or a preload: what was found, where the
    fit starts and the force offset it fitted (:mod:`matid.fits.extension.start`); and one per row
    dropped from a run (its end-of-test row, :mod:`matid.fits.extension.runs`)."""
    said = [
        f"{run.name}: {run.start.reason()}: force offset {c:.4g} N; check the plot of its start"
        for run, c in zip(runs, offsets, strict=True)
        if run.start is not None
    ]
    said += [text for run in runs for text in run.said]
    return replace(e_e, warnings=(*e_e.warnings, *said)) if said else e_e


def fit_extension(
    measurements: Sequence[Measurement], *, specimen: str, fixed: Mapping[str, float] = {}
) -> TestFit:
    """Joint SLS fit of all extension runs of one specimen: E_e = k1, k2, eta with 95 % intervals,
    and beside it the Prony model BIC prefers (:mod:`matid.fits.extension.prony`).

    Residuals of run j are weighted by 1/sigma_j, its own noise estimated from its
    residuals; only rows inside the window and not slack enter (the model runs over
    every row: it has a memory). Intervals are the AR(1) sandwich of
    :mod:`matid.fits.stats`. ``fixed`` may hold any of E_e (= sls_k1), sls_k2, sls_eta.
    """
    fixed_k = _fixed(fixed)
    if not measurements:
        raise FitError(f"specimen {specimen}: no extension runs to fit")
    if len(fixed_k) == 3:
        raise FitError(f"specimen {specimen}: k1, k2 and eta are all fixed; nothing to fit")
    runs = _unique([_run(m) for m in measurements])
    runs, minimizer, result, ref, sigma = _solve(runs, fixed_k)
    minimizer, result = _covariance_fit(runs, sigma, minimizer, result, ref, fixed_k)
    k = _values(result.params, ref)
    se, cov = _sandwich(result, runs, sigma, ref, _stderr(result, ref))
    corr = _correlation(result)
    reasons = _unidentifiable(k, se, corr, runs, fixed_k)
    correlated = cov is not None and cov.rho > 0
    dof = cov.dof if cov is not None else result.nfree
    ci = _intervals(minimizer, result, ref, se, profile=not reasons and not correlated, dof=dof)
    n = sum(int(run.used.sum()) for run in runs)
    lof, misfit = _misfit(result, runs, ref, cov, unresolved=bool(reasons))
    choice, prony_estimates, prony_e_e, prony_sls = _prony(runs, sigma, k, fixed_k)
    why = [f"k2 and eta are not identifiable from the rates given: {'; '.join(reasons)}"] if reasons else []
    sls_warn = [w for w in (misfit, prony_sls) if w]
    k1_warn = list(_k1_warnings(k, se, runs, bool(reasons))) if "k1" not in fixed_k else []
    warn = {"k1": [*k1_warn, *sls_warn], "k2": [*why, *sls_warn], "eta": [*why, *sls_warn]}
    sls = [_estimate(_PARAM_NAMES[name], name, k, se, ci, n, fixed_k, warn[name]) for name in _ORDER]
    e_e = replace(sls[0], parameter="E_e")
    if prony_estimates:
        k0 = prony_estimates[0]
        e_e = replace(k0, parameter="E_e", warnings=(prony_e_e, *k0.warnings))
    best = choice.fits[choice.best] if prony_estimates else None
    offsets = _offsets(runs, k, best)
    line = None
    if "k1" not in fixed_k:
        noise = [run.noise for run in runs]  # model-free: the line must not move with where the fit landed
        compared = _relaxing(result, runs, sigma, ref, best, noise)
        e_e, line, given = elastic.choose(e_e, runs, noise, bool(reasons), compared)
        offsets = list(given) if given is not None else offsets  # those of the model giving E_e
        e_e = _below_hold(_nonlinear(e_e, runs, k, best, line), runs, offsets)
    e_e = _started(e_e, runs, offsets)
    if line is not None:  # the line describes the runs as well: the SLS's k2 and eta are not resolved
        sls = [elastic.unresolved_arm(est) if est.parameter in ("sls_k2", "sls_eta") else est for est in sls]
    estimates = (e_e, *sls, *prony_estimates)
    models = _models(runs, k)
    info = _info(runs, models, k, sigma, n - n_params(result.nvarys, runs))
    info["lack_of_fit"] = lof.as_info()
    info["n_effective"] = cov.n_eff if cov is not None else float(n)
    info["interval_widening"] = float(np.max(cov.inflation)) if cov is not None else 1.0
    if choice is not None:
        info["model_choice"] = {"arms_preferred": choice.best, **choice.table()}
    if prony_estimates and line is None:  # E_e is the Prony series': the force-time plot draws it
        _plot_prony(info["plot_data"], runs, choice.fits[choice.best])
    if line is not None:  # the figure draws the SLS, which does not give E_e
        info["plot_data"]["model"] = "SLS model (E_e is the elastic line's slope: no relaxation resolved)"
    return TestFit(
        kind=KIND.name,
        specimen=specimen,
        tests=tuple(m.test for m in measurements),
        estimates=estimates,
        series=_series(runs, models),
        x_label="strain [1]",
        y_label="force [N]",
        correlation=corr,
        info=info,
    )


def _relaxing(result, runs, sigma, ref, best: prony.PronyFit | None, noise) -> tuple[str, np.ndarray, int]:
    """The relaxing model that gave E_e: (its name, residuals on every used row weighted by each
    run's model-free ``noise`` as the elastic line's are, its parameters with the runs' force
    offsets): the preferred Prony series, else the SLS (both fitted with weights ``sigma``)."""
    rescale = np.repeat(np.asarray(sigma, dtype=float) / noise, [int(run.used.sum()) for run in runs])
    if best is not None:
        arms = f"the {best.n_terms}-arm Prony series"
        return arms, best.residual * rescale, n_params(best.n_params, runs)
    resid = lsq.residual(result.params, runs, sigma, ref, rows=True)
    return "the standard linear solid", resid * rescale, n_params(result.nvarys, runs)


#: Fixed parameters the extension fit holds (E_e is sls_k1).
FIXABLE = ("E_e", "sls_k1", "sls_k2", "sls_eta")


def _fit(measurements, *, specimen, fixed, known) -> TestFit:
    return fit_extension(
        measurements, specimen=specimen.id, fixed={k: v for k, v in fixed.items() if k in FIXABLE}
    )


KIND = Kind(
    name="extension",
    title="Extension",
    columns={"time": "time", "force": "force", "elongation": "length", "strain": "strain"},
    required=(("time",), ("force",), ("elongation", "strain")),
    keys={"gauge_length": "length"},
    positive=("force", "elongation", "strain"),
    parameters=("E_e", "sls_k1", "sls_k2", "sls_eta"),
    gives=("sls_k1", "sls_k2", "sls_eta"),  # E_e is sls_k1: skipped only when k1, k2 and eta are fixed
    fit=_fit,
    drawings=("force_time",),
)
