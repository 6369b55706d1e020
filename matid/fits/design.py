"""Experiment design for E_s: which spans and which measurement identify it to a given precision.

For a tube of known section, E_b and E_e (or E_t), the predicted relative
standard deviation of E_s from one three-point bend at span S combines, in
quadrature (Timoshenko compliance C = S^3/(48 E_b) + S/(4 E_s), shear share
phi = (S/4E_s)/C, d ln E_s = -d ln C_shear = -d ln C / phi):

- E_b's uncertainty:    (1 - phi)/phi * sd(E_b)/E_b;
- force noise:          r / (phi sqrt(n/3)), r = noise sd / largest force, n rows
                        (the slope of n evenly spaced rows through the origin);
- model form:           delta/phi, delta = 0.01 + 0.2 d_max/S (rod against continuum,
                        :func:`matid.fits.shear.checks.model_form_variance`).

Nose travel adds the local contact compliance c_loc
(:func:`matid.fits.shear.torsion.local_compliance`), which the rod model does
not have: E_s,fit / E_s = c_s/(c_s + c_loc), a bias, not noise. A nose-travel
span qualifies only when that bias, at the unfavourable end of its predicted
range, is within the precision. Everything uses a reference k G A from torsion
or extension (:func:`matid.fits.shear.torsion.reference_kGA`), never a bend fit.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from matid.errors import FitError
from matid.fits.shear.checks import MODEL_FORM_FLOOR, MODEL_FORM_SLOPE, nose_ratio, shear_share
from matid.fits.shear.torsion import e_s_torsion, local_compliance, reference_kGA, young_modulus
from matid.model.results import Estimate
from matid.model.study import Specimen

SPANS = (0.006, 0.008, 0.010, 0.015, 0.020, 0.030)


@dataclass(frozen=True)
class Option:
    """One span and measurement: predicted shear share, relative sd of E_s, nose bias range."""

    span: float
    measurement: str  # "centreline" or "nose"
    share: float
    rel_sd: float
    bias: tuple[float, float]  # (low, high) relative error of E_s from the local compliance (0 centreline)
    ok: bool


def design(
    specimen: Specimen,
    *,
    E_b: float,
    E_e: float | None = None,
    E_t: float | None = None,
    precision: float = 0.05,
    spans: Sequence[float] = SPANS,
    rel_sd_E_b: float = 0.01,
    noise: float = 0.003,
    rows: int = 20,
    d_over_S: float = 0.02,
) -> list[Option]:
    """Every span x measurement with its predicted precision (module docstring)."""
    known = {}
    if E_e:
        known["E_e"] = Estimate("E_e", E_e, 0.0, None, 0, "given")
    if E_t:
        known["E_t"] = Estimate("E_t", E_t, 0.0, (E_t, E_t), 0, "given")
        known["E_s_torsion"] = e_s_torsion(known["E_t"], specimen)
    ref = reference_kGA(known, specimen)
    if ref is None:
        raise FitError("experiment design for E_s needs E_e or E_t besides E_b")
    kGA_lo, kGA_hi, _ = ref
    kGA = math.sqrt(kGA_lo * kGA_hi)
    c_loc = local_compliance(specimen, young_modulus(known, specimen))
    delta = MODEL_FORM_FLOOR + MODEL_FORM_SLOPE * d_over_S
    out = []
    for S in spans:
        phi = shear_share(S, E_b, kGA)
        sd = math.hypot((1 - phi) / phi * rel_sd_E_b, noise / (phi * math.sqrt(rows / 3)), delta / phi)
        out.append(Option(S, "centreline", phi, sd, (0.0, 0.0), sd <= precision))
        bias = (nose_ratio(S, kGA_lo, c_loc[0]) - 1, nose_ratio(S, kGA_hi, c_loc[1]) - 1)
        out.append(Option(S, "nose", phi, sd, bias, sd <= precision and abs(bias[1]) <= precision))
    return out


def summary(options: Sequence[Option], precision: float) -> str:
    """A compact table and the recommendation."""
    lines = [f"{'span':>8}  {'measurement':<11} {'shear share':>11} {'sd(E_s)':>8} {'nose bias':>14}  ok"]
    for o in options:
        bias = f"{100 * o.bias[1]:+.0f}..{100 * o.bias[0]:+.0f} %" if o.measurement == "nose" else "-"
        lines.append(
            f"{1e3 * o.span:>5g} mm  {o.measurement:<11} {100 * o.share:>10.1f}% {100 * o.rel_sd:>7.1f}% "
            f"{bias:>14}  {'yes' if o.ok else 'no'}"
        )
    good = [o for o in options if o.ok]
    if not good:
        lines.append(
            f"No span identifies E_s to {100 * precision:g} %: use E_s_torsion (torsion test) or "
            "measure E_b more precisely."
        )
        return "\n".join(lines)
    best = min(good, key=lambda o: o.rel_sd)
    nose = [o for o in good if o.measurement == "nose"]
    lines.append(
        f"Best: {best.measurement} deflection at {1e3 * best.span:g} mm (sd {100 * best.rel_sd:.1f} %); "
        + (
            "nose travel also qualifies at " + ", ".join(f"{1e3 * o.span:g} mm" for o in nose)
            if nose
            else "nose travel does not qualify at any span (local contact compliance)"
        )
        + "; two or more spans also test the consistency of the model."
    )
    return "\n".join(lines)
