"""The bend's compiled rod (matid.rod.bend_kernel) against the numpy path of BendSystem (issue 13):
same residual, bordered tangent (rod block, dR/dsigma, contact rows), stiffness derivatives
and path, on random states and moved meshes."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from matid.rod import bend_compiled, compiled  # noqa: E402
from matid.rod.bend import BendGeometry, BendModel  # noqa: E402

pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="MATID_JIT=0: no compiled path")

E_B, E_S, E_E = 6.5e-5, 21.0, 120.0
GEOMETRY = BendGeometry(0.01, 0.03, 2e-3, 2e-3, 2.4e-3)


def pair(elements: int, E_s: float = E_S):
    """(compiled, numpy) systems of the same bend."""
    model = BendModel(GEOMETRY, elements=elements)
    ours, numpy_path = (model.system(E_B, E_s, E_E, 1e-3) for _ in range(2))
    numpy_path.jit = None
    assert ours.jit is not None
    return ours, numpy_path


def random_state(system, rng) -> np.ndarray:
    X = system.initial()
    X[: system.nu] += 0.05 * rng.standard_normal(system.nu)
    X[system.nu : system.nu + 2] = rng.uniform(0.1, 2.0, 2)
    X[-1] = rng.uniform(0.3, 0.8)  # the support vertex moves the mesh
    return X


def close(a, b, scale=None) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return np.allclose(a, b, rtol=0, atol=1e-13 * (np.abs(b).max() if scale is None else scale))


@pytest.mark.parametrize(("elements", "E_s"), [(6, E_S), (24, E_S), (24, 0.3)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_bend_residual_and_tangent_equal_numpy(elements, E_s, seed):
    rng = np.random.default_rng(seed)
    ours, oracle = pair(elements, E_s)
    for _ in range(2):  # a second state on another mesh: the work arrays are reused
        X, lam = random_state(ours, rng), rng.uniform(0.0, 1.0)
        (R, A), (R_np, A_np) = ours.evaluate(X, lam), oracle.evaluate(X, lam)
        assert close(R, R_np)
        assert close(A.K.tocsr().toarray(), A_np.K.tocsr().toarray())
        assert close(A.K.ab, A_np.K.ab)  # the band storage itself, both triangles
        assert close(A.B, A_np.B) and np.array_equal(A.C, A_np.C)
        # the bordered solves the path uses (Newton correction, sensitivities): equal up to the
        # entries' round-off (1e-15 relative, above) times the condition number of the system
        F, F_np = A.factor(), A_np.factor()
        cond = np.linalg.cond(A_np.tocsr().toarray())
        pairs = [(F.solve(-R), F_np.solve(-R_np))]
        d, d_np = ours.derivatives(X, lam, F, True), oracle.derivatives(X, lam, F_np, True)
        pairs += [(d[name], d_np[name]) for name in ("lam", "E_s", "E_e")]
        for a, b in pairs:
            assert np.allclose(a, b, rtol=0, atol=1e-15 * cond * np.abs(b).max())
        assert close(ours.evaluate(X, lam, tangent=False)[0], R_np)


@pytest.mark.parametrize("seed", [3, 4])
def test_compiled_stiffness_and_mesh_derivatives_equal_numpy_and_differences(seed):
    rng = np.random.default_rng(seed)
    ours, oracle = pair(12)
    X, lam = random_state(ours, rng), 0.4
    dR = ours.jit.stiffness_residuals(ours.jit.expand(X[: ours.nu]), X[-1])
    for j, name in enumerate(("E_s", "E_e")):
        assert close(dR[:, j], oracle.stiffness_derivative(X, name)[: ours.nu])
    # dR/dsigma (the bordered system's third column) against central differences of R
    _, A = ours.evaluate(X, lam)
    h = 1e-6
    Xp, Xm = X.copy(), X.copy()
    Xp[-1] += h
    Xm[-1] -= h
    diff = (ours.evaluate(Xp, lam, tangent=False)[0] - ours.evaluate(Xm, lam, tangent=False)[0]) / (2 * h)
    assert np.allclose(A.B[:, 2], diff[: ours.nu], rtol=0, atol=1e-6 * np.abs(diff).max())


def test_compiled_and_numpy_paths_give_the_same_forces_and_sensitivities():
    d = np.linspace(0.0, 1e-3, 6)
    paths = []
    for jit in (True, False):
        model = BendModel(GEOMETRY, elements=10)
        system = model.system
        if not jit:  # the same model with every system on the numpy path

            def system(*args, _make=model.system):
                out = _make(*args)
                out.jit = None
                return out

        model.system = system
        paths.append(model.solve(E_B, E_S, E_E, d, sensitivities=("E_s", "E_b", "E_e")))
    ours, numpy_path = paths
    assert ours.newton_iterations == numpy_path.newton_iterations
    assert np.allclose(ours.force, numpy_path.force, rtol=1e-12, atol=0)
    for name in ("E_s", "E_b", "E_e"):
        assert np.allclose(ours.dforce[name], numpy_path.dforce[name], rtol=1e-9, atol=1e-12)


def test_the_kernel_serves_new_systems_once_numpy_evaluations_pass_the_warmup(monkeypatch):
    monkeypatch.delenv("MATID_JIT", raising=False)
    monkeypatch.setattr(bend_compiled, "_numba_loaded", lambda: False)
    monkeypatch.setattr(bend_compiled, "WARMUP", 3)
    monkeypatch.setattr(bend_compiled, "_numpy_evaluations", 0)
    model = BendModel(GEOMETRY, elements=6)
    first = model.system(E_B, E_S, E_E, 1e-3)
    assert first.jit is None  # a short job: numba is not loaded for it
    X = first.initial()
    for _ in range(3):
        first.evaluate(X, 0.5)
    assert model.system(E_B, E_S, E_E, 1e-3).jit is not None
    monkeypatch.setattr(bend_compiled, "_numpy_evaluations", 0)
    monkeypatch.setenv("MATID_JIT", "1")  # asked for: from the first system
    assert model.system(E_B, E_S, E_E, 1e-3).jit is not None
