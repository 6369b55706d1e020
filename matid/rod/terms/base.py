"""What a load (or a constraint) on the clamped rod gives :class:`matid.rod.system.RodSystem`.

A term is frozen data in scaled units (see :mod:`matid.rod.models`), built from a scene by its
module's ``from_scene(scene, scale)``, which returns None when the scene has no such load: a
scene builds only the terms it has. The system binds each term once (:meth:`Term.prepare`: its
dofs, tangent patterns and values at the quadrature points) and sums, at every evaluation,

- a *distributed* term's pointwise gradient and Hessian (:meth:`Term.derivatives`, in place,
  before the one vectorised assembly) and, for the jets that check them, its energy density
  (:meth:`Term.density`);
- a *nodal* term's residual and tangent blocks on node-local dofs (:meth:`Term.nodal`), the
  virtual work of a load that has no potential (a dead moment in 3D) included.

A term says what it needs: the models it runs in (``models``), whether its tangent is a
Hessian (:meth:`Term.symmetric`), and whether a converged state is no answer for it
(:meth:`Term.reject`: a unilateral contact's pulling reaction, say). A contact with a wall is
such a term: its gap and active set from U in :meth:`Term.nodal` (blocks on the candidate
nodes, patterns built once in :meth:`Term.prepare`), its admissibility in :meth:`Term.reject`.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from matid.rod.models import FULL, PLANAR


class Term:
    """Base of the rod's terms; every method is a no-op (see the module docstring)."""

    #: name in Solution.terms ("magnetic", "point loads"), or None: not listed
    label: ClassVar[str | None] = None
    #: the models the term runs in
    models: ClassVar[tuple[str, ...]] = (PLANAR, FULL)
    #: where the system calls it: "distributed" (pointwise, before assembly) or "nodal"
    kind: ClassVar[str] = "nodal"

    def prepare(self, system) -> object:
        """What one system needs at every evaluation, built once (dofs, patterns, point values)."""
        return None

    def symmetric(self, system) -> bool:
        """Whether the term's tangent is a Hessian (False: a dead moment in 3D, no potential)."""
        return True

    def density(self, system, prep, u: list, du: list, lam: float):
        """Energy density at the points (jets: the oracle of :meth:`derivatives`)."""
        return 0.0

    def derivatives(self, system, prep, z: np.ndarray, lam: float, g: np.ndarray, H) -> None:
        """Add the pointwise gradient and Hessian (H None: residual only) at point values z."""

    def kernel(self, system, prep) -> tuple | None:
        """(mu at the points, B): a field on a magnetisation along d3 in the full model, which the
        strain kernel differentiates as one more row (:func:`matid.physics.full.derivatives`); None
        for any other term."""
        return None

    def nodal(self, system, prep, U: np.ndarray, lam: float, R: np.ndarray, blocks: list) -> None:
        """Add the residual (all dofs) and append the tangent blocks [(pattern, values)]."""

    def reject(self, system, prep, U: np.ndarray, lam: float) -> str | None:
        """Why a converged state is no answer for this term, or None."""
        return None

    def branch(self, prep) -> bytes | None:
        """Which smooth piece of a piecewise-smooth residual the last :meth:`nodal` evaluated on
        (a contact's active set), or None for a smooth term: Newton judges its convergence only
        between evaluations on one piece (:attr:`matid.rod.system.RodSystem.branch`)."""
        return None


class Scale:
    """SI to scaled units of a scene (lengths by L, forces by E_b/L^2, moments by E_b/L), and
    the planar projection onto (transverse, -, axial) when the plane direction e_a is given."""

    def __init__(self, length: float, E_b: float, e_a: np.ndarray | None):
        self.L, self.E_b = length, E_b
        self.e_a = None if e_a is None else (float(e_a[0]), float(e_a[1]))  # e_a horizontal

    def vec(self, v, factor: float) -> tuple[float, float, float]:
        """A force-like vector times ``factor``; planar: its (transverse, normal, axial) components."""
        v = [float(c) * factor for c in v]
        if self.e_a is None:
            return tuple(v)
        a0, a1 = self.e_a  # n = e3 x e_a = (-a1, a0, 0)
        return (v[0] * a0 + v[1] * a1, -v[0] * a1 + v[1] * a0, v[2])

    def moment(self, v, factor: float) -> tuple[float, float, float]:
        """A moment-like vector times ``factor``; planar: only its component about n."""
        w = self.vec(v, factor)
        return w if self.e_a is None else (0.0, w[1], 0.0)

    def force(self, v) -> tuple[float, float, float]:
        return self.vec(v, self.L**2 / self.E_b)

    def torque(self, v) -> tuple[float, float, float]:
        return self.moment(v, self.L / self.E_b)


def node(system, s: float) -> int:
    """The scalar dof of the mesh vertex nearest to scaled arc length s."""
    return system.disc.nearest_vertex_dof(s)


def q_dofs(nodes, nf: int) -> np.ndarray:
    """The global dofs (k, 4) of q at the scalar dofs ``nodes`` (full model: r, q are fields 0-2, 3-6)."""
    return np.asarray(nodes, int).reshape(-1, 1) * nf + 3 + np.arange(4)


def at_points(system, key: object, make):
    """``make()`` (arrays at the mesh's quadrature points), remembered per mesh and ``key`` (a cached
    mesh serves every solve of a scene); read-only arrays."""
    disc = system.disc
    cache = disc.__dict__.setdefault("_fields", {})
    hit = cache.get(key)
    if hit is None or hit[0] is not disc.s_quad:  # a moved mesh shares the dict, not the points
        if len(cache) > 32:
            cache.clear()
        hit = cache[key] = (disc.s_quad, make())
    return hit[1]
