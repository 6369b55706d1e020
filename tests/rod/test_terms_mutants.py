"""The rod's terms against hand-made answers, for what the mutation sample (benchmarks/mutation.sh,
seed 29) showed no other test sees: each test states the behaviour, its answer is worked out by hand
from the scene (a straight rod along z, a wall parallel to it), not read off the code."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.physics.kinematics import NORMALISED, RAW
from matid.rod import solve
from matid.rod.cantilever import INTORDER, equilibrium, mesh, prepare_scene
from matid.rod.fem import Discretisation
from matid.rod.models import FULL, PLANAR, ScaledRod, Segment
from matid.rod.scenes import load_scene, scene_from_dict
from matid.rod.system import RodSystem
from matid.rod.terms import Contact, Magnets
from matid.rod.terms.base import q_dofs

SCENES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
#: a scaled rod for the terms built by hand (its stiffness plays no part in a term's derivatives)
SCALED = ScaledRod(E_t=0.7, E_s=3e3, E_e=2e4, segments=(Segment(0.6, 0.8, 5.0, 4.0, 1e5, 2e5),))
ROD = {"length": "30 mm", "E_b": 1e-4, "E_t": 1e-4, "E_s": 10, "E_e": 10, "outer_diameter": "1 mm"}


def _system(raw: dict, elements: int = 4) -> RodSystem:
    chosen, _, rod, loads, at = prepare_scene(scene_from_dict(raw), "auto")
    disc = mesh(elements, at, 3 if chosen == PLANAR else 7, "P2", 2)
    return RodSystem(disc, rod, loads, model=chosen)


def _contact(system: RodSystem):
    return next((term, prep) for term, prep in system.nodal if isinstance(term, Contact))


@pytest.mark.parametrize("segment_from", ["0 mm", "20 mm"])
def test_a_wider_segment_keeps_its_radius_to_the_tip_and_from_its_start(segment_from: str) -> None:
    """A distal segment of 3 mm outer diameter on a 1 mm tube, a wall 5 mm from the straight axis:
    the gap is 5 - 1.5 = 3.5 mm on the segment, both ends included (the tip node, and the node at
    the step, where the wider tube's surface is), 5 - 0.5 = 4.5 mm elsewhere."""
    raw = {
        "rod": ROD,
        "segment": [{"from": segment_from, "to": "30 mm", "outer_diameter": "3 mm"}],
        "tip": {"force": ["0.001 N", "0 N", "0 N"]},
        "wall": [{"point": ["-5 mm", "0 mm", "0 mm"], "normal": [1, 0, 0]}],
    }
    system = _system(raw)
    term, prep = _contact(system)
    ((g, _, _),) = term.gaps(prep, system.reference())
    s = prep["s"] * 30.0  # mm
    start = float(segment_from.split()[0])
    expected = np.where(s >= start - 1e-9, 3.5, 4.5) / 30.0
    assert np.allclose(g, expected, rtol=0, atol=1e-12), np.c_[s, g * 30.0]


def test_a_wall_the_rod_does_not_touch_adds_nothing_to_what_the_estimate_follows() -> None:
    """No force on a wall: its resultant and its force-weighted position are all zero (the error
    estimate compares these numbers between meshes; an untouched wall must not move them)."""
    raw = {
        "rod": ROD,
        "tip": {"force": ["0.001 N", "0 N", "0 N"]},
        "wall": [{"point": ["-5 mm", "0 mm", "0 mm"], "normal": [1, 0, 0]}],
    }
    system = _system(raw)
    term, prep = _contact(system)
    q = term.quantities(system, prep, system.reference())
    assert q.tolist() == [0.0, 0.0, 0.0, 0.0]


# -- lumped magnets: the residual and tangent are the derivatives of a hand-written potential ------


def _rotation(q: np.ndarray) -> np.ndarray:
    """R(q) of a quaternion (w, x, y, z), not normalised: the textbook matrix times |q|^2."""
    w, x, y, z = q
    return np.array([
        [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
    ])  # fmt: skip


def _magnet_potential(q: np.ndarray, m_a: np.ndarray, B, variant: str) -> float:
    """-(R a).B m of one magnet (moment m along a in the director frame: m_a = m a); the
    normalised variant rotates by q/|q|, the raw one by the quadratic map itself."""
    R = _rotation(q) if variant == RAW else _rotation(q) / (q @ q)
    return -float((R @ m_a) @ np.asarray(B))


def _fd(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences of f at x (f scalar: the gradient; f a vector: the Jacobian, rows f)."""
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        cols.append((np.asarray(f(x + e)) - np.asarray(f(x - e))) / (2 * h))
    return np.array(cols).T


@pytest.mark.parametrize("variant", [RAW, NORMALISED])
@pytest.mark.parametrize("directed", [False, True])
def test_a_lumped_magnet_is_the_derivative_of_its_potential(variant: str, directed: bool) -> None:
    """The full model's magnet term at a node with a random q: its residual is dE/dq and its tangent
    d2E/dq2 of E = lam (-(R(q) a).B m), R(q) written out here (finite differences, 1e-7)."""
    B, lam, m = (0.3, -0.5, 0.8), 0.7, 1.3
    a = np.array([0.6, 0.0, 0.8]) if directed else np.array([0.0, 0.0, 1.0])
    term = Magnets(B, (), ((1.0, m, tuple(a)),)) if directed else Magnets(B, ((1.0, m),))
    disc = Discretisation(np.linspace(0.0, 1.0, 5), 7, element="P2", intorder=INTORDER["P2"])
    system = RodSystem(disc, SCALED, (term,), model=FULL, variant=variant)
    ((_, prep),) = system.nodal
    rng = np.random.default_rng(3)
    U = system.reference() + 0.3 * rng.standard_normal(disc.n)
    R, blocks = np.zeros(disc.n), []
    term.nodal(system, prep, U, lam, R, blocks)
    dofs = q_dofs([system.tip], 7)[0]
    energy = lambda q: lam * _magnet_potential(q, m * a, B, variant)  # noqa: E731
    grad = _fd(energy, U[dofs])
    hess = _fd(lambda q: _fd(energy, q), U[dofs], 1e-4)
    assert np.allclose(R[dofs], grad, rtol=0, atol=1e-7 * np.abs(grad).max())
    assert np.count_nonzero(R) == 4  # the tip's q only
    ((_, values),) = blocks
    assert np.allclose(values[0], hess, rtol=0, atol=1e-5 * np.abs(hess).max())


def test_the_tangent_of_a_rod_pressed_into_a_wall_is_the_derivative_of_its_residual() -> None:
    """A wall touching the straight tube, the tube moved 0.1 mm into it beyond the clamp: every
    free node is in contact, the first free dof's included; the assembled tangent (rod, tip load
    and contact blocks) equals the central differences of the assembled residual."""
    raw = {
        "rod": ROD,
        "tip": {"force": ["0.001 N", "0 N", "0 N"]},
        "wall": [{"point": ["-0.5 mm", "0 mm", "0 mm"], "normal": [1, 0, 0]}],
    }
    system = _system(raw)
    term, prep = _contact(system)
    nf = system.disc.nf
    U = system.reference().reshape(-1, nf)
    U[system.disc.s_dof > 0, 0] -= 0.1 / 30.0  # x, scaled by L = 30 mm
    rng = np.random.default_rng(2)
    X = system.reduce(U.ravel()) + 1e-5 * rng.standard_normal(int(system.disc.free.sum()))
    ((g, _, _),) = term.gaps(prep, system.expand(X))
    assert np.all(g[prep["s"] > 0] < -1e-3)  # every free node presses into the wall
    K = system.evaluate(X, 0.6)[1]
    K = K.toarray() if hasattr(K, "toarray") else K.tocsr().toarray()
    fd = _fd(lambda x: system.evaluate(x, 0.6, tangent=False)[0], X, 1e-7)
    assert np.allclose(K, fd, rtol=0, atol=1e-6 * np.abs(fd).max())


def test_the_converged_point_stresses_are_the_tip_force_on_the_directors() -> None:
    """Statics of a cantilever under a dead tip force F and nothing else: the internal force is F
    everywhere, so the shear and axial forces at every point are F.d1 and F.d3 of the deformed
    section there, d1 = (cos t, -sin t), d3 = (sin t, cos t) in the plane (alpha = F L^2/E_b = 1.385:
    large rotations)."""
    scene = load_scene(SCENES / "tip_force.toml")
    eq = equilibrium(scene, elements=16)
    assert eq.model == PLANAR and eq.stress is not None
    F = np.asarray(scene.loads.tip_force) * scene.rod.length**2 / scene.rod.E_b  # scaled, (x, -, z)
    theta = eq.disc.interpolate(eq.U.ravel())[0][2]
    c, s = np.cos(theta), np.sin(theta)
    expected = np.stack([F[0] * c - F[2] * s, F[0] * s + F[2] * c], axis=-1)
    assert np.abs(theta).max() > 0.5  # a large deflection
    assert np.allclose(eq.stress, expected, rtol=0, atol=1e-6 * np.abs(F).max())


@pytest.mark.parametrize("phi_deg", [30.0, 90.0])
def test_an_end_moment_about_any_horizontal_axis_bends_a_circle_about_it(phi_deg: float) -> None:
    """A pure end moment M = theta E_b/L about the horizontal axis a = (cos phi, sin phi, 0): the
    planar model in the plane normal to a bends the rod into a circle of angle theta, the tip at
    L ((1 - cos theta)/theta (a x e3) + sin theta/theta e3) (shear and extension carry nothing)."""
    theta, phi, L, E_b = 1.0, np.radians(phi_deg), 0.03, 6.5e-5
    a = np.array([np.cos(phi), np.sin(phi), 0.0])
    rod = {"length": L, "E_b": E_b, "E_t": 4.4e-5, "E_s": 1e8 * E_b / L**2, "E_e": 1e8 * E_b / L**2}
    sol = solve(scene_from_dict({"rod": rod, "tip": {"moment": list(theta * E_b / L * a)}}), elements=16)
    assert sol.model == PLANAR
    exact = (1 - np.cos(theta)) / theta * np.cross(a, [0.0, 0.0, 1.0]) + np.sin(theta) / theta * np.array(
        [0, 0, 1.0]
    )
    assert np.allclose(sol.position[-1] / L, exact, rtol=0, atol=1e-8)


def test_a_moved_mesh_has_the_tables_of_one_built_on_its_vertices() -> None:
    """Discretisation.moved rescales the tables of a P2 mesh onto new vertices; scikit-fem's Basis
    built on those vertices from scratch gives the same weights, slopes, points and assembly
    tables (to round-off)."""
    base = Discretisation(np.linspace(0.0, 1.0, 6), 3, element="P2", intorder=INTORDER["P2"])
    vertices = np.array([0.0, 0.13, 0.35, 0.52, 0.8, 1.0])
    moved = base.moved(vertices)
    fresh = Discretisation(vertices, 3, element="P2", intorder=INTORDER["P2"])
    for name in ("dx", "dphi", "s_quad", "s_dof", "weighted", "both", "element_tables", "point_table"):
        assert np.allclose(getattr(moved, name), getattr(fresh, name), rtol=1e-12, atol=1e-12), name


def test_a_stack_of_cantilevers_is_in_equilibrium_at_every_dof_but_the_clamp() -> None:
    """The stacked residual at the converged states holds the free dofs only: it vanishes there,
    while the whole residual keeps the clamp's reaction, the tip force (statics, not the code)."""
    from matid.rod import batch

    F = 2.0 * ROD["E_b"] / 0.03**2  # a tip force across the rod: 2 E_b / L^2
    scenes = [scene_from_dict({"rod": ROD, "tip": {"force": [f, 0, 0]}}) for f in (F, -0.5 * F)]
    parts = [prepare_scene(scene, PLANAR)[2:4] for scene in scenes]
    disc = mesh(8, (1.0,), 3, "P2", INTORDER["P2"])
    stack = batch.Stack(disc, parts)
    X, _, _, reasons = batch.follow(stack, stack.reference())
    assert reasons == [None, None]
    R = stack.evaluate(X, np.ones(2), tangent=False)[0]
    whole = stack.residual(np.zeros((2, disc.ne, disc.s_quad.shape[1], 6)), np.ones(2))  # the loads alone
    tip = np.abs(whole).max(axis=1)  # the scaled tip force of each scene
    assert np.all(tip > 0.1)
    assert np.abs(R).max(axis=1) == pytest.approx([0.0, 0.0], abs=1e-8 * tip.max())


def test_a_table_a_mesh_does_not_have_is_named_in_the_error() -> None:
    disc = mesh(4, (1.0,), 3, "P2", INTORDER["P2"])
    with pytest.raises(AttributeError, match="'Discretisation' object has no attribute 'tip_table'"):
        disc.tip_table  # noqa: B018


def test_the_first_step_s_stability_probe_does_not_depend_on_a_failed_newton_before_it() -> None:
    """equilibrium starts the continuation from the straight rod after a warm Newton failed: the
    probe of the straight rod must see its own tangent, not the failed solve's point stresses."""
    from matid.bench import scenes as S
    from matid.rod import newton as nw

    chosen, _, rod, loads, at = prepare_scene(S.magnetic(6.4, 120.0), PLANAR)
    disc = mesh(8, at, 3, "P2", INTORDER["P2"])
    fresh = RodSystem(disc, rod, loads, model=chosen, banded=True, mixed=True)
    used = RodSystem(disc, rod, loads, model=chosen, banded=True, mixed=True)
    x0 = fresh.reduce(fresh.reference())
    with pytest.raises(nw.NewtonFailure):  # a wild guess at the full load: Newton gives up
        nw.newton(used, x0 + np.random.default_rng(0).normal(0.0, 1.0, x0.size), 1.0)
    want = nw.definite_step(fresh, x0, 0.0, 1.0, 1.0, nw.MIN_STEP)
    assert want < 1.0  # beyond buckling at the full load: the probe halves (the test can tell)
    assert nw.definite_step(used, x0, 0.0, 1.0, 1.0, nw.MIN_STEP) == want


def test_p2_interpolation_reproduces_a_quadratic_from_integer_positions() -> None:
    """interpolate_p2 is exact on a quadratic, also when the vertices and points are integers."""
    from matid.rod.transfer import interpolate_p2

    def f(s):
        return 3.0 - 2.0 * s + 0.5 * s**2

    nodes = np.arange(5)  # vertex, mid-point, vertex, ... of the mesh 0, 2, 4
    s = np.array([0, 1, 3, 4])
    got = interpolate_p2(np.array([0, 2, 4]), f(nodes)[:, None].astype(float), s)
    assert got[:, 0] == pytest.approx(f(s), abs=1e-12)


def _tip_force_system() -> RodSystem:
    return _system({"rod": ROD, "tip": {"force": [0.5 * ROD["E_b"] / 0.03**2, 0, 0]}}, elements=4)


def test_a_continuation_back_down_the_load_reaches_the_state_of_the_lower_load(monkeypatch) -> None:
    """follow through load factors 2 then 0.5 (back down by more than one step) ends where a
    continuation straight to 0.5 does: the equilibrium of a stable cantilever is unique. (A budget
    of 100 Newton iterations, 19 used: a continuation that walks away from 0.5 stops early.)"""
    from matid.rod import newton as nw

    monkeypatch.setattr(nw, "MIN_ITERATIONS", 100)
    monkeypatch.setattr(nw, "WORK_BUDGET", 1.0)
    system = _tip_force_system()
    x0 = system.reduce(system.reference())
    down, _ = nw.follow(system, x0, [2.0, 0.5])
    direct, _ = nw.follow(system, x0, [0.5])
    assert np.abs(down - direct).max() < 1e-8


def test_a_continuation_that_gives_up_for_its_effort_says_how_far_it_got(monkeypatch) -> None:
    """With a work budget of one Newton iteration, the first load step (0.25 of the load) already
    exceeds it: the error names the load factor reached."""
    from matid.errors import ConvergenceError
    from matid.rod import newton as nw

    monkeypatch.setattr(nw, "MIN_ITERATIONS", 1)
    monkeypatch.setattr(nw, "WORK_BUDGET", 1.0)
    system = _tip_force_system()
    with pytest.raises(ConvergenceError, match="too little progress") as info:
        nw.follow(system, system.reduce(system.reference()), [1.0], first_step=0.25)
    assert info.value.load_factor == 0.25
    assert "last converged load factor 0.25" in str(info.value)


def test_newton_on_an_exactly_singular_banded_tangent_says_so() -> None:
    """A stand-in system whose banded tangent is all zeros: Newton fails, naming the singular tangent."""
    from matid.rod import newton as nw
    from matid.rod.band import Banded

    class Singular:
        def evaluate(self, x, lam, *, tangent=True):
            K = Banded(np.zeros((3, 4)), 1, np.arange(4), np.arange(4), True)
            return np.ones(4), K

    with pytest.raises(nw.NewtonFailure, match="singular tangent"):
        nw.newton(Singular(), np.zeros(4), 1.0)


def test_a_segment_s_precurvature_is_kept_whole_beside_a_rod_s_given_in_integers() -> None:
    """kappa_ref_at on a rod whose own precurvature is written (0, 0, 0): the segment's 0.25 and
    1.5 are read as they are, not cut to integers; the rod's zeros hold outside it."""
    rod = ScaledRod(
        E_t=1.0,
        E_s=1e3,
        E_e=1e3,
        kappa_ref=(0, 0, 0),
        segments=(Segment(0.5, 1.0, 1, 1, 1, 1, (0.25, 1.5, 0.0)),),
    )
    got = rod.kappa_ref_at(np.array([0.25, 0.75]))
    assert got.tolist() == [[0.0, 0.0, 0.0], [0.25, 1.5, 0.0]]
