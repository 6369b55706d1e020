"""E_s from the three-point bend: the rod solver inside a least-squares loop.

For every loading-branch point i of every bend test of a specimen (span S_k),

    r_i(E_s) = F_rod(d_i; E_b, E_s, E_e, S_k) - F_i,

minimised over log E_s (and log E_b with ``fit_E_b``), E_b and E_e taken from
the specimen's own fits or [[fixed]] entries (physics.md section 6). F_rod is
the nose force of :class:`matid.rod.bend.BendModel`, solved along a few knots and
interpolated to every row, with dF/dE_s from the linearised equilibrium, not from
differences of solver output (:mod:`matid.fits.shear.problem`; why scipy's least_squares and
not lmfit: :mod:`matid.fits.shear.lsq`; centreline data: :mod:`matid.fits.shear.centreline`).
A fit costs the knots, not the rows (17-33 knots for 3000 rows).

The start is the classic Timoshenko estimate from the small-deflection
compliance C = d/F:  C = S^3/(48 E_b) + S/(4 E_s).

Uncertainty: the linearised standard error s^2 (J^T J)^-1 with s^2 the
residual variance, plus the propagated uncertainty of the held stiffnesses,

    var(E_s) = var_fit + (dE_s/dE_b)^2 var(E_b) + (dE_s/dE_e)^2 var(E_e),
    dE_s/dp = -(J_s . J_p)/(J_s . J_s)   (first-order optimality),

which dominates on long spans. The shear share of the compliance,
(S/4E_s) / (S^3/48E_b + S/4E_s), says how identifiable E_s is: a 1 % error in
E_b moves E_s by about (1 - share)/share %; below ``MIN_SHEAR_SHARE`` the
estimate carries a warning instead of standing as a confident number.

The discretisation error is estimated by solving again at half the elements at
the fitted values (P2 converges at order 4 here, measured) and mapping the
force difference into E_s; the mesh is doubled until that error is below a
tenth of the statistical standard error.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from matid.errors import FitError
from matid.fits.bending import KIND as BENDING
from matid.fits.shear.checks import MIN_SHEAR_SHARE, assess, consistency, model_form_variance, shear_share
from matid.fits.shear.data import BendData, bend_data, timoshenko_force, timoshenko_start
from matid.fits.shear.lsq import least_squares, statistics
from matid.fits.shear.problem import Problem, fe_error, span_fits
from matid.fits.shear.torsion import agreement
from matid.fits.stats import Covariance, lack_of_fit, t95
from matid.model.kind import Kind
from matid.model.measurement import Measurement
from matid.model.results import Estimate, Series, TestFit
from matid.model.study import Specimen

#: The FE error must stay below this fraction of the statistical standard error
#: (or below FE_ERROR_FLOOR, for noise-free data whose standard error is zero).
FE_ERROR_FRACTION = 0.1
FE_ERROR_FLOOR = 1e-6
START_ELEMENTS = 16
#: Why a nose-travel test of a specimen with centreline tests is not fitted.
LEFT_OUT = (
    "nose travel, left out: centreline tests of this specimen are fitted (nose travel includes the "
    "local contact compliance)"
)
MAX_ELEMENTS = 256


def _held(known: Mapping[str, Estimate], name: str, specimen: str) -> Estimate:
    est = known.get(name)
    if est is None:
        source = f"a {BENDING.name} test" if name == "E_b" else "extension tests"
        raise FitError(
            f"E_s of specimen {specimen} needs {name}: add {source} or a [[fixed]] {name} for {specimen}"
        )
    return est


@dataclass
class Outcome:
    x: np.ndarray
    r: np.ndarray
    J: np.ndarray
    covariance: Covariance  # of (log E_s[, log E_b]) from the fit alone (:func:`statistics`)
    fe_error: float  # relative discretisation error of E_s
    elements: int
    solves: int
    problem: Problem
    levels: list  # [{elements, discretization_error, runtime_s}] of every mesh tried

    @property
    def cov_log(self) -> np.ndarray:
        return self.covariance.cov

    @property
    def sigma(self) -> float:
        """Residual standard deviation [N]."""
        return float(np.sqrt(float(self.r @ self.r) / max(self.r.size - self.J.shape[1], 1)))


def _fit_adaptive(data, E_b, E_e, *, fit_E_b: bool, elements: int | None, progress) -> Outcome:
    x = np.log([timoshenko_start(data, E_b)] + ([E_b] if fit_E_b else []))
    n = elements or START_ELEMENTS
    solves, levels = 0, []
    while True:
        problem = Problem(data, E_b, E_e, fit_E_b=fit_E_b, elements=n)
        x = least_squares(problem, x)
        while problem.refine(x):  # the knots chosen at the start miss the tolerance here
            x = least_squares(problem, x)
        r, J = problem.evaluate(x)
        cov = statistics(r, J, [b.d.size for b in data])
        fe, tried = fe_error(problem, x, data, E_e, fit_E_b)
        levels += [lvl for lvl in tried if lvl["elements"] not in {m["elements"] for m in levels}]
        solves += problem.solves + len(data)
        if progress:
            progress(f"E_s fit at {n} elements: E_s = {np.exp(x[0]):.6g} N, FE error {fe:.2e}")
        target = max(FE_ERROR_FRACTION * float(np.sqrt(cov.cov[0, 0])), FE_ERROR_FLOOR)
        if elements or fe <= target or 2 * n > MAX_ELEMENTS:
            return Outcome(x, r, J, cov, fe, n, solves, problem, levels)
        n *= 2


def fit_three_point_bend(
    measurements: Sequence[Measurement],
    *,
    specimen: Specimen,
    fixed: Mapping[str, float] | None = None,
    known: Mapping[str, Estimate],
    fit_E_b: bool = False,
    elements: int | None = None,
    progress=None,
    local_compliance: tuple[float, float] | None = None,
    model_form: float | None = None,
) -> TestFit:
    """E_s (and E_b with ``fit_E_b``) of one specimen from all its bend tests (module docstring).

    Centreline tests, when there are any, are fitted alone and nose-travel tests
    are shown but left out. Nose travel alone is assessed by
    :func:`matid.fits.shear.checks.assess` (withheld or warned when the local
    contact compliance would bias E_s); ``local_compliance`` (low, high) [m/N]
    replaces its prediction, e.g. (0, 0) for data of the rod model itself.
    ``model_form``: relative compliance uncertainty of the rod model against a
    continuum (default :func:`matid.fits.shear.checks.model_form_variance`; 0 for
    data of the rod model itself).
    ``fixed``: the specimen's [[fixed]] values (SI), held as the lmfit fits hold a
    ``vary=False`` parameter: a fixed E_b is not fitted with ``fit_E_b`` (its value
    comes, like E_e's, through ``known``); a fixed E_s leaves nothing to fit.
    """
    t0 = time.perf_counter()
    if not measurements:
        raise FitError("no three-point-bend tests to fit")
    fixed = fixed or {}
    if "E_s" in fixed:
        raise FitError(f"specimen {specimen.id}: E_s is fixed; nothing to fit")
    fit_E_b = fit_E_b and "E_b" not in fixed
    E_b_est = _held(known, "E_b", specimen.id)
    E_e_est = _held(known, "E_e", specimen.id)
    every = [bend_data(m, specimen, E_b_est.value) for m in measurements]
    data = [b for b in every if b.centreline] or every
    nose = not data[0].centreline
    spans = sorted({b.geometry.span for b in data})
    if fit_E_b and len(spans) < 2:
        raise FitError("fitting E_b jointly with E_s needs bend tests at two or more spans")
    F_max = max(float(np.max(b.F)) for b in data)
    check = assess(spans, E_b_est.value, specimen, known, nose=nose, local=local_compliance, max_force=F_max)
    if check.withhold:
        raise FitError(check.withhold)
    out = _fit_adaptive(
        data, E_b_est.value, E_e_est.value, fit_E_b=fit_E_b, elements=elements, progress=progress
    )
    E_s = float(np.exp(out.x[0]))
    var_log, held = _propagated_variance(out, E_b_est, E_e_est, fit_E_b)
    mf = model_form_variance(data, E_b_est.value, check.info, E_s, model_form)
    sd_log = float(np.sqrt(var_log + mf["var_log"]))
    E_b = float(np.exp(out.x[1])) if fit_E_b else E_b_est.value
    shares = [shear_share(b.geometry.span, E_b, E_s) for b in data]
    design = _design_note(specimen, known, E_b_est.value)
    warnings, extra_info = _checks(out, data, shares, check, sd_log, E_b, E_s, mf, design)
    left_out = [b for b in every if b not in data]
    if left_out:
        extra_info["left_out_tests"] = dict.fromkeys(
            (b.measurement.test.file.name for b in left_out), LEFT_OUT
        )
    fe = _fe_info(out, t0)
    estimates, correlation = _estimates(
        out, check, sd_log, E_b, E_s, fe, fit_E_b, known, warnings, extra_info
    )
    measured = "nose travel" if nose else "centreline deflection"
    info = {**_info(data, out, shares, held, E_s, fe), **extra_info, "measurement": measured}
    return TestFit(
        kind=KIND.name,
        specimen=specimen.id,
        tests=tuple(b.measurement.test for b in every),
        estimates=tuple(estimates),
        series=tuple(_series(b, force) for b, force in zip(data, out.problem.force, strict=True))
        + tuple(_series(b, None) for b in left_out),
        x_label="deflection [m]",
        y_label="force [N]",
        correlation=correlation,
        info=info,
    )


def _checks(out: Outcome, data, shares, check, sd_log, E_b, E_s, mf, design) -> tuple[list, dict]:
    """The fit's warnings (identifiability, precision, lack of fit, spans that disagree) and the
    figures behind them for ``info`` (with the model-form share ``mf`` and the design note)."""
    warnings = list(check.warnings)
    if "reference_kGA_N" not in check.info and max(shares) < MIN_SHEAR_SHARE:
        warnings.append(
            f"E_s is not identifiable: shear is only {100 * max(shares):.1f} % of the bend compliance"
        )
    if sd_log > 0.1:
        warnings.append(f"E_s is poorly determined: relative standard error {100 * sd_log:.0f} %")
    fit_check = lack_of_fit(out.r, out.J.shape[1], segments=[b.d.size for b in data])
    misfit = fit_check.warning(
        "The rod model of the bend",
        float(out.covariance.inflation[0]),
        "Check the window (toe, yield), the unit of the force, and the set-up (span, radii).",
    )
    warnings += [misfit] if misfit else []
    per_span = span_fits(out.problem, out.x, E_b, sorted({b.geometry.span for b in data}))
    extra_info = {"assessment": check.info, "per_span": per_span, "model_form": mf}
    extra_info["lack_of_fit"] = fit_check.as_info()
    extra_info["experiment_design"] = design
    extra_info["residual_correlation"] = {
        "rho": out.covariance.rho,
        "n_eff": out.covariance.n_eff,
        "interval_inflation": float(out.covariance.inflation[0]),
    }
    if per_span:
        extra_info["span_consistency"], warning = consistency(
            [(p["span"], p["E_s"], p["sd_log"]) for p in per_span], E_s
        )
        warnings += [warning] if warning else []
    return warnings, extra_info


def _fe_info(out: Outcome, t0: float) -> dict:
    return {
        "element": "P2",
        "elements": out.elements,
        "discretization_error": out.fe_error,
        "runtime_s": round(time.perf_counter() - t0, 4),
        "rod_solves": out.solves,
        "levels": out.levels,  # error against run time of every mesh level tried
        "interpolation": out.problem.interpolation(),
    }


def _estimates(out: Outcome, check, sd_log, E_b, E_s, fe, fit_E_b, known, warnings, extra_info):
    """E_s (its interval widened by the assessment, compared with E_s_torsion) and, with ``fit_E_b``,
    E_b and their correlation."""
    t, m = t95(out.covariance.dof), out.r.size
    est = _log_estimate("E_s", E_s, sd_log, t, m, fe)
    if check.widen > 1:
        est = replace(est, ci95=(est.ci95[0], float(est.ci95[1] * check.widen)))
    if "E_s_torsion" in known:
        extra_info["torsion_check"] = text = agreement(est, known["E_s_torsion"])
        explained = _bias_explains(check, E_s / known["E_s_torsion"].value)
        warnings += [text] if "disagree" in text and not explained else []  # one warning per fact
    estimates, correlation = [replace(est, warnings=tuple(warnings))], {}
    if fit_E_b:
        cov = out.cov_log
        estimates.append(_log_estimate("E_b", E_b, float(np.sqrt(cov[1, 1])), t, m, fe))
        correlation = {"E_s|E_b": float(cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1]))}
    return estimates, correlation


def _bias_explains(check, ratio: float) -> bool:
    """Whether the nose-travel bias already warned of (E_s at ``nose_bias_ratio`` of its value) spans
    the ratio of the bend's E_s to E_s_torsion: then their disagreement is that warning's fact, not a
    second one."""
    low, high = check.info.get("nose_bias_ratio", (1.0, 1.0))
    return check.widen > 1 and low <= ratio <= high


def _design_note(specimen: Specimen, known: Mapping[str, Estimate], E_b: float) -> str:
    """The recommendation of :func:`matid.fits.design.design` for this tube (E_s to 5 %)."""
    from matid.fits.design import design, summary  # design builds on these fits: import at use

    E_t = known.get("E_t")
    options = design(
        specimen, E_b=E_b, E_e=known["E_e"].value, E_t=E_t.value if E_t else None, precision=0.05
    )
    return "E_s to 5 %: " + summary(options, 0.05).splitlines()[-1]


def _log_estimate(name: str, value: float, sd_log: float, t: float, n: int, fe: dict) -> Estimate:
    """An estimate fitted in log space: stderr value * sd_log, interval value * exp(+-t sd_log)."""
    ci = (value * float(np.exp(-t * sd_log)), value * float(np.exp(t * sd_log)))
    return Estimate(name, value, value * sd_log, ci, n_points=n, method="cosserat-fe", extra={"fe": fe})


def _propagated_variance(out: Outcome, E_b: Estimate, E_e: Estimate, fit_E_b: bool):
    """Variance of log E_s: the fit's own plus that of the held stiffnesses (first order)."""
    Js = out.J[:, 0]
    var = float(out.cov_log[0, 0])
    held = {}
    for name, est in (("E_b", E_b), ("E_e", E_e)):
        if name == "E_b" and fit_E_b or not est.stderr:
            continue
        Jp = out.problem.sensitivity(name) * est.value  # dF/dlog p
        dlogs = -float(Js @ Jp) / float(Js @ Js)  # d log E_s / d log p
        rel = est.stderr / est.value
        held[name] = {"dlogEs_dlogp": dlogs, "contribution": abs(dlogs) * rel}
        var += (dlogs * rel) ** 2
    return var, held


def _series(b: BendData, force: np.ndarray | None) -> Series:
    """The whole file, with the model at the rows in the fit (none for a test left out)."""
    d = np.asarray(b.measurement.table["deflection"])
    y_fit, used = np.full(d.size, np.nan), np.zeros(d.size, dtype=bool)
    if force is not None:
        used = b.loading
        y_fit[used] = force  # loading rows are increasing in d (bend_window)
    where = "centreline" if b.centreline else "nose"
    label = f"{b.measurement.test.file.name} (span {1e3 * b.geometry.span:g} mm, {where})"
    return Series(label, d, np.asarray(b.measurement.table["force"]), y_fit, used)


def _info(data, out: Outcome, shares, held, E_s: float, fe: dict) -> dict:
    E_b = out.problem.params(out.x)[1]
    # force change for +10 % E_s, linearised: dF = dF/dE_s * 0.1 E_s (one back-substitution per point)
    r10 = out.r + out.problem.sensitivity("E_s") * 0.1 * E_s
    change = float(np.sqrt(np.mean((r10 - out.r) ** 2)))
    return {
        "spans_mm": [round(1e3 * b.geometry.span, 6) for b in data],
        "shear_share": [round(s, 4) for s in shares],
        "E_b_used": E_b,
        "E_e_used": out.problem.E_e,
        "timoshenko_start_N": timoshenko_start(data, out.problem.E_b),
        "noise_N": out.sigma,
        "force_change_for_10pct_E_s_N (linearised)": change,
        "sensitivity_to_noise": change / out.sigma if out.sigma > 0 else float("inf"),
        "held_stiffness_propagation": held,
        "unloading_rows_excluded": int(sum((~b.loading).sum() for b in data)),
        "rows_left_out": {b.measurement.test.file.name: b.cut.reasons for b in data if b.cut.reasons},
        "toe_offset_m": {b.measurement.test.file.name: b.cut.d0 for b in data if b.cut.d0 > 0},
        "fe": fe,
        "plot_data": _plot_data(data, out, r10),
    }


def _plot_data(data, out: Outcome, r10: np.ndarray) -> dict:
    """Arrays the report draws: Timoshenko-only curves, +10 % E_s curves, the deformed shape."""
    problem = out.problem
    E_s, E_b = problem.params(out.x)
    plus10 = np.split(r10, np.cumsum([b.d.size for b in data])[:-1])
    curves = [
        {
            "label": b.measurement.test.file.name,
            "span": b.geometry.span,
            "d": b.d,
            "F": b.F,
            "model": force,
            "timoshenko": timoshenko_force(b.d, b.geometry.span, E_b, E_s),
            "plus10": r + b.F,
            "shape": model.shape(path),
        }
        for b, r, force, path, model in zip(
            data, plus10, problem.force, problem.paths, problem.models, strict=True
        )
    ]
    return {"curves": curves, "noise_N": out.sigma}


def _fit(measurements, *, specimen: Specimen, fixed, known) -> TestFit:
    return fit_three_point_bend(measurements, specimen=specimen, fixed=fixed, known=known)


KIND = Kind(
    name="three_point_bend",
    title="Three-point bend",
    columns={"deflection": "length", "force": "force"},
    required=(("deflection",), ("force",)),
    keys=dict.fromkeys(("span", "specimen_length", "support_radius", "nose_radius"), "length"),
    options=("deflection_at",),
    positive=("force", "deflection"),
    parameters=("E_s",),
    fit=_fit,
    drawings=("bend",),
)
