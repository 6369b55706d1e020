"""Independent checks of a returned planar cantilever state: residual and stability.

The bench rebuilds the planar system of :func:`matid.rod.cantilever.solve_cantilever`
on the same mesh, puts the returned state (positions, angles) back into it, and
evaluates the residual (is it an equilibrium?) and the reduced tangent (is it a
stable one?). A stable equilibrium of a conservative system has a positive
definite tangent; the dense ``eigvalsh`` of the symmetrised tangent gives its
smallest eigenvalue. A negative one below round-off (``-EIG_ROUNDOFF *
max |eigenvalue|``) marks an unstable equilibrium.
"""

from __future__ import annotations

import numpy as np

from matid.rod.scenes import Scene

MAX_DENSE = 2000  # dofs; larger meshes skip the dense eigenvalue check
EIG_ROUNDOFF = 1e-9


def planar_state_check(scene: Scene, sol) -> dict:
    """Residual, extreme eigenvalues and 'stable' of the returned state, or {'check': why not}."""
    try:
        system, X = _rebuild(scene, sol)
        R, K = system.evaluate(X, 1.0)
    except Exception as exc:  # noqa: BLE001 - the check is optional: say why it could not run
        return {"check": f"unavailable: {type(exc).__name__}: {exc}"}
    out = {"residual": float(np.max(np.abs(R))) if R.size else 0.0}
    if K.shape[0] > MAX_DENSE:
        return {**out, "check": f"no eigenvalues (more than {MAX_DENSE} dofs)"}
    dense = K.toarray()
    w = np.linalg.eigvalsh(0.5 * (dense + dense.T))
    scale = float(np.max(np.abs(w)))
    return {
        **out,
        "min_eigenvalue": float(w[0]),
        "max_eigenvalue": float(w[-1]),
        "stable": bool(w[0] > -EIG_ROUNDOFF * scale),
        "check": "ok",
    }


def _rebuild(scene: Scene, sol):
    from matid.rod import cantilever as solve_mod
    from matid.rod.fem import Discretisation
    from matid.rod.models import PLANAR
    from matid.rod.scenes import plane_of
    from matid.rod.system import RodSystem

    if sol.model != PLANAR or sol.element != "P2":
        raise ValueError("only planar P2 solutions are checked")
    e_a, e3 = np.asarray(plane_of(scene)), np.array([0.0, 0.0, 1.0])
    vertices = np.asarray(sol.s)[::2] / scene.rod.length  # P2 nodes: vertex, mid-point, vertex, ...
    disc = Discretisation(vertices, 3, element="P2", intorder=2)
    system = RodSystem(disc, *solve_mod.scaled(scene, e_a), model=PLANAR)
    L = scene.rod.length
    order = np.argsort(disc.s_dof)
    if not np.allclose(disc.s_dof[order] * L, sol.s, rtol=0, atol=1e-12 * L):
        raise ValueError("the solution's nodes do not match the rebuilt mesh")
    U = np.zeros((disc.nscalar, 3))
    position, d3 = np.asarray(sol.position) / L, np.asarray(sol.d3)
    U[order, 0], U[order, 1] = position @ e_a, position @ e3
    U[order, 2] = np.unwrap(np.arctan2(d3 @ e_a, d3 @ e3))
    return system, system.reduce(U.ravel())
