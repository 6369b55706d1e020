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
