"""The full model's point closed forms (matid.physics.full.magnet, dead_moment) against the jets."""

import numpy as np
import pytest

from matid.physics import full
from matid.physics import kinematics as kin
from matid.physics.jet import Jet


@pytest.mark.parametrize("variant", [kin.NORMALISED, kin.RAW])
@pytest.mark.parametrize("seed", [0, 1])
def test_lumped_magnet_matches_the_jets(variant, seed):
    rng = np.random.default_rng(seed)
    q, B = rng.standard_normal((5, 4)), rng.standard_normal(3)
    g, H = full.magnet(q, B, variant)
    e = kin.magnetic_energy(1.0, kin.d3(Jet.variables(q.T), variant), B)
    assert np.allclose(g, e.g, rtol=1e-12, atol=1e-12 * np.abs(e.g).max())
    assert np.allclose(H, e.h, rtol=1e-12, atol=1e-12 * np.abs(e.h).max())


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_dead_moment_work_matches_the_jets(seed):
    """Q = 2 (-M.v, q0 M + M x v)/|q|^2, written with the jets, and its Jacobian."""
    rng = np.random.default_rng(seed)
    q, M = rng.standard_normal(4), rng.standard_normal(3)
    Q, J = full.dead_moment(q, M)
    qj = Jet.variables(q.reshape(4, 1))
    q0, v = qj[0], qj[1:]
    inv = 1.0 / kin.norm2(qj)
    Mxv = [M[1] * v[2] - M[2] * v[1], M[2] * v[0] - M[0] * v[2], M[0] * v[1] - M[1] * v[0]]
    jets = [-2.0 * (M[0] * v[0] + M[1] * v[1] + M[2] * v[2]) * inv]
    jets += [2.0 * (q0 * M[i] + Mxv[i]) * inv for i in range(3)]
    assert np.allclose(Q, [c.v[0] for c in jets], rtol=1e-12, atol=1e-14)
    assert np.allclose(J, [c.g[0] for c in jets], rtol=1e-12, atol=1e-14)


def test_the_point_tables_are_the_kinematics():
    """A (curvature numerator 2 G(q) p = q^T A_i p) and Q (directors R_ji(q) = q^T Q_ji q), built
    afresh, against matid.physics.kinematics at random q, p."""
    rng = np.random.default_rng(3)
    q, p = rng.standard_normal(4), rng.standard_normal(4)
    A, Q = full._bilinear(), full._quadratic()
    np.testing.assert_allclose(np.einsum("iab,a,b->i", A, q, p), kin.curvature_numerator(q, p), atol=1e-14)
    np.testing.assert_allclose(np.einsum("jiab,a,b->ji", Q, q, q), kin.directors(q), atol=1e-14)


def test_the_strain_for_the_mixed_tangent_is_the_stiffness_times_the_strain():
    """strain = (C (e - e_ref), C de/dz): e = (kappa, nu) of kinematics.strains, e_ref =
    (lam kappa_ref, 0, 0, 1), C = (E_b, E_b, E_t, E_s, E_s, E_e); the Jacobian by central differences."""
    rng = np.random.default_rng(5)
    z = rng.standard_normal((4, 14))
    props = {k: rng.uniform(1.0, 3.0, 4) for k in ("E_b", "E_t", "E_s", "E_e")}
    lam, kappa_ref = 0.7, np.array([0.3, -0.2, 0.1])

    def strain(z):
        args = (lam, props, kappa_ref, None, (0.0, 0.0, 0.0), True)  # mu, B, tangent
        return full.derivatives(z, *args, stress=None, want_strain=True)[2]

    Ce, Cde = strain(z)
    kappa, nu = kin.strains(z[:, 7:10].T, z[:, 3:7].T, z[:, 10:14].T)
    e = np.column_stack([*kappa, *nu])
    e_ref = np.concatenate([lam * kappa_ref, [0.0, 0.0, 1.0]])
    C = np.column_stack([props[k] for k in ("E_b", "E_b", "E_t", "E_s", "E_s", "E_e")])
    np.testing.assert_allclose(Ce, C * (e - e_ref), rtol=1e-12, atol=1e-12)
    h = 1e-6
    for k in range(14):
        dz = np.zeros(14)
        dz[k] = h
        central = (strain(z + dz)[0] - strain(z - dz)[0]) / (2 * h)
        np.testing.assert_allclose(Cde[:, :, k], central, rtol=1e-6, atol=1e-6)
