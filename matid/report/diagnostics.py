"""Fit diagnostics in words: the lack-of-fit test with its rule, the model choice, a glossary.

The lack-of-fit decision is the fit's (:class:`matid.fits.stats.LackOfFit`: a misfit when
the reduced chi-square exceeds ``MISFIT_CHI2`` *and* the residuals are serially dependent:
the sign-runs p-value is below ``MISFIT_RUNS_P`` or the lag-1 autocorrelation's below
``MISFIT_LAG1_P``); the report prints that rule beside the statistics so the decision can
be read off them (reduced chi-square 5.6 with runs p = 0.0014 and lag-1 r = 0.69 over 30
rows, p = 3e-5, is a misfit by the lag-1 test). Nothing is decided here.
"""

from __future__ import annotations

from collections.abc import Mapping

from matid.fits.stats import MIN_POINTS, MISFIT_CHI2, MISFIT_LAG1_P, MISFIT_RUNS_P
from matid.report.quantities import Nested, fmt
from matid.units import UNIT_SYSTEMS

LACK_OF_FIT_KEYS = ("reduced_chi2", "runs", "runs_expected", "runs_p", "misfit")


def glossary(units: str = "SI") -> tuple[tuple[str, str], ...]:
    """Terms of the report, explained once (the glossary at the end), stiffnesses in ``units``."""
    force, bending, viscosity = (
        UNIT_SYSTEMS[units][k][0] for k in ("force", "bending_stiffness", "viscosity")
    )
    return (
        ("use it / check it / not identifiable", "the status of a value: no warning applies / a warning "
         "applies, read it / the data do not determine the value, so none is given"),
        ("95 % interval", "the range that holds the value with 95 % confidence given the fit and its noise"),
        ("± standard error (1σ)", "one standard deviation of the estimate; about 68 % confidence"),
        ("E_e", f"axial stiffness E A [{force}]"),
        ("E_b", f"bending stiffness E I [{bending}]"),
        ("E_t", f"torsional stiffness G J [{bending}]"),
        ("E_s", f"shear stiffness k G A [{force}] from a three-point bend"),
        ("E_s_torsion", f"shear stiffness k G A [{force}] from the torsion test and the section's shear "
         "coefficient"),
        ("sls_k1, sls_k2, sls_eta", f"standard linear solid: equilibrium spring k1 = E_e [{force}], "
         f"arm spring k2 [{force}], arm dashpot eta [{viscosity}]; relaxation time τ = eta / k2 [s]"),
        ("reduced χ²", "(residual rms / point-to-point noise)²: about 1 when the model describes the data"),
        ("runs test", "counts stretches of residuals of one sign; far fewer than expected (small p) means a "
         "systematic misfit"),
        ("lag-1 autocorrelation", "correlation of each residual with the next: near 0 for independent noise"),
        ("effective number of points", "points counted as independent after the residuals' correlation"),
        ("BIC, AIC", "Bayesian and Akaike information criteria: the model with the lower value is preferred"),
        ("tare offset", "a constant offset of the measured force or torque, fitted and reported"),
    )  # fmt: skip


def lack_of_fit_table(lof: Mapping) -> Nested | None:
    """The lack-of-fit statistics with the rule each is judged by, and the fit's decision."""
    if not all(k in lof for k in LACK_OF_FIT_KEYS):
        return None
    chi2, p, misfit = float(lof["reduced_chi2"]), float(lof["runs_p"]), bool(lof["misfit"])
    p1 = float(lof.get("lag1_p", 1.0))
    serial = p < MISFIT_RUNS_P or p1 < MISFIT_LAG1_P
    both = chi2 > MISFIT_CHI2 and serial
    reasons = (
        f"reduced χ² {fmt(chi2, 3)} is {'above' if chi2 > MISFIT_CHI2 else 'not above'} {MISFIT_CHI2:g}, "
        f"runs p {fmt(p, 2)} is {'below' if p < MISFIT_RUNS_P else 'not below'} {MISFIT_RUNS_P:g}"
    )
    if "lag1_p" in lof:
        reasons += f", lag-1 p {fmt(p1, 2)} is {'below' if p1 < MISFIT_LAG1_P else 'not below'} {MISFIT_LAG1_P:g}"
    if misfit != both:  # the fit could not decide (too few residuals)
        reasons = f"fewer than {MIN_POINTS} residuals: not decided"
    rows = [
        ("reduced χ² against the residuals' point-to-point noise", fmt(chi2, 3),
         f"above {MISFIT_CHI2:g}: residuals larger than the noise"),
        ("runs of one sign, observed / expected", f"{int(lof['runs'])} / {float(lof['runs_expected']):.0f}",
         "fewer than expected: residuals run in stretches"),
        ("p-value of the runs test", fmt(p, 2), f"below {MISFIT_RUNS_P:g}: the stretches are systematic"),
    ]  # fmt: skip
    if "lag1_autocorrelation" in lof:
        lag1 = fmt(float(lof["lag1_autocorrelation"]), 2)
        rows.append(("lag-1 autocorrelation", lag1, "near 0: independent"))
    if "lag1_p" in lof:
        rows.append(("p-value of the lag-1 test", fmt(p1, 2),
                     f"below {MISFIT_LAG1_P:g}: neighbouring residuals are alike (the runs test, which "
                     "sees only signs, misses this on short records)"))  # fmt: skip
    rows.append(("misfit (χ² and either test)", "yes" if misfit else "no", reasons))
    return Nested(("statistic", "value", "indicates a misfit when"), tuple(rows))


def model_choice_table(choice: Mapping) -> Nested | None:
    """The relaxation models compared (1, 2 ... arms) by BIC and AIC, the chosen one marked."""
    models = {k: v for k, v in choice.items() if isinstance(v, Mapping) and {"bic", "aic"} <= v.keys()}
    if not models:
        return None
    chosen = choice.get("arms_preferred")
    rows = []
    for name, item in models.items():
        arms = name.split(" ")[0]
        mark = "chosen (lowest BIC)" if str(arms) == str(chosen) else ""
        rss = fmt(float(item["rss_weighted"]), 4) if "rss_weighted" in item else "—"
        rows.append((f"{name} (SLS)" if arms == "1" else f"{name} (Prony series)", fmt(float(item["bic"]), 4),
                     fmt(float(item["aic"]), 4), rss, mark))  # fmt: skip
    return Nested(("model", "BIC", "AIC", "weighted residual sum of squares", ""), tuple(rows))
