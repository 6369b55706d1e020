"""The compiled Newton path (matid.rod.kernel) against the jets (the derivative oracle) and
against the numpy path: same residual, same tangent, same iterations, same solutions."""

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("numba")

from matid.bench import scenes as S  # noqa: E402
from matid.bench.peers import precurved_3d  # noqa: E402
from matid.rod import compiled, kernel  # noqa: E402
from matid.rod.fem import Discretisation  # noqa: E402
from matid.rod.models import FULL, PLANAR, RodSystem  # noqa: E402
from matid.rod.solve import solve_cantilever  # noqa: E402
from tests.rod import test_derivatives as derivatives  # noqa: E402 - its rod

#: the derivative tests' rod, with a dead tip moment and a second magnet (both planar-only here)
ROD = replace(derivatives.ROD, tip_moment=(0.0, 0.9, 0.0), magnets=((1.0, 0.8), (0.4, -0.3)))


@pytest.fixture(autouse=True)
def _kernel_on(monkeypatch):
    """These tests are of the kernel itself: they run with MATID_JIT=0 too."""
    monkeypatch.setattr(compiled, "ENABLED", True)


def system(model: str, **kw) -> RodSystem:
    nf = 3 if model == PLANAR else 7
    rod = ROD if model == PLANAR else replace(ROD, magnets=(), tip_moment=(0.0, 0.0, 0.0))
    disc = Discretisation(np.linspace(0.0, 1.0, 6), nf, intorder=2)
    return RodSystem(disc, rod, model=model, c_u=3.0, banded=True, mixed=True, **kw)


@pytest.mark.parametrize("model", [PLANAR, FULL])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_compiled_residual_and_tangent_match_the_jets(model, seed):
    rng = np.random.default_rng(seed)
    ours, jets = system(model), system(model, analytic=False)
    assert compiled.supported(ours)
    X = ours.reduce(ours.reference() + 0.4 * rng.standard_normal(ours.disc.n))
    for lam in (0.37, 1.0):
        R, K = compiled.evaluate(ours, X, lam)
        R_jet, K_jet = jets.evaluate(X, lam)
        K_jet = K_jet.tocsr().toarray()
        assert np.allclose(R, R_jet, rtol=0, atol=1e-12 * np.abs(R_jet).max())
        assert np.allclose(K, K_jet, rtol=0, atol=1e-12 * np.abs(K_jet).max())


@pytest.mark.parametrize(("n", "u"), [(1, 0), (7, 2), (40, 8), (90, 20)])
def test_band_factorisations_solve_the_system(n, u):
    rng = np.random.default_rng(n)
    A = np.zeros((n, n))
    for k in range(u + 1):
        v = rng.standard_normal(n - k)
        A += np.diag(v, -k) + (np.diag(v, k) if k else 0)
    lower = np.zeros((n, u + 1))  # lower[i, t] = A[i, i - u + t]
    for t in range(u + 1):
        i = np.arange(max(0, u - t), n)
        lower[i, t] = A[i, i - u + t]
    b = rng.standard_normal(n)
    abd, ipvt, info = kernel.band_lu(lower, u)
    assert info == 0
    assert np.allclose(A @ kernel.band_lu_solve(abd, ipvt, u, b), b, atol=1e-10)
    spd = A + (2 * u + 2) * 3.0 * np.eye(n)
    L = lower.copy()
    L[:, u] += (2 * u + 2) * 3.0
    assert kernel.cholesky(L, u)
    assert np.allclose(spd @ kernel.cholesky_solve(L, u, b), b, atol=1e-10)
    if n > 1:  # indefinite: Cholesky refuses (the stability test), LU still solves
        L = lower.copy()
        L[:, u] -= 10.0 * np.abs(A).max() * (u + 1)
        assert not kernel.cholesky(L, u)


SCENES = {
    "magnetic": lambda: S.magnetic(6.4, 120.0),
    "tip_force": lambda: S.tip_force(5.0),
    "precurved_3d": precurved_3d,
}


@pytest.mark.parametrize("name", sorted(SCENES))
@pytest.mark.parametrize("elements", [4, 16])
def test_compiled_newton_is_the_numpy_newton(name, elements, monkeypatch):
    """Same iterations, load steps and solution as the numpy path (which the other tests pin)."""
    scene = SCENES[name]()
    fast = solve_cantilever(scene, elements=elements)
    monkeypatch.setattr(compiled, "ENABLED", False)
    slow = solve_cantilever(scene, elements=elements)
    assert (fast.newton_iterations, fast.load_steps) == (slow.newton_iterations, slow.load_steps)
    assert np.allclose(fast.position, slow.position, rtol=0, atol=1e-10 * scene.rod.length)
    assert np.allclose(fast.d3, slow.d3, rtol=0, atol=1e-10)


def test_unsupported_systems_stay_on_the_numpy_path():
    """A dead tip moment in 3D (unsymmetric tangent) and 3D lumped magnets are not compiled."""
    disc = Discretisation(np.linspace(0.0, 1.0, 6), 7, intorder=2)
    assert not compiled.supported(RodSystem(disc, ROD, model=FULL, banded=True))
    no_moment = replace(ROD, tip_moment=(0.0, 0.0, 0.0))
    assert not compiled.supported(RodSystem(disc, no_moment, model=FULL, banded=True))  # magnets
    assert not compiled.supported(RodSystem(disc, replace(no_moment, magnets=()), model=FULL))  # CSR


def test_kernel_cached_looks_where_numba_looks(tmp_path, monkeypatch):
    """With NUMBA_CACHE_DIR set numba reads only there: an empty one means a compile is coming."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert not compiled.kernel_cached()
    index = tmp_path / "some" / "subpath" / "kernel.newton-318.py311.nbi"
    index.parent.mkdir(parents=True)
    index.write_bytes(b"")
    assert compiled.kernel_cached()


def test_a_kernel_that_does_not_import_falls_back_to_numpy(monkeypatch):
    """A broken numba, or no writable cache (numba raises at import: 'cannot cache function'),
    gives one RuntimeWarning and the numpy path's answer, never a failed solve."""
    import sys

    scene = S.magnetic(6.4, 120.0)
    monkeypatch.setattr(compiled, "ENABLED", False)
    expected = solve_cantilever(scene, elements=8).position
    monkeypatch.setattr(compiled, "ENABLED", True)
    monkeypatch.setattr(compiled, "_AVAILABLE", [None])
    monkeypatch.setitem(sys.modules, "matid.rod.kernel", None)  # importing it raises ImportError
    with pytest.warns(RuntimeWarning, match="compiled rod kernel is unavailable"):
        got = solve_cantilever(scene, elements=8).position
    np.testing.assert_array_equal(got, expected)
    assert compiled.supported(system(PLANAR)) is False
