"""The clamped rod's residual and tangent for :mod:`matid.rod.newton` (see :mod:`matid.rod.models`
for the scaling and the total energy)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from matid.physics import full, planar
from matid.physics import kinematics as kin
from matid.physics.jet import Jet
from matid.rod.fem import Discretisation
from matid.rod.models import FULL, PLANAR, ScaledRod

_DIAG4 = np.arange(4)


@dataclass
class RodSystem:
    """Residual and tangent of a clamped rod for :mod:`matid.rod.newton`."""

    disc: Discretisation
    rod: ScaledRod
    model: str = PLANAR
    variant: str = kin.NORMALISED
    c_u: float = 1.0
    fixed: tuple[int, ...] | None = None  # fixed global dofs; default: clamp at s = 0
    analytic: bool = True  # planar: closed-form derivatives (False: jets, the cross-check)
    banded: bool = False  # tangent in band storage (band.Banded: LAPACK Cholesky/LU) instead of CSR
    mixed: bool = False  # mixed-integration-point tangent in Newton (see mixed_update)
    terms: list[str] = field(init=False)  # the energy terms that run, from the rod and model

    def __post_init__(self) -> None:
        self._stress = self._strain = None
        #: point stresses (ne, nq, ns) for the mixed tangent's first iteration (a warm start
        #: from a coarser mesh's recovered stresses)
        self.stress_start: np.ndarray | None = None
        self.props, self.mu = _fields(self.disc, self.rod)
        nf = self.disc.nf
        free = np.ones(self.disc.n, dtype=bool)
        clamp = self.disc.vertex_dof(0) * nf + np.arange(nf)  # values only (Hermite: slopes stay free)
        free[clamp if self.fixed is None else list(self.fixed)] = False
        self.disc.set_free(free)  # a shared (cached) mesh keeps its patterns when the set is the same
        self.index = self.disc.free_index  # free dof number of each dof, -1 where fixed
        self.tip = self.disc.vertex_dof(self.disc.vertices.size - 1)
        verts = self.disc.vertices
        node = lambda s_p: self.disc.vertex_dof(int(np.argmin(np.abs(verts - s_p))))  # noqa: E731
        self.magnet_nodes = [(node(s_m), m) for s_m, m in self.rod.magnets]
        #: per-segment precurvature and off-axis magnetisation at the points, point loads at nodes
        self.kappa = self.rod.kappa_ref_at(self.disc.s_quad)
        directed = self.mu_directed = (
            self.rod.directed_mu_at(self.disc.s_quad) if self.rod.has_field else None
        )
        #: their maps M (points, 4, 4) of physics.full.directed_maps, built once per system
        self._directed_point_M = (
            None if directed is None else full.directed_maps(self.rod.B, directed.reshape(-1, 3))
        )
        self.directed_nodes = [(node(s_m), m, np.asarray(a)) for s_m, m, a in self.rod.directed_magnets]
        self.point_nodes = [(node(s_p), np.asarray(F), np.asarray(M)) for s_p, F, M in self.rod.point_loads]
        optional = {
            "twist": self.model == FULL,
            "unity penalty": self.model == FULL,
            "magnetic": self.rod.has_field,
            "precurvature": any(self.rod.kappa_ref) or self.kappa is not None,
            "point loads": bool(self.point_nodes),
        }
        self.terms = ["bending", "shear", "extension"] + [name for name, on in optional.items() if on]
        self._node_patterns()

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
        p, rod = self.props, self.rod
        if self.model == PLANAR:
            x, z, th = u
            k2, nu1, nu3 = kin.planar_strains(du[0], du[1], th, du[2])
            kref = lam * (rod.kappa_ref[1] if self.kappa is None else self.kappa[..., 1])
            w = kin.planar_strain_energy(k2, nu1, nu3, p["E_b"], p["E_s"], p["E_e"], kref)
            if "magnetic" in self.terms:
                w = w + kin.magnetic_energy(
                    lam * self.mu, [kin.jet.sin(th), 0.0, kin.jet.cos(th)], [rod.B[0], 0.0, rod.B[2]]
                )
            if any(rod.f):
                w = w - lam * (rod.f[0] * x + rod.f[2] * z)
            return w
        r, q, dr, dq = u[:3], u[3:], du[:3], du[3:]
        kappa, nu = kin.strains(dr, q, dq, self.variant)
        kref = [lam * (k if self.kappa is None else self.kappa[..., i]) for i, k in enumerate(rod.kappa_ref)]
        w = kin.strain_energy(kappa, nu, p["E_b"], p["E_t"], p["E_s"], p["E_e"], kref)
        if self.variant == kin.RAW:  # the paper's integrated penalty; normalised: see gauge_terms
            w = w + kin.unity_penalty(q, self.c_u)
        if "magnetic" in self.terms:
            w = w + kin.magnetic_energy(lam * self.mu, kin.d3(q, self.variant), rod.B)
        if self.mu_directed is not None:
            w = w + sum(
                kin.magnetic_energy(lam * self.mu_directed[..., j], kin.director(q, j, self.variant), rod.B)
                for j in range(3)
            )
        if any(rod.f):
            w = w - lam * (rod.f[0] * r[0] + rod.f[1] * r[1] + rod.f[2] * r[2])
        return w

    def energy_derivatives(self, U: np.ndarray, lam: float, tangent: bool = True):
        """Pointwise gradient and Hessian of the density: the closed forms of
        :mod:`matid.physics.planar` and :mod:`matid.physics.full`; the jets of :meth:`density`
        only when ``analytic`` is off (their test oracle)."""
        rod = self.rod
        mu = self.mu if "magnetic" in self.terms else None
        options = {"stress": self._stress, "want_strain": self.mixed}
        if not self.analytic:
            variables = Jet.variables(np.concatenate(self.disc.interpolate(U)), hessian=tangent)
            nf = self.disc.nf
            w = self.density(variables[:nf], variables[nf:], lam)
            return w.g, w.h
        z = self.disc.point_values(U)
        kappa_ref = rod.kappa_ref if self.kappa is None else self.kappa  # per point: per segment
        args = (z, lam, self.props, kappa_ref, mu, rod.B, rod.f, tangent)
        if self.model == PLANAR:
            g, H, strain = planar.derivatives(*args, **options)
        else:
            g, H, strain = full.derivatives(*args, variant=self.variant, c_u=self.c_u, **options)
            if self.mu_directed is not None:  # magnetisation off d3 (contract section 9)
                full.directed_magnetic(g, H, z, lam, self._directed_point_M, self.variant)
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
        sigma_u, CJ = self._strain
        dU = np.zeros(self.disc.n)
        dU[self.disc.free] = dx
        dz = self.disc.point_values(dU)  # P + (2 nf,)
        target = sigma_u + np.matmul(CJ, dz[..., None])[..., 0]
        old = sigma_u if self._stress is None else self._stress
        self._stress = old + alpha * (target - old)

    @property
    def roundoff(self) -> float:
        """Smallest Newton correction distinguishable from round-off: eps times the stiffness spread."""
        stiff = max([float(v.max()) for v in self.props.values()])  # the method: no np.max dispatch
        return 1e-15 * max(stiff, 1.0)

    # -- point terms (tip loads, lumped magnets, the nodal unity penalty) -------------------
    def _node_patterns(self) -> None:
        """Dofs (a magnet's: theta, or q) and tangent patterns of the node-local terms, built once
        per system (None: no such term)."""
        disc, nf = self.disc, self.disc.nf
        self._tip = np.arange(self.tip * nf, self.tip * nf + nf)
        nodes = np.array([node for node, _ in self.magnet_nodes], int)
        self._magnet_dofs = nodes[:, None] * nf + 2 if self.model == PLANAR else _q_dofs(nodes, nf)
        self._magnet_m = np.array([m for _, m in self.magnet_nodes], float)
        self._patterns = {"magnets": disc.block_pattern(self._magnet_dofs) if self.magnet_nodes else None}
        if self.model == FULL:
            self._patterns["moment"] = disc.block_pattern(self._tip[3:])
            self._gauge_dofs = _q_dofs(disc.value_dofs, nf)
            self._patterns["gauge"] = disc.block_pattern(self._gauge_dofs)
            values, slopes = disc.slope_pairs  # Hermite: (q, q') at each vertex
            self._slope_dofs = np.concatenate([_q_dofs(values, nf), _q_dofs(slopes, nf)], axis=1)
            self._patterns["slopes"] = disc.block_pattern(self._slope_dofs) if values.size else None
            self._designer_patterns()

    def _designer_patterns(self) -> None:
        """Dofs, maps and patterns of off-axis magnets and interior dead moments (full model)."""
        disc, nf = self.disc, self.disc.nf
        self._directed_dofs = _q_dofs([node for node, _, _ in self.directed_nodes], nf)
        moments = np.array([m * np.asarray(a, float) for _, m, a in self.directed_nodes]).reshape(-1, 3)
        self._directed_M = full.directed_maps(self.rod.B, moments)
        self._patterns["directed"] = disc.block_pattern(self._directed_dofs) if self.directed_nodes else None
        loaded = [(node, M) for node, _, M in self.point_nodes if any(M)]
        self._moment_dofs = _q_dofs([node for node, _ in loaded], nf)
        self._point_moments = np.array([M for _, M in loaded], float).reshape(-1, 3)
        self._patterns["point moments"] = disc.block_pattern(self._moment_dofs) if loaded else None

    def point_terms(self, U: np.ndarray, lam: float) -> tuple[np.ndarray, list]:
        """Residual of the point loads (all dofs) and their tangent blocks [(pattern, blocks)]."""
        R = np.zeros(self.disc.n)
        blocks = []
        tip, rod = self._tip, self.rod
        if self.model == PLANAR:
            R[tip] -= lam * np.array([rod.tip_force[0], rod.tip_force[2], rod.tip_moment[1]])
            if self.magnet_nodes:  # -m (sin th Bx + cos th Bz): first and second derivative in theta
                th, m = U[self._magnet_dofs[:, 0]], lam * self._magnet_m
                R[self._magnet_dofs[:, 0]] -= m * (np.cos(th) * rod.B[0] - np.sin(th) * rod.B[2])
                k = m * (np.sin(th) * rod.B[0] + np.cos(th) * rod.B[2])
                blocks.append((self._patterns["magnets"], k))
            nf = self.disc.nf
            for node, F, M in self.point_nodes:  # dead loads in the plane: potential -F.r - M theta
                R[node * nf : node * nf + 3] -= lam * np.array([F[0], F[2], M[1]])
            return R, blocks
        R[tip[:3]] -= lam * np.asarray(rod.tip_force)
        if any(rod.tip_moment):
            g, h = full.dead_moment(U[tip[3:]], rod.tip_moment)
            R[tip[3:]] -= lam * g
            blocks.append((self._patterns["moment"], -lam * h))
        if self.magnet_nodes:
            g, h = full.magnet(U[self._magnet_dofs], rod.B, self.variant)
            m = lam * self._magnet_m
            R[self._magnet_dofs] += m[:, None] * g
            blocks.append((self._patterns["magnets"], m[:, None, None] * h))
        self._designer_point_terms(U, lam, R, blocks)
        return R, blocks

    def _designer_point_terms(self, U: np.ndarray, lam: float, R: np.ndarray, blocks: list) -> None:
        """Off-axis magnets (-m (R a).B: :func:`matid.physics.full.magnet` with their maps) and
        interior dead loads (contract section 9), full model."""
        if self.directed_nodes:
            g, h = full.magnet(U[self._directed_dofs], self.rod.B, self.variant, M=self._directed_M)
            R[self._directed_dofs] += lam * g
            blocks.append((self._patterns["directed"], lam * h))
        nf = self.disc.nf
        for node, F, _ in self.point_nodes:
            R[node * nf : node * nf + 3] -= lam * F
        if self._patterns["point moments"] is not None:
            pairs = [
                full.dead_moment(U[d], M) for d, M in zip(self._moment_dofs, self._point_moments, strict=True)
            ]
            R[self._moment_dofs] -= lam * np.array([g for g, _ in pairs])
            blocks.append((self._patterns["point moments"], -lam * np.array([h for _, h in pairs])))

    def gauge_terms(self, U: np.ndarray) -> tuple[np.ndarray, list]:
        """Unity penalty c_u/2 (|q|^2 - 1)^2 at every node (normalised variant).

        With directors from q/|q| no energy depends on |q|: the penalty only fixes
        that null direction. Applied per node its stiffness does not shrink with
        the element size, so load terms coupling into |q| (a dead tip moment)
        cannot swamp it; the physical solution is the same for any c_u > 0.
        The nodes are the point values of q (not the Hermite's slopes).
        """
        dofs = self._gauge_dofs
        Q = U[dofs]
        e = np.einsum("na,na->n", Q, Q) - 1.0
        R = np.zeros_like(U)
        R[dofs] = (2.0 * self.c_u) * e[:, None] * Q
        H = (4.0 * self.c_u) * (Q[:, :, None] * Q[:, None, :])
        H[:, _DIAG4, _DIAG4] += (2.0 * self.c_u) * e[:, None]
        blocks = [(self._patterns["gauge"], H)]
        if self._patterns["slopes"] is not None:
            Rs, Hs = self._slope_gauge(U)
            R += Rs
            blocks.append((self._patterns["slopes"], Hs))
        return R, blocks

    def _slope_gauge(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """c_u/2 (q.q')^2 at each vertex of an element with slopes (the Hermite): d|q|^2/ds = 0
        there, the slopes' share of the null direction |q| (the values' is the penalty above)."""
        dofs = self._slope_dofs
        Y = U[dofs]  # (k, 8): q, q'
        q, p = Y[:, :4], Y[:, 4:]
        w = np.einsum("ka,ka->k", q, p)
        swapped = Y[:, [4, 5, 6, 7, 0, 1, 2, 3]]  # d(q.q')/d(q, q') = (q', q)
        R = np.zeros_like(U)
        R[dofs] = self.c_u * w[:, None] * swapped
        H = self.c_u * (swapped[:, :, None] * swapped[:, None, :])
        H[:, _DIAG4, _DIAG4 + 4] += self.c_u * w[:, None]
        H[:, _DIAG4 + 4, _DIAG4] += self.c_u * w[:, None]
        return R, H

    # -- residual and tangent on the free dofs ---------------------------------
    def evaluate(self, X: np.ndarray, lam: float, *, tangent: bool = True, U: np.ndarray | None = None):
        """Residual on the free dofs and, with ``tangent``, its Jacobian (banded or CSR)."""
        U = self.expand(X) if U is None else U
        g, H = self.energy_derivatives(U, lam, tangent)
        self.last_points = (U, g, H)  # pointwise derivatives of this evaluation (bend: dR/dsigma)
        if self.banded:
            R = self.disc.residual(g)
            K = self.disc.tangent(H, self.symmetric) if tangent else None
        else:
            R, K = self.disc.assemble(g, H)
        Rp, blocks = self.point_terms(U, lam)
        R += Rp
        if self.model == FULL and self.variant == kin.NORMALISED:
            Rg, gblocks = self.gauge_terms(U)
            R += Rg
            blocks += gblocks
        for pattern, values in blocks if tangent else ():
            if self.banded:
                K.add(pattern, values)
            else:
                entries = (values.reshape(-1)[pattern.keep], (pattern.rows, pattern.cols))
                K = K + sp.csr_matrix(entries, shape=K.shape)
        return R[self.disc.free], K

    @property
    def symmetric(self) -> bool:
        """The tangent is a Hessian, except with a dead moment in 3D (no potential)."""
        point_moment = any(any(M) for _, _, M in self.rod.point_loads)
        return not (self.model == FULL and (any(self.rod.tip_moment) or point_moment))

    def reject(self, X: np.ndarray, lam: float, factor: object = None) -> str | None:
        """Why a converged state is no answer, or None: a saddle of the potential is not an equilibrium
        a rod can hold (used by :func:`matid.rod.newton.follow` to halve the load step).

        ``factor``: Newton's last factorised tangent; a successful banded Cholesky of it
        (every pivot > 0) is the stability test, read off without a second factorisation.
        """
        if getattr(factor, "positive_definite", None) is True:
            return None
        if self.negative_modes(X, lam):
            if not self.symmetric:
                return (
                    "no stable equilibrium assured: with a dead moment in 3D (no potential) the "
                    "symmetrised tangent is not positive definite (physics.md section 8)"
                )
            return "unstable equilibrium (the tangent stiffness is not positive definite: buckling or snap)"
        return None

    def negative_modes(self, X: np.ndarray, lam: float) -> int | None:
        """Non-positive pivots of the tangent at X: 0 iff it is positive definite (a stable state).

        The test of Cholesky: SuperLU in symmetric mode without off-diagonal
        pivoting (checked: perm_r == perm_c) computes K = L D L^T, and every
        pivot of D is positive iff K is (for a positive definite K this
        elimination is backward stable, so a pivot <= 0 is no round-off).
        None when the test cannot be made.

        With dead moments in 3D (physics.md section 8), which have no potential: the test of
        the symmetrised tangent (K + K^T)/2, i.e. positive second-order work of every
        perturbation (Hill's criterion: sufficient, coordinate-free). Measured: it rejects the
        saddle of a magnet in a reversed field (two negative eigenvalues, so det K > 0 there: a
        sign change of det K would miss it), and pure dead tip moments above ~2.2 E_b/L in
        3D (det K > 0 there too: stability is then not assured, rather than assumed).
        """
        K = self.evaluate(X, lam)[1].tocsr()
        if not self.symmetric:
            K = (K + K.T) * 0.5
        try:
            lu = spla.splu(
                K.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
            )
        except RuntimeError:  # an exactly zero pivot: singular, a bifurcation point
            return 1
        if not np.array_equal(lu.perm_r, lu.perm_c):
            return None
        return int(np.sum(lu.U.diagonal() <= 0.0))

    def expand(self, X: np.ndarray) -> np.ndarray:
        U = self._reference().copy()
        U[self.disc.free] = X
        return U

    def reduce(self, U: np.ndarray) -> np.ndarray:
        return U[self.disc.free].copy()


def _q_dofs(nodes, nf: int) -> np.ndarray:
    """The global dofs (k, 4) of q at the scalar dofs ``nodes`` (full model: r, q are fields 0-2, 3-6)."""
    return np.asarray(nodes, int).reshape(-1, 1) * nf + 3 + np.arange(4)


def _fields(disc: Discretisation, rod: ScaledRod) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """(stiffnesses, magnetisation) of the rod at the mesh's quadrature points, remembered per
    mesh and rod (a cached mesh serves every solve of a scene); read-only arrays."""
    cache = disc.__dict__.setdefault("_fields", {})
    hit = cache.get(rod)
    if hit is None or hit[0] is not disc.s_quad:  # a moved mesh shares the dict, not the points
        if len(cache) > 32:
            cache.clear()
        hit = cache[rod] = (disc.s_quad, rod.stiffness_at(disc.s_quad), rod.mu_at(disc.s_quad))
    return hit[1], hit[2]
