"""The contact reference (tests/rod/contact_reference.py) against answers it does not compute itself:
the elastica with its tip on a wall in incomplete elliptic integrals, the propped cantilever of beam
theory (with its observed order as the load goes to zero), a discrete energy minimiser with the walls
as inequality constraints (its own model, converging at its own order), and the 3D director
shooting of tests/rod/reference.py for a tube in a straight lumen."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import minimize

from tests.rod import contact_reference as cr
from tests.rod import reference

EB, L, R_O = 6.5e-5, 0.03, 1.2e-3


# -- the elastica with its tip on a wall: shooting against elliptic integrals ----------------------


def _tip_on_wall_case(k, xi_L, gamma, inflections, length=L):
    """Tip data on the orbit (k, xi_L) of the first integral, scaled to a rod of ``length``: with
    omega = sqrt(P/E_b), sin(phi_L/2) = k sin xi_L and phi'_L = 2 omega k cos xi_L."""

    def closed(omega):
        phi_L = 2 * math.asin(k * math.sin(xi_L))
        M_L = EB * 2 * omega * k * math.cos(xi_L)
        return (
            cr.elastica_tip_on_wall(EB, EB * omega**2, gamma, phi_L + gamma, M_L, inflections),
            phi_L + gamma,
            M_L,
        )

    omega = closed(1.0)[0]["L"] / length  # L scales as 1/omega on one orbit
    cf, theta_L, M_L = closed(omega)
    return cf, EB * omega**2, theta_L, M_L


@pytest.mark.parametrize(
    ("k", "xi_L", "gamma", "inflections"),
    [
        (0.85, 0.0, math.pi / 2, 0),  # tip at 90 deg to the clamp, pressed on a wall parallel to it
        (0.75, -0.25, math.pi / 2, 0),
        (0.75, -0.31, math.pi / 2, 1),  # the clamp moment opposes the tip couple: an inflection
        (0.8, -0.16, math.pi / 2, 1),
        (0.65, -0.6, math.pi / 2 - 0.3, 1),  # an oblique wall facing the clamp
        (0.85, -0.3, math.pi / 2 - 0.3, 0),
    ],
)
def test_tip_on_a_wall_matches_the_elliptic_integral_closed_form(k, xi_L, gamma, inflections):
    cf, P, theta_L, M_L = _tip_on_wall_case(k, xi_L, gamma, inflections)
    assert cf["L"] == pytest.approx(L, rel=1e-12)
    normal = -np.array([math.sin(gamma), math.cos(gamma)])  # the force on the tip is P * normal
    point = cf["tip"] - R_O * normal  # the wall R_o beyond the tip's centreline
    psi = theta_L + 0.8
    m = 0.01
    B = M_L / (m * math.sin(psi - theta_L))  # m |B| sin(psi - theta_L) = M_L
    out = cr.solve_planar_contact(
        L, EB, R_O, [(point, normal)], B=(B * math.sin(psi), B * math.cos(psi)), m=m, contacts=[("tip", 0)]
    )
    # measured: every difference below 3e-13 (relative to P, L, E_b/L)
    assert out["converged"] and out["admissible"], out["violations"]
    assert abs(out["contacts"][0]["force"] / P - 1) < 1e-8
    assert np.max(np.abs(out["tip"] - cf["tip"])) < 1e-8 * L
    assert abs(out["theta_L"] - theta_L) < 1e-8
    assert abs(out["m0"] - cf["m0"]) < 1e-8 * EB / L
    # the branch is the one asked for: the clamp moment has the tip couple's sign iff no inflection
    assert (cf["m0"] * M_L < 0) == (inflections == 1)
    assert np.max(np.abs(out["tip"])) > 0.05 * L and abs(theta_L) > 0.3  # large deflection


def test_the_closed_form_tip_is_the_integral_of_its_shape():
    """The elliptic-integral tip against the first integral integrated by quadrature:
    ds = dtheta / theta', theta' = +-sqrt(2 (P cos(theta - gamma) + C) / E_b), on either side of the
    inflection (a check of the closed form's algebra, independent of the shooting)."""
    from scipy.integrate import quad

    cf, P, theta_L, M_L = _tip_on_wall_case(0.75, -0.31, math.pi / 2, 1)
    gamma = math.pi / 2
    C = M_L**2 / (2 * EB) - P * math.cos(theta_L - gamma)
    theta_min = gamma - math.acos(-C / P)  # theta' = 0 at the inflection (below gamma here)

    def rate(t):
        return math.sqrt(max(2 * (P * math.cos(t - gamma) + C) / EB, 0.0))

    def leg(b):  # theta from theta_min to b, theta = theta_min + u^2 removes the 1/sqrt singularity
        def f(u, g):
            t = theta_min + u * u
            return (
                g(t) * 2 * u / rate(t)
                if u > 0
                else g(t) * 2 / math.sqrt(2 * P * math.sin(gamma - theta_min) / EB)
            )

        ub = math.sqrt(b - theta_min)
        return np.array(
            [
                quad(f, 0.0, ub, args=(g,), epsabs=1e-15, epsrel=1e-13)[0]
                for g in (lambda t: 1.0, math.sin, math.cos)
            ]
        )

    # the clamp (theta = 0) back down to theta_min, then up to theta_L: ds = |dtheta| / |theta'|
    down, up = leg(0.0), leg(theta_L)
    length = down[0] + up[0]
    tip = down[1:] + up[1:]
    assert abs(length - cf["L"]) < 1e-9 * L
    assert np.max(np.abs(tip - cf["tip"])) < 1e-9 * L


# -- the propped cantilever in the small-deflection limit ------------------------------------------


@pytest.mark.parametrize(("alpha_deg", "order"), [(0.0, 2.0), (30.0, 1.0)])
@pytest.mark.parametrize("a_over_L", [0.5, 0.3])
def test_propped_cantilever_reaction_converges_to_beam_theory(alpha_deg, order, a_over_L):
    """A point load P at a, the tip on a frictionless support (a wall through the tip whose normal is
    -e1 tilted by alpha towards the clamp). The transverse reaction R tends to P a^2 (3L - a)/(2 L^3)
    as P -> 0. With alpha = 0 the error is even in P (order 2); a tilted support adds an axial force
    R tan(alpha), whose P-delta moment makes it order 1. alpha = 0 is an idealised roller: the
    infinite wall through the tip is crossed by the bent rod, which the reference must report."""
    alpha, a = math.radians(alpha_deg), a_over_L * L
    normal = np.array([-math.cos(alpha), -math.sin(alpha)])
    point = np.array([0.0, L]) - R_O * normal
    loads = [0.2, 0.1, 0.05]  # P L^2 / E_b
    errors = []
    for q in loads:
        P = q * EB / L**2
        out = cr.solve_planar_contact(
            L, EB, R_O, [(point, normal)], point_loads=[(a, (P, 0.0))], contacts=[("tip", 0)], steps=2
        )
        assert out["converged"]
        R = -out["contacts"][0]["force_vector"][0]
        errors.append(abs(R / cr.propped_cantilever_reaction(P, a, L) - 1))
        assert out["admissible"] == (alpha_deg > 0), out["violations"]
    observed = np.diff(np.log(errors)) / np.diff(np.log(loads))
    # measured: alpha 0: 2.0000 (error 1.2e-6 at q = 0.2, a = L/2); alpha 30 deg: 0.998-1.001 (1.0e-3)
    assert np.all(np.abs(observed - order) < 0.02), observed
    assert errors[-1] < (1e-6 if order == 2 else 1e-3)
    if a_over_L == 0.5:
        assert cr.propped_cantilever_reaction(1.0, a, L) == pytest.approx(5 / 16, rel=1e-15)


# -- a channel, advanced step by step ---------------------------------------------------------------

#: two parallel walls 2 x 4 mm apart, tilted 10 deg from the clamp's axis; a tip magnet in a field
#: 60 deg to the other side; free length 10 to 100 mm.
BETA, HALF_WIDTH, PSI, Q = math.radians(10), 4e-3, math.radians(-60), 0.6
T = np.array([math.cos(BETA), math.sin(BETA)])
CHANNEL = [(HALF_WIDTH * T, -T), (-HALF_WIDTH * T, T)]
MAGNET = 0.01
FIELD = Q * EB / (MAGNET * 0.1) * np.array([math.sin(PSI), math.cos(PSI)])
FREE = np.linspace(0.01, 0.1, 19)


@pytest.fixture(scope="module")
def channel_steps():
    return cr.advance(FREE, EB, R_O, CHANNEL, B=FIELD, m=MAGNET)


def _set(step):
    return tuple(sorted((c["kind"], c["wall"]) for c in step["contacts"]))


def test_advance_in_a_channel_makes_contacts_appear_move_and_change_sides(channel_steps):
    sets = [_set(s) for s in channel_steps]
    order = []
    for s in sets:
        if not order or order[-1] != s:
            order.append(s)
    # no contact; the tip on the wall it heads for; the tip leaves, the rod rests on that wall behind
    # it; the tip reaches the other wall
    assert order == [(), (("tip", 0),), (("interior", 0),), (("interior", 0), ("tip", 1))]
    for step in channel_steps:
        assert step["admissible"], step["violations"]
        assert all(c["force"] >= 0 for c in step["contacts"])
        assert min(g for g, _ in step["gap_min"]) > -1e-9 * step["free_length"]
    # the interior contact moves along the rod as the tube advances
    s_int = [c["s"] for st in channel_steps for c in st["contacts"] if c["kind"] == "interior"]
    assert s_int[-1] - s_int[0] > 1e-3


def _discrete_minimiser(ell, n, walls, theta0):
    """Another model of the same state, returning its tip, node angles and active (wall, node)s:
    node angles theta_0..theta_n (theta_0 = 0, the clamp), the
    bending energy sum E_b (dtheta)^2 / (2h) of piecewise-linear theta, node positions by the
    trapezoidal rule, the magnet's -m d3(L).B, and every node's gap >= 0 as an inequality
    constraint (SLSQP). Its error is O(h^2)."""
    h = ell / n

    def positions(th):
        d = np.stack([np.sin(th), np.cos(th)])
        steps = 0.5 * h * (d[:, 1:] + d[:, :-1])
        return np.concatenate([np.zeros((2, 1)), np.cumsum(steps, axis=1)], axis=1)

    def full(x):
        return np.concatenate([[0.0], x])

    def energy(x):
        th = full(x)
        return EB * np.sum(np.diff(th) ** 2) / (2 * h) - MAGNET * (
            FIELD[0] * math.sin(th[-1]) + FIELD[1] * math.cos(th[-1])
        )

    def grad(x):
        th = full(x)
        d = np.diff(th)
        g = np.zeros(n + 1)
        g[1:] += EB * d / h
        g[:-1] -= EB * d / h
        g[-1] -= MAGNET * (FIELD[0] * math.cos(th[-1]) - FIELD[1] * math.sin(th[-1]))
        return g[1:]

    # dr_k / dtheta_j = W[k, j] t(theta_j): the trapezoidal weights h/2 at j = 0 and j = k, h between
    W = np.tril(np.full((n + 1, n + 1), h))
    W[np.arange(n + 1), np.arange(n + 1)] = h / 2
    W[:, 0] = h / 2
    W[0, 0] = 0.0

    def gaps(x):
        r = positions(full(x))
        return np.concatenate([(r.T - p) @ nw - R_O for p, nw in walls])

    def gaps_jac(x):
        th = full(x)
        tx, tz = np.cos(th), -np.sin(th)
        rows = [(nw[0] * W * tx + nw[1] * W * tz)[:, 1:] for _, nw in walls]
        return np.concatenate(rows)

    e_scale, g_scale = ell / EB, 1 / ell  # O(1) energy and gaps: SLSQP's ftol is absolute
    out = minimize(
        lambda x: e_scale * energy(x),
        theta0[1:],
        jac=lambda x: e_scale * grad(x),
        method="SLSQP",
        constraints=[
            {"type": "ineq", "fun": lambda x: g_scale * gaps(x), "jac": lambda x: g_scale * gaps_jac(x)}
        ],
        options={"ftol": 1e-15, "maxiter": 500},
    )
    assert out.success, out.message
    th = full(out.x)
    r = positions(th)
    active = [
        (wi, k)
        for wi, (p, nw) in enumerate(walls)
        for k in range(n + 1)
        if (r[:, k] - p) @ nw - R_O < 1e-9 * ell
    ]
    return r[:, -1], th, active


def test_a_tip_contact_state_is_the_limit_of_a_discrete_energy_minimiser(channel_steps):
    """Step 3 (25 mm, the tip on wall 0): the minimiser converges to the reference's tip at order 2."""
    st = channel_steps[3]
    ell, ns, errors = st["free_length"], [20, 40, 80], []
    assert _set(st) == (("tip", 0),)
    theta = np.zeros(ns[0] + 1)  # from the straight rod: the minimiser finds its own contact
    for n in ns:
        theta0 = np.interp(np.linspace(0, 1, n + 1), np.linspace(0, 1, theta.size), theta)
        tip, theta, active = _discrete_minimiser(ell, n, CHANNEL, theta0)
        assert {(w, k == n) for w, k in active} == {(0, True)}
        errors.append(np.linalg.norm(tip - st["tip"]))
    observed = np.diff(np.log(errors)) / np.diff(np.log(1 / np.array(ns)))
    # measured: errors 3.2e-6, 8.0e-7, 2.0e-7 (x ell), orders 2.00, 2.00
    assert np.all(np.abs(observed - 2) < 0.05), (errors, observed)
    assert errors[-1] < 1e-6 * ell


@pytest.mark.parametrize("step", [5, 18])  # an interior contact on wall 0; and the tip on wall 1
def test_interior_contact_states_are_minima_of_the_discrete_energy(channel_steps, step):
    """Started at the reference's shape, the discrete minimiser stays with the same contacts (it
    would let a pulling contact go, or push through no wall) and near the same tip: nodal contact
    puts the point force at a node, so this comparison is first order in h (measured 1e-5 ell at 40
    nodes), a check of the active set rather than of digits."""
    st = channel_steps[step]
    ell, n = st["free_length"], 40
    theta0 = np.interp(np.linspace(0, ell, n + 1), st["shape"]["s"], st["shape"]["theta"])
    tip, _, active = _discrete_minimiser(ell, n, CHANNEL, theta0)
    found = {(w, k == n) for w, k in active}
    assert found == {(c["wall"], c["kind"] == "tip") for c in st["contacts"]}
    assert np.linalg.norm(tip - st["tip"]) < 3e-5 * ell


# -- a straight lumen: a planar wall solution rotated about the axis --------------------------------


def test_lumen_tip_is_the_planar_wall_solution_rotated_and_agrees_with_3d_shooting():
    rho, m, Bmag = 4.2e-3, 0.0125, 0.1
    azimuth, psi = math.radians(35), math.radians(80)
    B3 = Bmag * np.array(
        [math.sin(psi) * math.cos(azimuth), math.sin(psi) * math.sin(azimuth), math.cos(psi)]
    )
    out = cr.solve_lumen_tip(L, EB, R_O, rho, B3, m)
    assert out["converged"] and out["admissible"] and out["lumen_gap_min"] > -1e-12
    assert out["beta"] == pytest.approx(azimuth, abs=1e-14)
    tip3 = out["tip3"]
    assert math.hypot(tip3[0], tip3[1]) == pytest.approx(rho - R_O, abs=1e-10 * L)  # on the lumen
    # 3D director shooting (tests/rod/reference.py) under the same field with the lumen's reaction
    # as a dead tip force: the same tip
    rod = SimpleNamespace(
        length=L, E_b=EB, E_t=EB, E_s=math.inf, E_e=math.inf, precurvature=(0.0, 0.0, 0.0), segments=()
    )
    loads = SimpleNamespace(
        B=B3,
        distributed_force=(0.0, 0.0, 0.0),
        tip_force=out["force3"],
        tip_moment=(0.0, 0.0, 0.0),
        magnets=[(L, m)],
        magnetization=[],
        point_loads=[],
        directions=lambda kind: [(0.0, 0.0, 1.0)] if kind == "magnet" else [],
    )
    ref = reference.solve(SimpleNamespace(rod=rod, loads=loads))
    # measured: 1e-13 L
    assert np.max(np.abs(ref["position"] - tip3)) < 1e-8 * L
    # the same tube turned to another azimuth: the same planar answer, rotated
    turned = cr.solve_lumen_tip(L, EB, R_O, rho, B3 * [-1, -1, 1], m)
    assert np.max(np.abs(turned["tip3"] - cr.rotate_about_axis(out["tip"], azimuth + math.pi))) < 1e-10 * L


# -- a vessel bend: the tip sliding along the outer wall of a curved lumen -------------------------

BEND = dict(EI=1e-5, R_o=0.5e-3, B=(30e-3, 0.0), m=0.01)  # examples/scenes/advance_lumen.toml


@pytest.fixture(scope="module")
def bend_steps():
    lumen = cr.BendLumen(1e-3, 20e-3, math.pi / 2)
    return lumen, cr.advance_in_bend([5e-3, 10e-3, 15e-3, 20e-3], BEND["EI"], BEND["R_o"], lumen,
                                     B=BEND["B"], m=BEND["m"])  # fmt: skip


def test_bend_steps_are_free_then_on_the_outer_wall_of_the_arc(bend_steps):
    """Geometry the shooting does not use: on the arc's outer wall the tip is Rc + rho - R_o from the
    arc's centre and the reaction points at that centre."""
    lumen, steps = bend_steps
    assert all(s["admissible"] for s in steps)
    assert [len(s["contacts"]) for s in steps] == [0, 1, 1, 1]
    for s in steps[1:]:
        tip, f = s["tip"], s["contacts"][0]["force_vector"]
        to_centre = lumen.centre - tip
        assert np.linalg.norm(to_centre) == pytest.approx(lumen.Rc + lumen.rho - BEND["R_o"], abs=1e-12)
        assert abs(f[0] * to_centre[1] - f[1] * to_centre[0]) < 1e-12 * np.linalg.norm(f) * lumen.Rc
        assert f @ to_centre > 0 and s["contacts"][0]["force"] > 0


def test_bend_tip_contact_is_the_elastica_closed_form(bend_steps):
    """The tip force and couple of each contact step put into the elliptic-integral closed form
    (which knows nothing of the wall): the rod it gives has the step's length and tip."""
    _, steps = bend_steps
    (Bx, Bz), m = BEND["B"], BEND["m"]
    for s in steps[1:]:
        f = s["contacts"][0]["force_vector"]
        P = float(np.linalg.norm(f))
        gamma = math.atan2(-f[0], -f[1])  # the force is -P (sin gamma, cos gamma)
        theta_L = s["theta_L"]
        M_L = m * (Bx * math.cos(theta_L) - Bz * math.sin(theta_L))
        cf = cr.elastica_tip_on_wall(BEND["EI"], P, gamma, theta_L, M_L, inflections=0)
        assert cf["L"] == pytest.approx(s["free_length"], rel=1e-9)
        assert np.abs(cf["tip"] - s["tip"]).max() < 1e-9 * s["free_length"]
