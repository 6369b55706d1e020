"""Closed-form derivatives of the rod densities against the jets (the oracle), and the banded
tangent against the CSR assembly: same model, same numbers, to round-off."""

import numpy as np
import pytest

from matid.physics.kinematics import NORMALISED, RAW
from matid.rod.cantilever import INTORDER
from matid.rod.fem import Discretisation
from matid.rod.models import FULL, PLANAR, ScaledRod, Segment
from matid.rod.system import RodSystem
from matid.rod.terms import DistributedForce, Magnetisation, Magnets, Tip
from matid.rod.transfer import interpolate_p2

ROD = ScaledRod(
    E_t=0.7,
    E_s=3e3,
    E_e=2e4,
    segments=(Segment(0.6, 0.8, 5.0, 4.0, 1e5, 2e5),),
    kappa_ref=(0.4, -1.3, 0.2),
)
B = (0.3, -0.5, 0.8)
LOADS = (
    Magnetisation(B, ((0.2, 1.0, 2.5),)),
    DistributedForce((0.7, -0.2, 1.1)),
    Tip((0.5, 1.5, -0.5), (0.0, 0.0, 0.0)),
    Magnets(B, ((1.0, 0.8),)),
)


def system(model: str, *, element: str = "P2", **kw) -> RodSystem:
    nf = 3 if model == PLANAR else 7
    disc = Discretisation(np.linspace(0.0, 1.0, 6), nf, element=element, intorder=INTORDER[element])
    return RodSystem(disc, ROD, LOADS, model=model, c_u=3.0, **kw)


@pytest.mark.parametrize(("model", "variant"), [(PLANAR, NORMALISED), (FULL, NORMALISED), (FULL, RAW)])
@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("element", ["P2", "Hermite"])
def test_closed_form_derivatives_match_the_jets(model, variant, seed, element):
    rng = np.random.default_rng(seed)
    sys_ = system(model, variant=variant, element=element)
    U = sys_.reference() + 0.4 * rng.standard_normal(sys_.disc.n)
    for lam in (0.37, 1.0):
        g, H = sys_.energy_derivatives(U, lam)
        sys_.analytic = False
        g_jet, H_jet = sys_.energy_derivatives(U, lam)
        sys_.analytic = True
        assert np.allclose(g, g_jet, rtol=1e-12, atol=1e-12 * np.abs(g_jet).max())
        assert np.allclose(H, H_jet, rtol=1e-12, atol=1e-12 * np.abs(H_jet).max())


@pytest.mark.parametrize("model", [PLANAR, FULL])
def test_banded_tangent_and_solve_equal_the_sparse_ones(model):
    rng = np.random.default_rng(7)
    sparse, banded = system(model), system(model, banded=True)
    X = sparse.reduce(sparse.reference() + 0.2 * rng.standard_normal(sparse.disc.n))
    R0, K0 = sparse.evaluate(X, 0.8)
    R1, K1 = banded.evaluate(X, 0.8)
    assert np.allclose(R0, R1, rtol=0, atol=1e-12 * np.abs(R0).max())
    assert np.allclose(K0.toarray(), K1.tocsr().toarray(), rtol=0, atol=1e-12 * np.abs(K0).max())
    b = rng.standard_normal(R0.size)
    x = K1.factor().solve(b)
    assert np.allclose(K0 @ x, b, atol=1e-8 * np.abs(b).max())


def test_band_cholesky_is_the_stability_test():
    """Positive definite -> Cholesky (the stable-state test); indefinite -> LU, flagged not stable."""
    sys_ = system(PLANAR, banded=True)
    X = sys_.reduce(sys_.reference())
    _, K = sys_.evaluate(X, 0.0)
    assert K.factor().positive_definite is True
    K.ab[K.u] -= 10.0 * np.abs(K.ab).max()  # shift the diagonal: indefinite
    factor = K.factor()
    assert factor.positive_definite is False
    b = np.arange(K.shape[0], dtype=float)
    assert np.allclose(K.tocsr() @ factor.solve(b), b)


def test_p2_interpolation_is_exact_for_quadratics():
    v = np.array([0.0, 0.3, 0.5, 1.0])
    nodes = np.sort(np.concatenate([v, 0.5 * (v[1:] + v[:-1])]))
    f = lambda s: 2.0 - 3.0 * s + 5.0 * s**2  # noqa: E731
    s = np.linspace(0.0, 1.0, 37)
    assert np.allclose(interpolate_p2(v, f(nodes)[:, None], s)[:, 0], f(s))


@pytest.mark.parametrize("model", [PLANAR, FULL])
def test_mixed_newton_reaches_the_same_equilibrium(model):
    """The mixed-integration-point tangent changes the path of Newton, never its root."""
    from matid.rod.newton import follow

    answers = []
    for mixed in (False, True):
        sys_ = system(model, banded=True, mixed=mixed)
        X, info = follow(sys_, sys_.reduce(sys_.reference()), [1.0])
        answers.append(X)
    assert np.max(np.abs(answers[0] - answers[1])) < 1e-9


def test_bend_mesh_derivative_and_bordered_solve():
    """dR/dsigma in closed form equals central differences; the bordered solve equals a dense one."""
    from matid.rod.bend import BendGeometry, BendModel

    geometry = BendGeometry(0.01, 0.03, 0.002, 0.002, 0.0024)
    model = BendModel(geometry, elements=8)
    path = model.solve(6.5e-5, 21.0, 120.0, np.array([0.0005, 0.001]))
    bend = model.system(6.5e-5, 21.0, 120.0, 0.001)
    X = path.states[-1]
    R, A = bend.evaluate(X, 1.0)
    u, sigma = X[: bend.nu], X[-1]
    U = bend.rod.expand(u)
    delta = 1e-6 * sigma
    out = []
    for s in (sigma + delta, sigma - delta):
        bend.at(s)
        out.append(bend.rod.evaluate(u, 0.0, tangent=False, U=U)[0])
    fd = (out[0] - out[1]) / (2 * delta)
    assert np.allclose(A.B[:, 2], fd, rtol=0, atol=1e-7 * np.abs(fd).max())
    dense = A.tocsr().toarray()
    x = A.factor().solve(R)
    assert np.allclose(dense @ x, R, rtol=0, atol=1e-9 * np.abs(R).max())


def test_stiff_rod_in_the_full_model_converges_with_the_mixed_tangent():
    """Regression: with the switch to the consistent tangent at corrections of 1e-3 the round-off
    stagnation test fired on this scene (tip force F L^2/E_b = 2, E_s = E_e = 1e8 E_b/L^2)."""
    from matid.rod.cantilever import solve_cantilever
    from matid.rod.scenes import scene_from_dict

    L, Eb = 0.03, 9e-5
    scale = Eb / L**2
    scene = scene_from_dict(
        {
            "rod": {"length": L, "E_b": Eb, "E_t": Eb, "E_s": 1e8 * scale, "E_e": 1e8 * scale},
            "tip": {"force": [2.0 * scale, 0.0, 0.0]},
        }
    )
    full = solve_cantilever(scene, elements=16, model="full")
    planar = solve_cantilever(scene, elements=16, model="planar")
    # Newton accepts corrections at its round-off floor, 1e-15 x the stiffness spread (1e8) = 1e-7
    assert np.max(np.abs(full.position[-1] - planar.position[-1])) < 1e-6 * L
