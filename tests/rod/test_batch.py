"""The stacked Newton of matid.rod.batch / matid.rod.many against one solve per scene."""

from __future__ import annotations

import numpy as np
import pytest

from matid.bench import scenes as S
from matid.rod.api import solve
from matid.rod.band import BlockTridiagonal
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


def test_block_tridiagonal_solve_and_definiteness():
    rng = np.random.default_rng(3)
    N, nb, b = 4, 5, 3
    n = nb * b
    K = np.zeros((N, n, n))
    for i in range(N):
        A = np.triu(np.tril(rng.normal(size=(n, n)), b), -b)  # half-bandwidth b
        A = A + A.T
        K[i] = A + (np.abs(A).sum(1).max() + 0.5 if i != 2 else 0.0) * np.eye(n)  # dominant: definite
    T = np.zeros((N, nb, b, 3 * b))
    for k in range(nb):
        for j, kk in enumerate((k - 1, k, k + 1)):
            if 0 <= kk < nb:
                T[:, k, :, j * b : (j + 1) * b] = K[:, k * b : (k + 1) * b, kk * b : (kk + 1) * b]
    r = rng.normal(size=(N, n))
    F = BlockTridiagonal(T)
    assert np.allclose(F.solve(r), np.linalg.solve(K, r[..., None])[..., 0])
    want = [bool(np.all(np.linalg.eigvalsh(k) > 0)) for k in K]
    assert F.positive_definite(np.arange(N)).tolist() == want
    assert want[2] is False and want[0] is True
