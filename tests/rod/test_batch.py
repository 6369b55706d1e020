"""The stacked Newton of matid.rod.batch / matid.rod.many against one solve per scene."""

from __future__ import annotations

import numpy as np
import pytest

from matid.bench import scenes as S
from matid.rod.api import solve
from matid.rod.cantilever import mesh
from matid.rod.chain import Chain, ChainLayout
from matid.rod.many import Failure, solve_many
from matid.rod.scenes import scene_from_dict

L, EB = S.L, S.E_B


def _family() -> list:
    """Planar scenes of one mesh family with every stacked term, and some that run alone."""
    rod = {"length": L, "E_b": EB, "E_t": EB, "E_s": 1e4 * EB / L**2, "E_e": 1e4 * EB / L**2}
    force = EB / L**2
    pl = {"at": L / 2, "force": [force, 0, 0], "moment": [0, EB / L, 0]}
    magnet = {"at": L, "moment": 2 * EB / 0.01 / L}
    scenes = [S.magnetic(q, a) for q in (2.0, 6.4) for a in (30.0, 120.0, 175.0)]
    scenes += [S.tip_force(a) for a in (0.5, 5.0)]
    scenes += [
        scene_from_dict({"rod": {**rod, "precurvature": [0, 1.0 / L, 0]}, "tip": {"force": [force, 0, 0]}}),
        scene_from_dict({"rod": rod, "load": {"distributed_force": [2 * force / L, 0, 0]}}),
        scene_from_dict({"rod": rod, "point_load": [pl]}),
        scene_from_dict({"rod": rod, "field": {"B": [0.01, 0, 0.0]}, "magnet": [magnet]}),
        # out of the plane: the full model, solved alone
        scene_from_dict({"rod": rod, "tip": {"force": [force, force, 0.5 * force]}, "elements": 8}),
    ]
    return scenes


def test_same_answers_as_one_solve_per_scene():
    scenes = _family()
    many = solve_many(scenes)
    assert len(many) == len(scenes)
    for scene, got in zip(scenes, many, strict=True):
        want = solve(scene)
        assert got.converged and got.scene is scene
        assert got.elements == want.elements
        assert np.max(np.abs(got.position - want.position)) / L < 1e-9
        assert np.max(np.abs(got.d3 - want.d3)) < 1e-9
        assert got.discretization_error == pytest.approx(want.discretization_error, rel=1e-3, abs=1e-12)
        assert got.terms == want.terms
        assert got.extra["warnings"] == want.extra["warnings"]


def test_fixed_elements_as_solve():
    scenes = [S.magnetic(q, 90.0) for q in (1.0, 3.0)]
    for got, scene in zip(solve_many(scenes, elements=12), scenes, strict=True):
        want = solve(scene, elements=12)
        assert got.elements == 12 and np.max(np.abs(got.position - want.position)) / L < 1e-9
        assert got.extra["error_estimate"]["meshes"] == want.extra["error_estimate"]["meshes"]


def test_a_failing_scene_leaves_with_its_reason():
    scenes = [S.magnetic(3.0, 60.0), S.magnetic(20.0, 180.0), S.magnetic(4.0, 100.0)]
    with pytest.raises(Exception, match="unstable equilibrium"):
        solve(scenes[1])
    got = solve_many(scenes)
    assert isinstance(got[1], Failure) and not got[1].converged
    assert "unstable equilibrium" in got[1].reason
    for i in (0, 2):
        assert got[i].converged
        assert np.max(np.abs(got[i].position - solve(scenes[i]).position)) / L < 1e-9


@pytest.mark.parametrize("b", [3, 7])
def test_chain_solve_and_definiteness(b: int) -> None:
    """The condensed, cyclically reduced factorisation against a dense solve and the eigenvalues,
    on element matrices of random symmetric blocks (one indefinite) on meshes of 1 to 13 elements,
    with b fields per node (planar 3, full model 7) and lumped additions on the vertices (diagonal
    and full blocks)."""
    rng = np.random.default_rng(3)
    N = 4
    for ne in (1, 2, 3, 5, 8, 13):
        disc = mesh(ne, (), b, "P2", 2)
        layout = ChainLayout(disc)
        Ke = rng.normal(size=(N, ne, 3 * b, 3 * b))  # [(node k, field i), (node l, field j)], layout order
        shift = np.where(np.arange(N) == 2, 0.0, 10.0 * b)[:, None, None, None] * np.eye(3 * b)
        Ke = Ke + Ke.transpose(0, 1, 3, 2) + shift
        extra = rng.uniform(0.0, 1.0, size=(b, ne + 1, N))
        blocks = rng.uniform(0.0, 0.1, size=(b, b, ne + 1, N))
        blocks = blocks + blocks.transpose(1, 0, 2, 3)
        dense = np.zeros((N, disc.n, disc.n))
        for e in range(ne):
            dofs = (disc.edofs[layout.local, e][:, None] * b + np.arange(b)).ravel()
            dense[:, dofs[:, None], dofs] += Ke[:, e]
        for f in range(b):
            dense[:, layout.vertices * b + f, layout.vertices * b + f] += extra[f].T
            for g in range(b):
                dense[:, layout.vertices * b + f, layout.vertices * b + g] += blocks[f, g].T
        free = np.ones(disc.n, bool)
        free[layout.vertices[0] * b + np.arange(b)] = False
        F = Chain(Ke.reshape(N, ne, 3, b, 3, b).transpose(2, 4, 3, 5, 1, 0), layout, extra, blocks)
        r = np.where(free, rng.normal(size=(N, disc.n)), 0.0)
        K = dense[:, free][:, :, free]
        x = F.solve(r)
        assert np.allclose(x[:, free], np.linalg.solve(K, r[:, free, None])[..., 0], rtol=1e-9, atol=1e-12)
        assert not x[:, ~free].any()
        want = [bool(np.all(np.linalg.eigvalsh(k) > 0)) for k in K]
        assert F.positive_definite(np.arange(N)).tolist() == want
        assert F.positive_definite(np.array([2, 0])).tolist() == [want[2], want[0]]
        assert want[2] is False and want[0] is True
