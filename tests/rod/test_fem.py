"""The rod's discretisation on scikit-fem (matid.rod.fem): its tables are the Basis', its tangent at
the reference state is the one an idiomatic skfem BilinearForm assembles, and P2 and the paper's
cubic Hermite converge at their order on a closed form, through the same code."""

import math

import numpy as np
import pytest
from skfem import Basis, BilinearForm, ElementLineHermite, ElementLineP1, ElementLineP2, MeshLine

from matid.bench import scenes as S
from matid.rod.cantilever import solve_cantilever
from matid.rod.fem import Discretisation
from matid.rod.models import FULL, PLANAR, ScaledRod
from matid.rod.system import RodSystem

SKFEM = {"P1": ElementLineP1, "P2": ElementLineP2, "Hermite": ElementLineHermite}
CASES = [("P2", 2), ("P2", 4), ("P1", 2), ("Hermite", 4)]
VERTICES = np.array([0.0, 0.3, 0.5, 0.6, 1.0])
ROD = ScaledRod(E_t=0.7, E_s=3e3, E_e=2e4)


@BilinearForm
def stiffness(u, v, w):
    return u.grad[0] * v.grad[0]


@BilinearForm
def mass(u, v, w):
    return u * v


@BilinearForm
def coupling(u, v, w):  # trial value against test slope
    return u * v.grad[0]


@pytest.mark.parametrize(("element", "intorder"), CASES)
def test_basis_tables_are_scikit_fems(element, intorder):
    ours = Discretisation(VERTICES, 3, element=element, intorder=intorder)
    b = Basis(MeshLine(VERTICES), SKFEM[element](), intorder=intorder)
    phi = np.array([np.asarray(f[0]) for f in b.basis])
    dphi = np.array([f[0].grad[0] for f in b.basis])
    assert np.allclose(ours.phi, phi) and np.allclose(ours.dphi, dphi) and np.allclose(ours.dx, b.dx)
    assert np.array_equal(ours.edofs, b.element_dofs) and np.allclose(ours.s_dof, b.doflocs[0])


def _interleave(blocks: dict[tuple[int, int], np.ndarray], nscalar: int, nf: int) -> np.ndarray:
    """The matrix of interleaved dofs k nf + c from its field blocks (scikit-fem numbering k)."""
    K = np.zeros((nscalar * nf, nscalar * nf))
    for (a, b), block in blocks.items():
        K[a::nf, b::nf] += block
    return K


def _matid_tangent(model: str, element: str, intorder: int) -> tuple[np.ndarray, Discretisation, RodSystem]:
    disc = Discretisation(VERTICES, 3 if model == PLANAR else 7, element=element, intorder=intorder)
    system = RodSystem(disc, ROD, model=model, c_u=3.0, banded=True)
    _, K = system.evaluate(system.reduce(system.reference()), 0.0)
    return K.tocsr().toarray(), disc, system


@pytest.mark.parametrize(("element", "intorder"), CASES)
def test_planar_tangent_at_the_reference_state_is_the_bilinear_form(element, intorder):
    """Second variation of 1/2 [E_b theta'^2 + E_s nu1^2 + E_e (nu3 - 1)^2] about the straight rod:
    nu1 ~ x' - theta, nu3 - 1 ~ z' - 1, so a = E_s (x' - theta)(x' - theta) + E_e z'z' + E_b theta'theta'."""
    ours, disc, system = _matid_tangent(PLANAR, element, intorder)
    basis = disc.basis
    Ks, M, C = (form.assemble(basis).toarray() for form in (stiffness, mass, coupling))
    E_s, E_e = ROD.E_s, ROD.E_e
    blocks = {(0, 0): E_s * Ks, (0, 2): -E_s * C, (2, 0): -E_s * C.T, (2, 2): Ks + E_s * M, (1, 1): E_e * Ks}
    theirs = _interleave(blocks, basis.N, 3)[np.ix_(disc.free, disc.free)]
    assert np.max(np.abs(ours - theirs)) < 1e-12 * np.max(np.abs(theirs))


@pytest.mark.parametrize(("element", "intorder"), [("P2", 2), ("Hermite", 4)])
def test_full_tangent_at_the_reference_state_is_the_bilinear_form(element, intorder):
    """At q = (1, 0, 0, 0): kappa ~ 2 qv', nu ~ r' - 2 (q2, -q1, 0) + e3, so the elastic form is
    E_b 4 (q1'^2 + q2'^2) + E_t 4 q3'^2 + E_s [(x' - 2 q2)^2 + (y' + 2 q1)^2] + E_e z'^2; the unity
    penalty adds 4 c_u on q0 at each point-value dof and, with slopes (Hermite), its slope gauge
    c_u/2 (q.q')^2 adds c_u on the slope of q0 (nodal terms, not forms)."""
    ours, disc, system = _matid_tangent(FULL, element, intorder)
    basis = disc.basis
    Ks, M, C = (form.assemble(basis).toarray() for form in (stiffness, mass, coupling))
    E_t, E_s, E_e = ROD.E_t, ROD.E_s, ROD.E_e
    blocks = {
        (0, 0): E_s * Ks,
        (0, 5): -2 * E_s * C,
        (5, 0): -2 * E_s * C.T,
        (1, 1): E_s * Ks,
        (1, 4): 2 * E_s * C,
        (4, 1): 2 * E_s * C.T,
        (2, 2): E_e * Ks,
        (4, 4): 4 * Ks + 4 * E_s * M,
        (5, 5): 4 * Ks + 4 * E_s * M,
        (6, 6): 4 * E_t * Ks,
    }
    K = _interleave(blocks, basis.N, 7)
    q0 = disc.value_dofs * 7 + 3
    K[q0, q0] += 4 * system.c_u
    slopes = disc.slope_pairs[1] * 7 + 3
    K[slopes, slopes] += system.c_u
    theirs = K[np.ix_(disc.free, disc.free)]
    assert np.max(np.abs(ours - theirs)) < 1e-12 * np.max(np.abs(theirs))


def _observed_order(element: str, levels=(4, 8, 16, 32)) -> float:
    """Least-squares order of the tip error of a quarter-circle (pure end moment) against the
    closed form (L/theta)(1 - cos theta, sin theta)."""
    scene, theta = S.end_moment(0.25), math.pi / 2
    exact = np.array([1.0 - math.cos(theta), 0.0, math.sin(theta)]) / theta
    errors = [
        np.max(np.abs(solve_cantilever(scene, elements=n, element=element).position[-1] / S.L - exact))
        for n in levels
    ]
    return float(-np.polyfit(np.log(levels), np.log(errors), 1)[0])


@pytest.mark.parametrize("element", ["P2", "Hermite"])
def test_p2_and_hermite_converge_at_order_four(element):
    assert 3.9 < _observed_order(element) < 4.1


def test_hermite_clamp_holds_values_only():
    """The slopes at the clamp are strains (curvature, shear), not supports: they stay free, and the
    reference state has slope 1 in the axial field and 0 elsewhere."""
    disc = Discretisation(VERTICES, 3, element="Hermite", intorder=4)
    system = RodSystem(disc, ROD, model=PLANAR)
    fixed = np.flatnonzero(~disc.free)
    assert np.array_equal(fixed, disc.vertex_dof(0) * 3 + np.arange(3))
    U = system.reference().reshape(-1, 3)
    assert np.allclose(U[disc.slope], [0.0, 1.0, 0.0]) and np.allclose(
        U[~disc.slope, 1], disc.s_dof[~disc.slope]
    )


def test_hermite_converges_on_the_3d_bend():
    """The full model on the Hermite (its slopes of q held by the gauge c_u/2 (q.q')^2 at the
    vertices): the tip of the 45-degree precurved rod under an out-of-plane force converges to
    the fine P2 answer at order >= 4."""
    from matid.bench.peers import precurved_3d

    scene = precurved_3d()
    reference = solve_cantilever(scene, elements=128).position[-1] / S.L
    levels = (8, 16, 32)
    errors = [
        np.max(np.abs(solve_cantilever(scene, elements=n, element="Hermite").position[-1] / S.L - reference))
        for n in levels
    ]
    assert -np.polyfit(np.log(levels), np.log(errors), 1)[0] > 3.9
