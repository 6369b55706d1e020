"""Warm starts of the error estimate's finer meshes: the coarse state and its recovered point
stresses change the iterations, never the answer."""

import numpy as np
import pytest

from matid.bench import scenes as S
from matid.bench.peers import precurved_3d
from matid.rod import starts
from matid.rod.cantilever import Equilibrium, equilibrium, mesh
from matid.rod.transfer import stress_recovery

SCENES = {
    "magnetic": lambda: S.magnetic(6.4, 120.0),
    "tip_force": lambda: S.tip_force(5.0),
    "3d": precurved_3d,
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_warm_start_converges_to_the_cold_answer_in_fewer_iterations(name, monkeypatch):
    scene = SCENES[name]()
    coarse = equilibrium(scene, elements=8)
    # cold: the continuation from the straight rod (the magnetic scene's own cold start, the rod
    # turned into the field, is as close as the plain warm start: tests/rod/test_aligned.py)
    monkeypatch.setattr(starts, "aligned", lambda system: None)
    cold = equilibrium(scene, elements=16)
    plain = equilibrium(scene, elements=16, start=coarse.state())  # nodal values only
    warm = equilibrium(scene, elements=16, start=coarse)  # with the recovered stresses
    assert warm.info.steps == plain.info.steps == 1  # no continuation: Newton from the start state
    for other in (plain, warm):
        assert np.allclose(other.U, cold.U, rtol=0, atol=1e-9)
    assert warm.info.iterations <= plain.info.iterations < cold.info.iterations


def test_stress_recovery_is_exact_for_linear_stresses():
    """Linear through each coarse element's two Gauss points: a linear field comes back exactly."""
    coarse_mesh, fine_mesh = mesh(4, (), 3, "P2", 2), mesh(8, (), 3, "P2", 2)
    s = coarse_mesh.s_quad
    field = np.stack([2.0 - 3.0 * s, 0.5 + s], axis=-1)
    eq = Equilibrium(
        None, "planar", coarse_mesh, np.zeros((coarse_mesh.nscalar, 3)), None, None, 0.0, (), field
    )
    recovered = eq.stress_at(fine_mesh)
    t = fine_mesh.s_quad
    assert recovered.shape == fine_mesh.s_quad.shape + (2,)
    assert np.allclose(recovered, np.stack([2.0 - 3.0 * t, 0.5 + t], axis=-1), rtol=0, atol=1e-14)


def test_a_segment_edited_in_place_is_solved_again():
    """The last scene's preparation is remembered between solves; editing a segment's overrides
    dict in place (the one mutable part of a frozen scene) must not return the old answer."""
    from matid.rod.cantilever import solve_cantilever
    from matid.rod.scenes import Loads, Rod, Scene, SegmentSpec

    seg = SegmentSpec(0.0, 0.05, {"E_b": 1e-4})
    scene = Scene(
        "cantilever",
        Rod(0.1, 1e-4, 1e-4, 10.0, 10.0, segments=(seg,)),
        Loads(tip_force=(1e-3, 0, 0)),
        elements=8,
    )
    stiff = solve_cantilever(scene).position[-1]
    seg.overrides["E_b"] = 1e-5
    soft = solve_cantilever(scene).position[-1]
    fresh = solve_cantilever(
        Scene(
            "cantilever",
            Rod(0.1, 1e-4, 1e-4, 10.0, 10.0, segments=(SegmentSpec(0.0, 0.05, {"E_b": 1e-5}),)),
            Loads(tip_force=(1e-3, 0, 0)),
            elements=8,
        )
    ).position[-1]
    assert soft[0] > 2 * stiff[0]
    np.testing.assert_allclose(soft, fresh, rtol=1e-12)


def test_stress_recovery_in_a_piece_is_exact_for_quadratics_and_never_reaches_across_a_break():
    """With the breaks: Lagrange through the element's two Gauss points and the nearest one of each
    neighbour in the same piece (cubic inside it, quadratic in its end elements), so a stress that
    jumps at a break is recovered on each side from that side only."""
    coarse_mesh, fine_mesh = mesh(8, (0.5,), 3, "P2", 2), mesh(16, (0.5,), 3, "P2", 2)
    s, t = coarse_mesh.s_quad.ravel(), fine_mesh.s_quad.ravel()
    quadratic = lambda x: 1.0 - 2.0 * x + 3.0 * x**2  # noqa: E731
    jump = lambda x: quadratic(x) + (x > 0.5)  # noqa: E731
    args = (coarse_mesh.vertices.tobytes(), s.tobytes(), t.tobytes())
    R = stress_recovery(*args, np.array([0.0, 0.5, 1.0]).tobytes())
    assert np.allclose(R @ quadratic(s), quadratic(t), rtol=0, atol=1e-12)
    assert np.allclose(R @ jump(s), jump(t), rtol=0, atol=1e-12)
    linear = stress_recovery(*args)
    assert np.abs(linear @ quadratic(s) - quadratic(t)).max() > 1e-4  # the linear one is not: it can tell
