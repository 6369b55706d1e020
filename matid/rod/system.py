"""The clamped rod's residual and tangent for :mod:`matid.rod.newton`: the rod's strain energy
(:mod:`matid.physics.planar`, :mod:`matid.physics.full`) plus the scene's terms (:mod:`matid.rod.terms`).

See :mod:`matid.rod.models` for the scaling and the total energy. The system binds each term once
(its dofs, patterns and point values) and sums, at each evaluation: the strain energy's pointwise
gradient and Hessian with the distributed terms' added in place, one vectorised assembly, then the
nodal loads' residual and tangent blocks, then the constraints' (the unity gauge of the normalised
full model). Only the terms a scene has run: no magnetic term without magnets in a field, no gauge
in the planar model, no precurvature term when it is zero.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from matid.physics import full, planar
from matid.physics import kinematics as kin
from matid.physics.jet import Jet
from matid.rod import stability
from matid.rod.fem import Discretisation
from matid.rod.models import FULL, PLANAR, ScaledRod
from matid.rod.newton import roundoff_floor
from matid.rod.terms import Term, UnityGauge
from matid.rod.terms.base import at_points

#: The names of Solution.terms beyond bending, shear and extension, in the order listed.
LABELS = ("twist", "unity penalty", "magnetic", "precurvature", "point loads")


def term_labels(model: str, rod: ScaledRod, loads, kappa: np.ndarray | None) -> list[str]:
    """The energy terms that run for a rod, its bound load terms and per-point precurvature (or
    None), as Solution.terms lists them."""
    present = {term.label for term in loads if term.label}
    if model == FULL:
        present |= {"twist", "unity penalty"}
    if any(rod.kappa_ref) or kappa is not None:
        present.add("precurvature")
    extra = sorted(present - set(LABELS))
    return ["bending", "shear", "extension"] + [name for name in LABELS if name in present] + extra


@dataclass
class RodSystem:
    """Residual and tangent of a clamped rod and its loads for :mod:`matid.rod.newton`."""

    disc: Discretisation
    rod: ScaledRod
    loads: tuple[Term, ...] = ()  # the scene's terms (matid.rod.terms.loads_of)
    model: str = PLANAR
    variant: str = kin.NORMALISED
    c_u: float = 1.0
    fixed: tuple[int, ...] | None = None  # fixed global dofs; default: clamp at s = 0
    analytic: bool = True  # closed-form derivatives (False: jets, the cross-check)
    banded: bool = False  # tangent in band storage (band.Banded: LAPACK Cholesky/LU) instead of CSR
    mixed: bool = False  # mixed-integration-point tangent in Newton (see mixed_update)
    terms: list[str] = field(init=False)  # the energy terms that run, from the rod, model and loads

    def __post_init__(self) -> None:
        self._stress = self._strain = None
        #: point stresses (ne, nq, ns) for the mixed tangent's first iteration (a warm start
        #: from a coarser mesh's recovered stresses)
        self.stress_start: np.ndarray | None = None
        self.props = at_points(self, self.rod, lambda: self.rod.stiffness_at(self.disc.s_quad))
        nf = self.disc.nf
        free = np.ones(self.disc.n, dtype=bool)
        clamp = self.disc.vertex_dof(0) * nf + np.arange(nf)  # values only (Hermite: slopes stay free)
        free[clamp if self.fixed is None else list(self.fixed)] = False
        self.disc.set_free(free)  # a shared (cached) mesh keeps its patterns when the set is the same
        self.index = self.disc.free_index  # free dof number of each dof, -1 where fixed
        self.tip = self.disc.vertex_dof(self.disc.vertices.size - 1)
        #: per-segment precurvature at the points (None: the rod's, uniform)
        self.kappa = self.rod.kappa_ref_at(self.disc.s_quad)
        gauge = (UnityGauge(self.c_u),) if self.model == FULL and self.variant == kin.NORMALISED else ()
        #: (term, what it prepared for this system): distributed, nodal loads and constraints
        self.distributed = self._bind(t for t in self.loads if t.kind == "distributed")
        self.nodal = self._bind(t for t in self.loads if t.kind == "nodal")
        self.constraints = self._bind(gauge)
        self.terms = self._labels()

    def with_loads(self, loads: tuple[Term, ...]) -> RodSystem:
        """This system (mesh, rod, model, constraints) with other load terms, only those bound anew:
        the same residual as a new RodSystem of them, without building the rest again (the field
        sensitivities of matid.rod.aim evaluate one system per field component)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.__dict__.pop("symmetric", None)  # read off the bound terms
        new.loads = tuple(loads)
        new.distributed = new._bind(t for t in new.loads if t.kind == "distributed")
        new.nodal = new._bind(t for t in new.loads if t.kind == "nodal")
        new.terms = new._labels()
        return new

    def _bind(self, terms) -> list[tuple[Term, object]]:
        return [(term, term.prepare(self)) for term in terms if self.model in term.models]

    def _labels(self) -> list[str]:
        """The energy terms that run, as Solution.terms lists them."""
        return term_labels(self.model, self.rod, [t for t, _ in self.distributed + self.nodal], self.kappa)

    # -- states -------------------------------------------------------------
    def reference(self) -> np.ndarray:
        """Straight rod along the axis, identity rotation."""
        U = np.zeros((self.disc.nscalar, self.disc.nf))
        U[:, 1 if self.model == PLANAR else 2] = self.disc.affine(0.0, 1.0)
        if self.model == FULL:
            U[:, 3] = self.disc.affine(1.0, 0.0)
        return U.ravel()

    def _reference(self) -> np.ndarray:
        """:meth:`reference`, cached per mesh and model (the fixed dofs of :meth:`expand`); read-only."""
        cache = self.disc.__dict__.setdefault("_references", {})
        hit = cache.get(self.model)
        if hit is None or hit[0] is not self.disc.s_dof:  # a moved mesh shares the dict, not s_dof
            U = self.reference()
            U.flags.writeable = False
            hit = cache[self.model] = (self.disc.s_dof, U)
        return hit[1]

    # -- energy density -------------------------------------------------------
    def density(self, u: list, du: list, lam: float):
        """The energy density in jets (the oracle of :meth:`energy_derivatives`)."""
        p, rod = self.props, self.rod
        if self.model == PLANAR:
            x, z, th = u
            k2, nu1, nu3 = kin.planar_strains(du[0], du[1], th, du[2])
            kref = lam * (rod.kappa_ref[1] if self.kappa is None else self.kappa[..., 1])
            w = kin.planar_strain_energy(k2, nu1, nu3, p["E_b"], p["E_s"], p["E_e"], kref)
        else:
            q, dr, dq = u[3:], du[:3], du[3:]
            kappa, nu = kin.strains(dr, q, dq, self.variant)
            kref = [
                lam * (k if self.kappa is None else self.kappa[..., i]) for i, k in enumerate(rod.kappa_ref)
            ]
            w = kin.strain_energy(kappa, nu, p["E_b"], p["E_t"], p["E_s"], p["E_e"], kref)
            if self.variant == kin.RAW:  # the paper's integrated penalty; normalised: terms.gauge
                w = w + kin.unity_penalty(q, self.c_u)
        for term, prep in self.distributed:
            w = w + term.density(self, prep, u, du, lam)
        return w

    def energy_derivatives(self, U: np.ndarray, lam: float, tangent: bool = True):
        """Pointwise gradient and Hessian of the density: the closed forms of
        :mod:`matid.physics.planar` and :mod:`matid.physics.full` plus the distributed terms'; the
        jets of :meth:`density` only when ``analytic`` is off (their test oracle)."""
        options = {"stress": self._stress, "want_strain": self.mixed}
        if not self.analytic:
            variables = Jet.variables(np.concatenate(self.disc.interpolate(U)), hessian=tangent)
            nf = self.disc.nf
            w = self.density(variables[:nf], variables[nf:], lam)
            return w.g, w.h
        z = self.disc.point_values(U)
        kappa_ref = self.rod.kappa_ref if self.kappa is None else self.kappa  # per point: per segment
        if self.model == PLANAR:
            g, H, strain = planar.derivatives(z, lam, self.props, kappa_ref, tangent, **options)
        else:  # the field on a magnetisation along d3 is a row of the full kernel (terms.magnetisation)
            rows = [term.kernel(self, prep) for term, prep in self.distributed]
            mu, B = next((row for row in rows if row is not None), (None, (0.0, 0.0, 0.0)))
            args = (z, lam, self.props, kappa_ref, mu, B, tangent)
            g, H, strain = full.derivatives(*args, variant=self.variant, c_u=self.c_u, **options)
        for term, prep in self.distributed:
            term.derivatives(self, prep, z, lam, g, H if tangent else None)
        if self.mixed and tangent:
            self._strain = strain
        return g, H

    # -- mixed-integration-point Newton (independent stresses at the quadrature points) ----------
    def mixed_reset(self) -> None:
        """Back to the consistent tangent (stresses from the displacements)."""
        self._stress = None

    def converged_stress(self) -> np.ndarray | None:
        """C e(u) (ne, nq, ns) at the points of the last Newton evaluation (mixed systems)."""
        return None if self._strain is None else self._strain[0]

    def hold_stress(self) -> None:
        """Keep the converged state's point stresses for the next Newton solve's first mixed
        tangent (the continuation's next load step); the residual, hence the root, is unchanged."""
        if self.mixed:
            self.stress_start = self.converged_stress()

    def mixed_begin(self) -> None:
        """The first iteration's tangent: from ``stress_start`` when given (mixed), else consistent."""
        self._stress = None if (self.stress_start is None or not self.mixed) else self.stress_start.copy()

    def mixed_update(self, dx: np.ndarray, alpha: float) -> None:
        """Point stresses after a Newton step alpha dx: sigma += alpha (C (e(u) + J du) - sigma).

        The mixed (Hellinger-Reissner) Newton condensed at each point: the right-hand side is
        the ordinary residual, only the tangent's geometric part uses sigma, which follows the
        *linearised* strain. On stiff rods this removes the alternating overshoot of the axial
        strain (theta^2/2 after a rotation step) that costs the displacement Newton its steps;
        at convergence sigma = C e(u), the same solution (Magisano, Leonetti & Garcea 2017).
        """
        if not self.mixed or self._strain is None:
            return
        target = self._linearised(dx)
        old = self._strain[0] if self._stress is None else self._stress
        self._stress = old + alpha * (target - old)

    def settle_stress(self, dx: np.ndarray) -> None:
        """Newton stopped at X + dx without evaluating there (newton's ``accept``): the point stresses
        :meth:`converged_stress` hands on become C (e(u) + J du), the strain linearised at the last
        evaluation (off by O(|dx|^2) times the stiffness, not O(|dx|) as those of the last evaluation)."""
        if self.mixed and self._strain is not None:
            self._strain = (self._linearised(dx), self._strain[1])

    def _linearised(self, dx: np.ndarray) -> np.ndarray:
        """C (e(u) + J du) at the points: the stresses after the free-dof correction dx, linearised."""
        sigma_u, CJ = self._strain
        dU = np.zeros(self.disc.n)
        dU[self.disc.free] = dx
        dz = self.disc.point_values(dU)  # P + (2 nf,)
        return sigma_u + np.matmul(CJ, dz[..., None])[..., 0]

    @functools.cached_property
    def roundoff(self) -> float:
        """Smallest Newton correction distinguishable from round-off: eps times the stiffness spread
        (of the stiffnesses bound at construction; read once, each Newton solve asks)."""
        stiff = max([float(v.max()) for v in self.props.values()])  # the method: no np.max dispatch
        return float(roundoff_floor(stiff))

    # -- residual and tangent on the free dofs ---------------------------------
    def evaluate(
        self,
        X: np.ndarray,
        lam: float,
        *,
        tangent: bool = True,
        U: np.ndarray | None = None,
        full: bool = False,
    ):
        """Residual on the free dofs (``full``: on every dof; at the fixed ones it is the supports'
        reaction) and, with ``tangent``, its Jacobian (banded or CSR)."""
        U = self.expand(X) if U is None else U
        g, H = self.energy_derivatives(U, lam, tangent)
        self.last_points = (U, g, H)  # pointwise derivatives of this evaluation (bend: dR/dsigma)
        if self.banded:
            R = self.disc.residual(g)
            K = self.disc.tangent(H, self.symmetric) if tangent else None
        else:
            R, K = self.disc.assemble(g, H)
        blocks: list = []
        for group in (self.nodal, self.constraints):  # each group's residual summed, then added
            if group:
                Rn = np.zeros(self.disc.n)
                for term, prep in group:
                    term.nodal(self, prep, U, lam, Rn, blocks)
                R += Rn
        for pattern, values in blocks if tangent else ():
            if self.banded:
                K.add(pattern, values)
            else:
                entries = (values.reshape(-1)[pattern.keep], (pattern.rows, pattern.cols))
                K = K + sp.csr_matrix(entries, shape=K.shape)
        return (R if full else R[self.disc.free]), K

    def branch(self) -> tuple:
        """The smooth pieces of the last evaluation (:meth:`Term.branch` of each nodal term)."""
        return tuple(term.branch(prep) for term, prep in self.nodal)

    @functools.cached_property
    def symmetric(self) -> bool:
        """The tangent is a Hessian, except with a dead moment in 3D (no potential); the bound terms
        are fixed at construction, so this is read once (each evaluation asks)."""
        bound = self.distributed + self.nodal + self.constraints
        return all(term.symmetric(self) for term, _ in bound)

    def reject(self, X: np.ndarray, lam: float, factor: object = None) -> str | None:
        """Why a converged state is no answer, or None: an unstable equilibrium is not one a rod can
        hold (used by :func:`matid.rod.newton.follow` to halve the load step).

        ``factor``: Newton's last factorised tangent; a successful banded Cholesky of it
        (every pivot > 0) is the stability test, read off without a second factorisation.
        """
        for term, prep in self.nodal + self.constraints:
            if type(term).reject is not Term.reject:  # a term with states that are no answer
                reason = term.reject(self, prep, self.expand(X), lam)
                if reason:
                    return reason
        if getattr(factor, "positive_definite", None) is True:
            return None
        if self.negative_modes(X, lam):
            if not self.symmetric:
                w = self.unstable[0]
                return (
                    f"unstable equilibrium: {self.unstable.size} eigenvalue(s) of the tangent with a "
                    f"non-positive real part (lowest {w.real:.3g}{w.imag:+.3g}j; a dead moment in 3D, "
                    "judged on overdamped slender-rod dynamics: matid.rod.stability)"
                )
            return "unstable equilibrium (the tangent stiffness is not positive definite: buckling or snap)"
        return None

    def negative_modes(self, X: np.ndarray, lam: float) -> int | None:
        """Unstable modes of the tangent at X: 0 iff the state is stable (:mod:`matid.rod.stability`);
        None when the test cannot be made.

        Symmetric tangent: its non-positive L D L^T pivots. With a dead moment in 3D (no
        potential): 0 when the symmetric part is positive definite (positive second-order work:
        stable whatever the dissipation), else the eigenvalues of the pencil (K, D) with a
        non-positive real part, D the drag of :func:`matid.rod.stability.drag` (kept in
        ``self.unstable``).
        """
        K = self.evaluate(X, lam)[1]
        csr = K.tocsr()
        if self.symmetric:
            return stability.ldl_negative(csr)
        if stability.ldl_negative((csr + csr.T) * 0.5) == 0:
            return 0
        self.unstable = stability.unstable_modes(csr, self.drag, getattr(K, "factor", None))
        return int(self.unstable.size)

    @functools.cached_property
    def drag(self):
        """The dissipation of the stability test of loads without a potential (built once)."""
        return stability.drag(self.disc)

    def expand(self, X: np.ndarray) -> np.ndarray:
        U = self._reference().copy()
        U[self.disc.free] = X
        return U

    def reduce(self, U: np.ndarray) -> np.ndarray:
        return U[self.disc.free].copy()

    def project(self, X: np.ndarray) -> np.ndarray:
        """X with each node's q put back on |q| = 1 (newton, after a correction above PROJECT_ABOVE).

        In the normalised full model the directors are those of q/|q|: at the nodes the projection
        changes no director, only the gauge the unity penalty holds, which an additive step of
        size h leaves off by O(h^2) (Newton's next step would spend itself on pulling it back).
        Between the nodes q is interpolated, so the directors at the points move by O(h^2) too:
        no converged state is projected. Other models, the raw variant and a piecewise residual (a
        contact's active set: there the projection made the set cycle, a tube on its lumen's wall
        in tests/rod/test_contact_short_stretch.py): X unchanged."""
        smooth = all(term.branch(prep) is None for term, prep in self.nodal)
        if self.model != FULL or self.variant != kin.NORMALISED or not smooth:
            return X
        U = self.expand(X).reshape(self.disc.nscalar, self.disc.nf)
        q = U[self.disc.value_dofs, 3:7]  # the point values (the Hermite's slopes keep theirs)
        U[self.disc.value_dofs, 3:7] = q / np.linalg.norm(q, axis=1, keepdims=True)
        return self.reduce(U.ravel())
