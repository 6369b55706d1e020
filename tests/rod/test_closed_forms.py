"""The rod solver against the closed forms of physics.md section 5, and its order of convergence.

References are computed here, independently of the solver: the circle, the tip
magnet's scalar equation (brentq), the elastica by shooting (DOP853 + brentq),
the Timoshenko beam. "Stiff" rods have E_s = E_e = 1e8 E_b / L^2 so that the
inextensible, unshearable answers apply to well below the tolerances.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from matid.errors import ConvergenceError, SlipOffError
from matid.rod import BendGeometry, BendModel, solve
from matid.rod.scenes import scene_from_dict

L, EB, ET = 0.03, 6.5e-5, 4.4e-5
STIFF = 1e8 * EB / L**2


def rod(**overrides) -> dict:
    return {"length": L, "E_b": EB, "E_t": ET, "E_s": STIFF, "E_e": STIFF, **overrides}


def tip_angle(sol) -> float:
    """Angle of d3 at the tip from +z towards +x (planar scenes in the x-z plane)."""
    d3 = sol.d3[-1]
    return float(np.arctan2(d3[0], d3[2]))


def field(B: float, psi: float) -> dict:
    return {"B": [B * np.sin(psi), 0.0, B * np.cos(psi)]}


# -- exact answers ----------------------------------------------------------------


@pytest.mark.parametrize(("model", "elements", "tol"), [("planar", 16, 1e-8), ("full", 32, 1e-8)])
def test_pure_end_moment_bends_a_circle(model, elements, tol):
    theta = 1.0
    sol = solve(
        scene_from_dict({"rod": rod(), "tip": {"moment": [0.0, theta * EB / L, 0.0]}}),
        elements=elements,
        model=model,
    )
    exact = np.array([(1 - np.cos(theta)) / theta, 0.0, np.sin(theta) / theta])
    assert sol.model == model
    # measured: planar 3.0e-9 (16 elements), full 4.3e-10 (32); P2 tip error ~ h^4
    assert np.max(np.abs(sol.position[-1] / L - exact)) / np.linalg.norm(exact) < tol
    assert tip_angle(sol) == pytest.approx(theta, abs=1e-8)


@pytest.mark.parametrize("psi_deg", [30, 90, 150, 179])
def test_tip_magnet_matches_its_scalar_equation(psi_deg):
    """theta = (m B L / E_b) sin(psi - theta); with k = 2 the root in (0, psi) is unique and stable."""
    k, B, psi = 2.0, 0.02, np.radians(psi_deg)
    exact = brentq(lambda t: t - k * np.sin(psi - t), 0.0, psi, xtol=1e-15)
    scene = scene_from_dict(
        {"rod": rod(), "magnet": [{"at": L, "moment": k * EB / (B * L)}], "field": field(B, psi)}
    )
    sol = solve(scene, elements=4)
    assert sol.model == "planar"
    assert tip_angle(sol) == pytest.approx(exact, abs=1e-6)  # measured: 2e-15 (a pure couple: theta linear)


def test_magnetic_cantilever_benchmark():
    """Distributed magnetisation, q = mu B L^2 / E_b = 6.4, field at 120 deg."""
    B, psi = 0.04, np.radians(120)
    scene = scene_from_dict(
        {
            "rod": rod(),
            "field": field(B, psi),
            "magnetization": [{"from": 0.0, "to": L, "per_length": 6.4 * EB / (B * L**2)}],
        }
    )
    sol = solve(scene, elements=16)
    assert np.degrees(tip_angle(sol)) == pytest.approx(98.636, abs=5e-4)
    x, _, z = sol.position[-1] / L
    assert (round(x, 5), round(z, 5)) == (0.83419, 0.29063)


@pytest.mark.parametrize("model", ["planar", "full"])
def test_axial_pull_stretches_by_PL_over_E_e(model):
    P, E_e = 0.5, 120.0
    scene = scene_from_dict({"rod": rod(E_s=21.0, E_e=E_e), "tip": {"force": [0.0, 0.0, P]}})
    sol = solve(scene, elements=2, model=model)
    assert sol.position[-1][2] - L == pytest.approx(P * L / E_e, rel=1e-10)
    assert np.max(np.abs(sol.position[:, :2])) < 1e-15


def test_torsion_twists_by_TL_over_E_t():
    phi = 0.5
    scene = scene_from_dict({"rod": rod(E_s=21.0, E_e=120.0), "tip": {"moment": [0.0, 0.0, phi * ET / L]}})
    sol = solve(scene, elements=8)
    assert sol.model == "full"  # a twisting moment leaves every plane
    d1 = sol.d1[-1]
    assert np.arctan2(d1[1], d1[0]) == pytest.approx(phi, abs=1e-8)  # measured 4e-9 (8 elements)
    assert np.max(np.abs(sol.position[-1] - [0.0, 0.0, L])) < 1e-15


def elastica_tip(alpha: float) -> tuple[float, float]:
    """Tip (x, z)/L of the inextensible cantilever under a dead tip force perpendicular to it.

    theta'' = -alpha cos(theta), theta(0) = 0, theta'(1) = 0, by shooting on theta'(0).
    """

    def rhs(_, y):
        return [y[1], -alpha * np.cos(y[0]), np.sin(y[0]), np.cos(y[0])]

    def end(c):
        ivp = solve_ivp(rhs, (0.0, 1.0), [0.0, c, 0.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-14)
        return ivp.y[:, -1]

    c = brentq(lambda c: end(c)[1], 1e-9, alpha, xtol=1e-15)
    y = end(c)
    return float(y[2]), float(y[3])


@pytest.mark.parametrize(("alpha", "table"), [(1, 0.30172), (2, 0.49346), (5, 0.71379), (10, 0.81061)])
def test_large_deflection_cantilever_bisshopp_drucker(alpha, table):
    x_ref, z_ref = elastica_tip(alpha)
    assert x_ref == pytest.approx(table, abs=1e-5)  # Bisshopp & Drucker's vertical deflection
    sol = solve(scene_from_dict({"rod": rod(), "tip": {"force": [alpha * EB / L**2, 0.0, 0.0]}}), elements=16)
    x, _, z = sol.position[-1] / L
    assert abs(x - x_ref) < 1e-5 and abs(z - z_ref) < 1e-5  # measured <= 1.3e-6 (alpha = 10)


def test_small_three_point_bend_is_timoshenko():
    """d = F S^3 / (48 E_b) + F S / (4 E_s) as d -> 0; the rest is the contact rolling on the supports."""
    S, E_s, E_e = 0.01, 21.0, 120.0
    model = BendModel(BendGeometry(S, 0.03, 0.002, 0.002, 0.0024), elements=12)

    def relative_excess(d):
        F = model.solve(EB, E_s, E_e, [d]).force[-1]
        return F / (d / (S**3 / (48 * EB) + S / (4 * E_s))) - 1

    excess = relative_excess(1e-7)
    assert abs(excess) < 1e-4  # measured 2.68e-5
    # the excess is linear in d (the contact points roll towards mid-span): the limit is exact
    assert relative_excess(1e-8) == pytest.approx(excess / 10, rel=1e-3)


# -- convergence ------------------------------------------------------------------


def observed_orders(values: list[np.ndarray], reference: np.ndarray) -> np.ndarray:
    errors = np.array([np.max(np.abs(v - reference)) for v in values])
    return np.log2(errors[:-1] / errors[1:])


def test_tip_force_cantilever_converges_at_order_four():
    scene = scene_from_dict({"rod": rod(), "tip": {"force": [5 * EB / L**2, 0.0, 0.0]}})
    tips = [solve(scene, elements=n).position[-1] / L for n in (4, 8, 16, 256)]
    orders = observed_orders(tips[:-1], tips[-1])
    assert np.all(orders > 3.5), orders  # measured 3.9, 4.1 (P2, two-point Gauss, at the vertices)


def test_bend_force_converges_at_order_four():
    """Nose force at d = 10 % of the span; meshes nested (6k elements put the support on vertex 2k)."""
    model = BendGeometry(0.01, 0.03, 0.002, 0.002, 0.0024)
    forces = [BendModel(model, elements=n).solve(EB, 21.0, 120.0, [1e-3]).force for n in (6, 12, 24, 384)]
    orders = observed_orders(forces[:-1], forces[-1])
    assert np.all(orders > 3.5), orders  # measured 3.93, 3.98


def test_planar_and_full_models_agree():
    k, B, psi = 2.0, 0.02, np.radians(120)
    scene = scene_from_dict(
        {
            "rod": rod(E_s=1e4 * EB / L**2, E_e=1e4 * EB / L**2),
            "magnet": [{"at": L, "moment": k * EB / (B * L)}],
            "field": field(B, psi),
        }
    )
    planar, full = solve(scene, elements=16), solve(scene, elements=16, model="full")
    assert (planar.model, full.model) == ("planar", "full")
    assert np.max(np.abs(planar.position - full.position)) / L < 1e-7  # measured 3.3e-8
    assert np.max(np.abs(planar.d1 - full.d1)) < 1e-7


# -- what must fail -----------------------------------------------------------------


def test_antiparallel_field_beyond_buckling_has_no_stable_answer():
    """Field exactly against the magnet, m B L / E_b = 2: the straight rod is an equilibrium but
    unstable past load factor 1/2 (the Euler-like buckling load), and no other state is reached by
    continuation. The solver must say so, not return the saddle."""
    k, B = 2.0, 0.02
    scene = scene_from_dict(
        {"rod": rod(), "magnet": [{"at": L, "moment": k * EB / (B * L)}], "field": {"B": [0.0, 0.0, -B]}}
    )
    with pytest.raises(ConvergenceError, match="unstable equilibrium") as info:
        solve(scene, elements=4)
    assert info.value.load_factor == pytest.approx(0.5, abs=1e-4)


def test_nearly_antiparallel_field_follows_the_stable_branch():
    """At 179 deg Newton from the straight rod also converges to theta = -2 deg, an unstable
    equilibrium; the continuation must reject it and reach the stable root near 108 deg."""
    k, B, psi = 2.0, 0.02, np.radians(179)
    scene = scene_from_dict(
        {"rod": rod(), "magnet": [{"at": L, "moment": k * EB / (B * L)}], "field": field(B, psi)}
    )
    assert np.degrees(tip_angle(solve(scene, elements=4))) == pytest.approx(108.21, abs=0.01)


def test_short_specimen_slips_off_its_supports():
    """0.1 mm of overhang on sharp supports: the ends reach the supports near d = 2.8 mm."""
    model = BendModel(BendGeometry(0.01, 0.0102, 0.0, 0.0, 0.0024), elements=8)
    with pytest.raises(SlipOffError, match="slips off") as info:
        model.solve(EB, 21.0, 120.0, [1e-3, 4e-3])
    assert info.value.deflection == pytest.approx(2.796e-3, rel=1e-3)


@pytest.mark.filterwarnings("ignore:invalid value:RuntimeWarning")  # a rejected iterate through a centre
def test_long_steps_past_sharp_supports_do_not_cross_them():
    """Contact held by |r - c| = rho also holds on the far side of a cylinder: with rho = 0.5 mm and
    0.5 mm deflection steps Newton used to land there (a pulling contact, ConvergenceError)."""
    model = BendModel(BendGeometry(0.01, 0.03, 0.0, 0.0, 0.001), elements=8)
    coarse = model.solve(EB, 21.0, 120.0, np.linspace(0.5e-3, 6e-3, 12))
    fine = model.solve(EB, 21.0, 120.0, np.linspace(0.1e-3, 6e-3, 60))
    assert np.all(coarse.force > 0)
    assert coarse.force[-1] == pytest.approx(fine.force[-1], rel=1e-9)
