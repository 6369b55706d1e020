"""Shear stiffness without the bend rig's contacts: torsion, extension, and the local compliance.

Hutchinson's (2001) shear coefficient of a hollow circle, outer radius a,
inner b (physics.md section 7):

    k = 6 (a^2 + b^2)^2 (1 + nu)^2 /
        [7a^4 + 34a^2b^2 + 7b^4 + nu (12a^4 + 48a^2b^2 + 12b^4) + nu^2 (4a^4 + 16a^2b^2 + 4b^4)]

**E_s from torsion** (docs/contract.md section 7): for a transversely isotropic
tube the shear modulus of torsion is that of transverse shear, so

    E_s_torsion = k(nu, a, b) A E_t / J,   A = pi (a^2 - b^2),  J = pi/2 (a^4 - b^4).

Other sections (contract section 10, :class:`matid.physics.moduli.Section`): a
rectangular coupon uses Cowper's (1966) rectangle coefficient k = 10 (1 + nu) /
(12 + 11 nu) with A = b h and Saint-Venant's series J; an open (slit) tube has no
closed-tube shear coefficient (its transverse shear is coupled to twist about a
shear centre off the axis), so E_s_torsion is withheld with the reason.

**Reference k G A** for the identifiability of E_s, independent of the bend
fit: E_s_torsion when there is a torsion test, else k(nu) E_e / (2 (1 + nu))
(isotropic wall, G = E/(2(1+nu)), E = E_e/A), as a range over nu.

**Local contact compliance** of the nose travel (indentation and ovalisation
of the wall under the three contacts, physics.md section 7). The point-load
deflection of a long cylindrical shell scales as P R_m^1.5 / (E t^2.5)
(R_m mid-wall radius, t wall thickness); the continuum tube of
``reference/tube3d`` (E 50 MPa, R_m 1 mm, t 0.4 mm: 0.198 mm/N for a
factor 1) measured 0.193-0.272 mm/N on the calibration spans, under-resolved
there by ~15 %, so

    c_loc = kappa R_m^1.5 / (E t^2.5),   kappa in [0.95, 1.58]

(low: the least measured, 0.193/0.198 rounded down; high: the most, 0.272 x 1.15 / 0.198).
Calibration spans: 8 and 20 mm only (the shared reference T8, T20 and benchmarks/continuum's
S8, which also gives CONTACT_N); spans 6, 10, 15 and 30 mm are kept for the acceptance
tests (tests/fits/shear/test_tube3d_acceptance.py), which never see 8 or 20 mm nose travel.
This is calibrated on one tube: it is an order of magnitude for other tubes,
good for deciding whether nose travel can identify E_s, not for correcting it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from matid.model.results import Estimate, TestFit
from matid.model.study import Specimen

#: Poisson's ratio range used when the specimen does not give one (polymers).
NU_RANGE = (0.3, 0.5)
#: Range of the local-compliance factor kappa (module docstring).
KAPPA_RANGE = (0.95, 1.58)
#: The continuum tube of ``reference/tube3d`` that calibrates kappa and the contact law
#: (benchmarks/README.md, "The 3D tube"), and the load exponent of its local contact travel,
#: u_local ~ F^CONTACT_N.
CONTACT_REF = {"E": 50e6, "R_m": 1.0e-3, "t": 0.4e-3}
CONTACT_N = 0.82


def hutchinson_k(nu: float, a: float, b: float = 0.0) -> float:
    """Hutchinson's shear coefficient of a hollow circle (module docstring)."""
    a2, b2 = a * a, b * b
    a4, b4, ab = a2 * a2, b2 * b2, a2 * b2
    den = 7 * a4 + 34 * ab + 7 * b4 + nu * (12 * a4 + 48 * ab + 12 * b4) + nu**2 * (4 * a4 + 16 * ab + 4 * b4)
    return 6.0 * (a2 + b2) ** 2 * (1.0 + nu) ** 2 / den


#: Why an open section gives no E_s_torsion, and what to measure instead.
OPEN_SECTION = (
    "E_s_torsion is not given for an open (slit) tube: the shear coefficient k of a closed tube does "
    "not apply to it (transverse shear and twist are coupled about a shear centre off the axis), and "
    "its torsion is that of a thin open wall; measure E_s in a three-point bend with centreline "
    'deflection (deflection_at = "centreline") instead'
)


def cowper_k(nu: float) -> float:
    """Cowper's (1966) shear coefficient of a rectangle, 10 (1 + nu) / (12 + 11 nu)."""
    return 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)


def shear_coefficient(nu: float, specimen: Specimen) -> float | None:
    """k of the specimen's section: Hutchinson's hollow circle, Cowper's rectangle, None when open."""
    shape = specimen.section.shape
    if shape == "slit":
        return None
    if shape == "rectangle":
        return cowper_k(nu)
    a, b = specimen.section.radii
    return hutchinson_k(nu, a, b)


def half_depths(specimen: Specimen) -> tuple[float, float]:
    """(a, b) [m]: outer and inner half-depth along the bend load (a rectangle: h/2 and 0, the
    solid rod of its depth for the contact's order of magnitude)."""
    sec = specimen.section
    return (0.5 * sec.height, 0.0) if sec.shape == "rectangle" else sec.radii


def nu_range(specimen: Specimen) -> tuple[float, float]:
    nu = specimen.poisson_ratio
    return (nu, nu) if nu is not None else NU_RANGE


def _k_range(specimen: Specimen) -> tuple[float, float]:
    ks = [shear_coefficient(nu, specimen) for nu in np.linspace(*nu_range(specimen), 11)]
    return min(ks), max(ks)


def e_s_torsion(E_t: Estimate, specimen: Specimen) -> Estimate:
    """E_s_torsion = k A E_t / J with E_t's interval and nu's range carried into it (log space).

    With nu given, k is exact; otherwise k is taken at the geometric mean of its
    range over ``NU_RANGE`` and the half range h (in log) is treated as uniform:
    stderr adds h/sqrt(3), the 95 % interval adds 0.95 h, in quadrature with E_t's.
    An open section gives no number: the estimate is withheld with :data:`OPEN_SECTION`.
    """
    if shear_coefficient(0.3, specimen) is None:
        return Estimate(
            "E_s_torsion", math.nan, None, None, n_points=E_t.n_points, method="shear-coefficient",
            withheld=OPEN_SECTION, extra={"section": specimen.section.describe()},
        )  # fmt: skip
    k_lo, k_hi = _k_range(specimen)
    k = math.sqrt(k_lo * k_hi)
    h = 0.5 * math.log(k_hi / k_lo)
    value = k * specimen.section.A * E_t.value / specimen.section.J
    sd_t = (E_t.stderr or 0.0) / E_t.value
    ci_t = math.log(E_t.ci95[1] / E_t.value) if E_t.ci95 else 1.96 * sd_t
    half = math.hypot(ci_t, 0.95 * h)
    extra = {
        "k": k,
        "k_range": [k_lo, k_hi],
        "poisson_ratio": specimen.poisson_ratio,
        "nu_range": list(nu_range(specimen)),
        "formula": _FORMULA[specimen.section.shape],
        "section": specimen.section.describe(),
    }
    return Estimate(
        "E_s_torsion",
        value,
        value * math.hypot(sd_t, h / math.sqrt(3.0)),
        (value * math.exp(-half), value * math.exp(half)),
        n_points=E_t.n_points,
        method="shear-coefficient",
        warnings=tuple(E_t.warnings),
        extra=extra,
    )


_FORMULA = {
    "tube": "k(nu, a, b) A E_t / J, Hutchinson (2001) hollow circle",
    "rectangle": "k(nu) A E_t / J, Cowper (1966) rectangle, J of Saint-Venant's series",
}


def with_E_s_torsion(fit: TestFit, specimen: Specimen) -> TestFit:
    """The torsion fit with E_s_torsion added next to E_t (docs/contract.md section 7)."""
    E_t = fit.estimate("E_t")
    if E_t is None:
        return fit
    return replace(fit, estimates=(*fit.estimates, e_s_torsion(E_t, specimen)))


def value_range(lo: float, hi: float, spec: str = "g") -> str:
    """'lo-hi' in format ``spec``, or one value when both print the same (a given Poisson ratio)."""
    a, b = format(lo, spec), format(hi, spec)
    return a if a == b else f"{a}-{b}"


def reference_kGA(known: Mapping[str, Estimate], specimen: Specimen) -> tuple[float, float, str] | None:
    """(low, high, source) of k G A from torsion or extension (module docstring); None without either."""
    est = known.get("E_s_torsion")
    if est is not None and est.ci95 and not est.withheld:
        return est.ci95[0], est.ci95[1], f"E_s_torsion = {est.value:.4g} N"
    E_e = known.get("E_e")
    if E_e is None or shear_coefficient(0.3, specimen) is None:
        return None
    lo, hi = nu_range(specimen)
    values = [shear_coefficient(nu, specimen) * E_e.value / (2 * (1 + nu)) for nu in np.linspace(lo, hi, 11)]
    return min(values), max(values), f"E_e = {E_e.value:.4g} N with nu {value_range(lo, hi)} (isotropic wall)"


def young_modulus(known: Mapping[str, Estimate], specimen: Specimen) -> float | None:
    """E of the wall from E_e / A (or 2 (1 + nu) E_t / J without an extension test)."""
    if "E_e" in known:
        return known["E_e"].value / specimen.section.A
    if "E_t" in known:
        return 2 * (1 + float(np.mean(nu_range(specimen)))) * known["E_t"].value / specimen.section.J
    return None


def local_compliance(specimen: Specimen, E: float) -> tuple[float, float]:
    """(low, high) local contact compliance of the nose travel [m/N] (module docstring)."""
    a, b = half_depths(specimen)
    t = a - b
    R_m = 0.5 * (a + b)
    base = R_m**1.5 / (E * t**2.5)
    return KAPPA_RANGE[0] * base, KAPPA_RANGE[1] * base


def agreement(E_s: Estimate, E_s_torsion: Estimate) -> str:
    """Whether the bend and torsion estimates of E_s agree within their combined uncertainty (2 sd, log)."""
    if E_s_torsion.withheld:
        return f"no comparison with torsion: {E_s_torsion.withheld}"
    sd = [(e.stderr or 0.0) / e.value for e in (E_s, E_s_torsion)]
    combined = math.hypot(*sd)
    diff = math.log(E_s.value / E_s_torsion.value)
    verdict = "agree" if abs(diff) <= 2 * combined else "disagree"
    text = (
        f"E_s from the bend ({E_s.value:.4g} N) and from torsion (E_s_torsion = {E_s_torsion.value:.4g} N) "
        f"{verdict}: the bend gives {math.exp(diff):.2g} times the torsion value (natural log of the "
        f"ratio {diff:+.2f}) against a combined relative standard error of {100 * combined:.1f} %"
    )
    if verdict == "disagree":
        text += (
            " (a braided/coiled or anisotropic wall, local contact compliance in the bend, "
            "or a wrong Poisson's ratio; the disagreement itself is the finding)"
        )
    return text
