"""The stability catalogue: each case's scene, solve, reference, tolerance, basis and expected outcome.

The references and error measures are in :mod:`matid.bench.measures`. Every case states the
outcome it must give (:class:`matid.bench.case.Expect`); the ones that must raise say where
and why: a planar magnetic cantilever pushed past buckling stops at q = q_c (load factor
q_c / q), a dead end moment in 3D at half a turn, the raw penalty at c_u >= 1e10 at round-off.
The contact cases (walls, a lumen, an advance; the impossible scenes the reader refuses) are
:func:`matid.bench.contact.cases`.
"""

from __future__ import annotations

import math

import numpy as np

from matid.bench import contact
from matid.bench import scenes as S
from matid.bench.case import FLAGGED, PENALTY_C, Q_CRIT, SOLVES, Case, raises
from matid.bench.common import tip_xz
from matid.bench.measures import (
    arc_error,
    bend_reference,
    branch_tip,
    cantilever_case,
    elastica,
    relative_error,
    spatial_tip,
    straight_error,
    tip3_error,
    tip_error,
)
from matid.bench.references import richardson, rigid_tip_magnet
from matid.rod.bend import BendModel

# -- the cases --------------------------------------------------------------------------------------

SPATIAL = "3D: precurved, tip magnet, tip force; E_s = E_e = 1e6 E_b/L^2"
BVP = "planar rod BVP with the same E_s, E_e (solve_bvp, checked by shooting)"
EXACT = "exact (round-off)"


def cases(quick: bool = False) -> list[Case]:
    """Every case (``quick``: the representative subset marked quick)."""
    every = (
        _penalty_cases()
        + _stiffness_cases()
        + _rotation_cases()
        + _bifurcation_cases()
        + _bend_cases(quick)
        + _mesh_cases()
        + _rigid_cases()
        + contact.cases()
    )
    return [c for c in every if c.quick] if quick else every


def _penalty_cases() -> list[Case]:
    scene = S.spatial(stiff=1e6)
    raw = [
        cantilever_case(
            "raw-quaternion penalty",
            f"raw q, c_u = {c_u:.0e}",
            {"scene": SPATIAL, "model": "full", "variant": "raw", "c_u (scaled)": c_u},
            scene,
            tip3_error(lambda: spatial_tip(16)),
            "normalised variant on the same mesh (isolates the penalty error)",
            solve={"model": "full", "variant": "raw", "c_u": c_u},
            tolerance=1e-3,
            penalty_c_u=c_u,
            expect=_raw_expect(c_u),
            quick=c_u in (1e2, 1e6),
            basis=f"0.1 % of L; the raw penalty's own error is <= {PENALTY_C:g}/c_u (measured ~1.4/c_u)",
        )
        for c_u in (1e2, 1e4, 1e6, 1e8, 1e10, 1e12)
    ]
    normalised = cantilever_case(
        "precurved 3D rod",
        "normalised q, default c_u",
        {"scene": SPATIAL, "model": "full", "variant": "normalised"},
        scene,
        tip3_error(lambda: richardson(spatial_tip(64), spatial_tip(128))),
        "Richardson extrapolation of the normalised variant on 64 and 128 elements",
        solve={"model": "full"},
        quick=True,
    )
    return [*raw, normalised]


def _raw_expect(c_u: float):
    """c_u = 1e2: within its own penalty error, flagged; 1e4 to 1e8: ok; from 1e10 the penalty's
    stiffness spread puts Newton's round-off floor above its tolerance at the first step."""
    if c_u < 1e3:
        return FLAGGED
    return raises(at=0.0, says="Newton stagnated") if c_u >= 1e10 else SOLVES


def _tip_force_case(family: str, name: str, E_s: float, E_e: float, quick: bool) -> Case:
    """Tip force F L^2/E_b = 2 against the planar rod BVP with the same E_s, E_e."""
    return cantilever_case(
        family,
        name,
        {"scene": "tip force F L^2/E_b = 2", "E_s L^2/E_b": E_s, "E_e L^2/E_b": E_e},
        S.tip_force(2.0, E_s=E_s, E_e=E_e),
        tip_error(lambda: elastica(2.0, E_s, E_e)),
        BVP,
        check=True,
        quick=quick,
    )


def _stiffness_cases() -> list[Case]:
    slender = [
        _tip_force_case("slenderness", f"tip force, E_s = E_e = {E:.0e}", E, E, E in (1e2, 1e10))
        for E in (1e2, 1e4, 1e6, 1e8, 1e10)
    ]
    magnetic = [
        cantilever_case(
            "slenderness",
            f"magnetic cantilever, E_s = E_e = {E:.0e}",
            {"scene": "magnetic cantilever q = 6.4, 120 deg", "E_s L^2/E_b": E, "E_e L^2/E_b": E},
            S.magnetic(6.4, 120.0, E_s=E, E_e=E),
            tip_error(lambda: elastica(q=6.4, psi_deg=120.0)),
            "elastica BVP (exact for any E_s, E_e: a uniform field exerts no force)",
            check=True,
        )
        for E in (1e2, 1e10)
    ]
    shear = [
        _tip_force_case("shear stiffness", "Kirchhoff limit, E_s = 1e12", 1e12, 1e8, False),
        _tip_force_case("shear stiffness", "soft shear, E_s = 1", 1.0, 1e4, True),
    ]
    return slender + magnetic + shear


def _rotation_cases() -> list[Case]:
    return [
        cantilever_case(
            "large rotation",
            f"end moment, tip at {360 * turns:.0f} deg ({model})",
            {"scene": "pure end moment", "M L/E_b": 2 * math.pi * turns, "model": model},
            S.end_moment(turns),
            arc_error(turns),
            "closed form (circular arc), largest nodal error",
            solve={"model": model},
            check=model == "auto",
            tolerance=1e-4,
            basis="P2 at 16 elements: 3e-6 per turn^4 (convergence section, circle); factor >= 10",
            expect=SOLVES if model == "auto" else raises(at=0.5 / turns, says="dead moment in 3D"),
            quick=quick,
        )
        for turns, model, quick in (
            (0.625, "auto", True),
            (1.0, "auto", False),
            (1.5, "auto", False),
            (1.0, "full", False),
        )
    ]


def _bifurcation_cases() -> list[Case]:
    near = [
        cantilever_case(
            "near bifurcation",
            f"field 179.5 deg, q = {factor:g} q_c",
            {"scene": "magnetic cantilever", "q": factor * Q_CRIT, "q_c": Q_CRIT, "field angle (deg)": 179.5},
            S.magnetic(factor * Q_CRIT, 179.5),
            tip_error(lambda q=factor * Q_CRIT: branch_tip(q, 179.5)),
            "elastica, first-mode branch towards +x (shooting scan, checked by solve_bvp); "
            "stability: tangent eigenvalues",
            check=True,
            quick=quick,
        )
        for factor, quick in ((0.95, False), (1.05, True))
    ]
    q = 1.2 * Q_CRIT
    reversal = [
        cantilever_case(
            "field reversal",
            "field 180 deg, q = 0.9 q_c",
            {"scene": "magnetic cantilever", "q": 0.9 * Q_CRIT, "field angle (deg)": 180.0},
            S.magnetic(0.9 * Q_CRIT, 180.0),
            tip_error(lambda: np.array([0.0, 1.0])),
            "the straight rod (stable below q_c)",
            check=True,
        ),
        cantilever_case(
            "field reversal",
            "field 180 deg, q = 1.2 q_c",
            {"scene": "magnetic cantilever", "q": q, "field angle (deg)": 180.0},
            S.magnetic(q, 180.0),
            lambda sol: float(
                min(np.linalg.norm(tip_xz(sol, S.L) - branch_tip(q, 180.0) * [sign, 1.0]) for sign in (1, -1))
            ),
            "the buckled state (either mirror image; elastica, shooting scan): the straight "
            "rod is an equilibrium but unstable beyond q_c",
            check=True,
            expect=raises(at=Q_CRIT / q, says="unstable equilibrium"),
            quick=True,
        ),
    ]
    return near + reversal


def _bend_cases(quick: bool) -> list[Case]:
    E, n_ref = S.BEND_E, (128 if quick else 512)
    d = (0.0005, 0.001, 0.0015, 0.002)
    model = BendModel(S.bend_geometry(), elements=24)
    slip = BendModel(S.bend_geometry(0.0105), elements=24)
    path = tuple(np.linspace(0.0005, 0.012, 24))
    return [
        Case(
            "three-point bend",
            "to 20 % of the span (d = 2 mm)",
            {"span (mm)": 10, "specimen (mm)": 30, "deflections (mm)": [1e3 * v for v in d], "elements": 24},
            lambda: model.solve(*E, d),
            lambda p: relative_error(p.force, bend_reference(n_ref, 0.03, d)),
            f"Richardson extrapolation of BendModel on {n_ref} and {2 * n_ref} elements",
            tolerance=1e-4,
            basis="relative force; 24 elements give ~1e-6 (convergence section); factor 100",
            quick=True,
        ),
        Case(
            "three-point bend",
            "until slip-off (specimen 10.5 mm on a 10 mm span)",
            {
                "span (mm)": 10,
                "specimen (mm)": 10.5,
                "deflections (mm)": "0.5 ... 12 (24 steps)",
                "elements": 24,
            },
            lambda: slip.solve(*E, path),
            None,
            "SlipOffError expected (a ConvergenceError subclass); converging to 12 mm would be wrong",
            tolerance=None,
            basis="must raise",
            expect=raises("SlipOffError", says="slips off"),
            quick=True,
        ),
    ]


def _mesh_cases() -> list[Case]:
    magnetic = "magnetic cantilever q = 6.4"
    mag_ref = tip_error(lambda: elastica(q=6.4, psi_deg=120.0))
    zero = [
        cantilever_case(
            "zero load",
            "no field (planar)",
            {"scene": "magnetic cantilever, q = 0"},
            S.magnetic(0.0, 120.0),
            straight_error,
            "the straight rod",
            check=True,
            tolerance=1e-12,
            basis=EXACT,
            quick=True,
        ),
        cantilever_case(
            "zero load",
            "no load (full model)",
            {"scene": "tip force 0", "model": "full"},
            S.tip_force(0.0),
            straight_error,
            "the straight rod",
            solve={"model": "full"},
            tolerance=1e-12,
            basis=EXACT,
        ),
    ]
    single = cantilever_case(
        "mesh extremes",
        "a single element",
        {"scene": magnetic},
        S.magnetic(6.4, 120.0),
        mag_ref,
        "elastica BVP",
        elements=1,
        tolerance=0.1,
        basis="P2 error at 2 elements is 3e-3 and grows ~h^4: one element may be off by a few %",
        quick=True,
    )
    many = [
        cantilever_case(
            "mesh extremes",
            f"10^4 elements, E_s = E_e = 1e{math.log10(E):.0f}",
            {"scene": magnetic, "E_s L^2/E_b": E},
            S.magnetic(6.4, 120.0, E_s=E, E_e=E),
            mag_ref,
            "elastica BVP",
            elements=10_000,
            tolerance=1e-6,
            basis=f"discretisation error ~1e-16: only round-off (condition ~E h^-2{condition})",
            timeout_s=timeout,
        )
        for E, condition, timeout in ((1e6, "", None), (1e8, " = 1e16", 90.0))
    ]
    return [*zero, single, *many]


def _rigid_cases() -> list[Case]:
    ref = rigid_tip_magnet(0.9, 0.1, 2.0, math.radians(120.0))[:2]
    planar = [
        cantilever_case(
            "rigid segment",
            f"rigid magnet body, E_s = E_e = {stiff:.0e}, {n} elements",
            {
                "scene": "tip magnet m B L/E_b = 2 at 120 deg in a rigid body over the last 10 %",
                "E_s L^2/E_b": stiff,
                "E_e L^2/E_b": stiff,
            },
            S.rigid_tip_magnet(stiff=stiff),
            tip_error(lambda: ref),
            "closed form: arc under the magnet's torque, then the straight rigid body",
            elements=n,
            check=True,
            quick=quick,
            basis="10 x the rigid body's own compliance (matid.rod.cantilever.RIGID_FACTOR = 1e6: ~1e-6)",
        )
        for stiff, n, quick in ((1e4, 16, False), (1e8, 16, True), (1e8, 64, False))
    ]
    spatial = [
        cantilever_case(
            "rigid segment",
            f"3D, rigid magnet body, E_s = E_e = {stiff:.0e}",
            {
                "scene": "3D: precurved, tip magnet in a rigid body (last 10 %), tip force",
                "E_s L^2/E_b": stiff,
                "model": "full",
            },
            S.spatial(stiff=stiff, rigid=True),
            tip3_error(lambda stiff=stiff: spatial_tip(48, stiff, True)),
            "the same scene on 48 elements (self-convergence: no independent 3D reference)",
        )
        for stiff in (1e3, 1e6)
    ]
    return planar + spatial
