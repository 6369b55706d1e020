"""The planar and full rod models on a clamped rod, in scaled units.

Scaling (physics.md, "scale the problem before solving it"): lengths by L,
forces by E_b0/L^2, moments by E_b0/L, energies by E_b0/L, with E_b0 the
bending stiffness at the clamp. Scaled stiffnesses are then E_b = 1,
E_t/E_b0, E_s L^2/E_b0, E_e L^2/E_b0; a magnetisation per length mu B becomes
mu B L^2/E_b0 and a lumped moment m B becomes m B L/E_b0.

Total energy, eq. (10), at load factor lam (loads and precurvature scale with lam):

    S = int_0^1 [W(kappa - lam kappa_ref, nu) - lam mu d3.B + c_u P - lam f.r] ds
        - lam sum_magnets m d3(s_m).B - lam F.r(1)  [- lam M theta(1), planar]

A dead tip moment in 3D has no potential; its virtual work lam M.dphi with the
spatial spin dphi = 2 vec(dq * conj(q))/|q|^2 enters the residual directly
(the tangent is then unsymmetric, which the LU solver handles).

Only the terms a scene has are evaluated: no magnetic term without a field,
no penalty in the planar model, no precurvature term when it is zero.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from matid.physics import full, planar
from matid.physics import kinematics as kin
from matid.physics.jet import Jet
from matid.rod import compiled
from matid.rod.fem import Discretisation

PLANAR, FULL = "planar", "full"
FIELDS = {PLANAR: ("x", "z", "theta"), FULL: ("x", "y", "z", "q0", "q1", "q2", "q3")}


@dataclass(frozen=True)
class Segment:
    """Scaled properties on [start, end): stiffness factors relative to the base rod."""

    start: float
    end: float
    E_b: float
    E_t: float
    E_s: float
    E_e: float
    kappa_ref: tuple[float, float, float] | None = None  # this piece's precurvature; None: the rod's


@dataclass(frozen=True)
class ScaledRod:
    """A clamped rod and its loads in scaled units (see module docstring).

    In the planar model vectors are (transverse, axial) pairs in the plane of
    the scene and moments/curvatures are about the plane normal.
    """

    E_t: float = 1.0
    E_s: float = 1e4
    E_e: float = 1e4
    segments: tuple[Segment, ...] = ()
    kappa_ref: tuple[float, ...] = (0.0, 0.0, 0.0)
    mu: tuple[tuple[float, float, float], ...] = ()  # (from, to, moment per length) pieces
    B: tuple[float, ...] = (0.0, 0.0, 0.0)
    f: tuple[float, ...] = (0.0, 0.0, 0.0)
    tip_force: tuple[float, ...] = (0.0, 0.0, 0.0)
    tip_moment: tuple[float, ...] = (0.0, 0.0, 0.0)
    magnets: tuple[tuple[float, float], ...] = ()  # (s, moment)
    #: magnetisation off d3 (contract section 9), direction a in the director frame:
    #: lumped (s, moment, a) and distributed (from, to, moment per length, a)
    directed_magnets: tuple[tuple[float, float, tuple[float, float, float]], ...] = ()
    directed_mu: tuple[tuple[float, float, float, tuple[float, float, float]], ...] = ()
    #: dead loads at interior points (s, force, moment); planar: (transverse, -, axial), (-, M, -)
    point_loads: tuple[tuple[float, tuple[float, ...], tuple[float, ...]], ...] = ()

    def kappa_ref_at(self, s: np.ndarray) -> np.ndarray | None:
        """kappa_ref at points s (P + (3,)) when a segment has its own, else None (the rod's, uniform)."""
        if not any(seg.kappa_ref is not None for seg in self.segments):
            return None
        out = np.broadcast_to(np.asarray(self.kappa_ref, float), s.shape + (3,)).copy()
        for seg in self.segments:
            if seg.kappa_ref is not None:
                out[(s >= seg.start) & (s < seg.end)] = seg.kappa_ref
        return out

    def directed_mu_at(self, s: np.ndarray) -> np.ndarray | None:
        """Sum of mu a (director frame) of the off-axis magnetised pieces at points s (P + (3,)), or None."""
        if not self.directed_mu:
            return None
        out = np.zeros(s.shape + (3,))
        for start, end, value, a in self.directed_mu:
            out += np.where((s >= start) & (s <= end), value, 0.0)[..., None] * np.asarray(a, float)
        return out

    def stiffness_at(self, s: np.ndarray) -> dict[str, np.ndarray]:
        out = {
            "E_b": np.ones_like(s),
            "E_t": np.full_like(s, self.E_t),
            "E_s": np.full_like(s, self.E_s),
            "E_e": np.full_like(s, self.E_e),
        }
        for seg in self.segments:
            inside = (s >= seg.start) & (s < seg.end)
            for name in out:
                out[name] = np.where(inside, getattr(seg, name), out[name])
        return out

    def mu_at(self, s: np.ndarray) -> np.ndarray:
        out = np.zeros_like(s)
        for start, end, value in self.mu:
            out += np.where((s >= start) & (s <= end), value, 0.0)
        return out

    @property
    def has_field(self) -> bool:
        magnetised = self.mu or self.magnets or self.directed_mu or self.directed_magnets
        return any(self.B) and bool(magnetised)


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
    banded: bool = False  # tangent in band storage (fem.Banded: LAPACK Cholesky/LU) instead of CSR
    mixed: bool = False  # mixed-integration-point tangent in Newton (see mixed_update)
    terms: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._stress = self._strain = None
        #: point stresses (ne, nq, ns) for the mixed tangent's first iteration (a warm start
        #: from a coarser mesh's recovered stresses), and C e(u) at the points of the last
        #: compiled Newton (the converged state's stresses, for the next warm start)
        self.stress_start: np.ndarray | None = None
        self.point_stress: np.ndarray | None = None
        self.props, self.mu, roundoff = _fields(self.disc, self.rod)
        self._roundoff = (self.props, roundoff)
        nf = self.disc.nf
        free = np.ones(self.disc.n, dtype=bool)
        free[list(range(nf)) if self.fixed is None else list(self.fixed)] = False
        self.disc.set_free(free)  # a shared (cached) mesh keeps its patterns when the set is the same
        self.index = self.disc._index  # free dof number of each dof, -1 where fixed
        self.tip = self.disc.vertex_dof(self.disc.vertices.size - 1)
        magnets = [(s_m, m) for s_m, m in self.rod.magnets]
        verts = self.disc.vertices
        self.magnet_nodes = [(int(np.argmin(np.abs(verts - s_m))), m) for s_m, m in magnets]
        self.terms = ["bending", "shear", "extension"] + (
            ["twist", "unity penalty"] if self.model == FULL else []
        )
        if self.rod.has_field:
            self.terms.append("magnetic")
        #: per-segment precurvature and off-axis magnetisation at the points, point loads at nodes
        self.kappa = self.rod.kappa_ref_at(self.disc.s_quad)
        self.mu_directed = self.rod.directed_mu_at(self.disc.s_quad) if self.rod.has_field else None
        node = lambda s_p: int(np.argmin(np.abs(verts - s_p)))  # noqa: E731
        self.directed_nodes = [(node(s_m), m, np.asarray(a)) for s_m, m, a in self.rod.directed_magnets]
        self.point_nodes = [(node(s_p), np.asarray(F), np.asarray(M)) for s_p, F, M in self.rod.point_loads]
        if any(self.rod.kappa_ref) or self.kappa is not None:
            self.terms.append("precurvature")
        if self.point_nodes:
            self.terms.append("point loads")

    # -- states -------------------------------------------------------------
    def reference(self) -> np.ndarray:
        """Straight rod along the axis, identity rotation."""
        U = np.zeros((self.disc.nscalar, self.disc.nf))
        U[:, 1 if self.model == PLANAR else 2] = self.disc.s_dof
        if self.model == FULL:
            U[:, 3] = 1.0
        return U.ravel()

    def _reference(self) -> np.ndarray:
        """:meth:`reference`, cached per mesh (the fixed dofs of :meth:`expand`)."""
        cached = self.__dict__.get("_ref")
        if cached is None or cached[0] is not self.disc:
            cached = self._ref = (self.disc, self.reference())
        return cached[1]

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
                kin.magnetic_energy(lam * self.mu_directed[..., j], pointing(q, self.variant, j), rod.B)
                for j in range(3)
            )
        if any(rod.f):
            w = w - lam * (rod.f[0] * r[0] + rod.f[1] * r[1] + rod.f[2] * r[2])
        return w

    def energy_derivatives(self, U: np.ndarray, lam: float, tangent: bool = True):
        vals, ders = self.disc.interpolate(U)
        closed_form = self.model == PLANAR or self.variant == kin.NORMALISED
        if self.analytic and closed_form:  # the jets below are the cross-check (tests)
            rod = self.rod
            mu = self.mu if "magnetic" in self.terms else None
            out = (planar if self.model == PLANAR else full).derivatives(
                vals,
                ders,
                lam,
                self.props,
                rod.kappa_ref if self.kappa is None else self.kappa,
                mu,
                rod.B,
                rod.f,
                tangent,
                stress=self._stress,
                want_strain=self.mixed,
            )
            if self.mixed and tangent:
                self._strain = out[2]
            if self.mu_directed is not None:  # magnetisation off d3 (contract section 9)
                full.directed_magnetic(out[0], out[1], vals, lam, self.mu_directed, rod.B)
            return out[0], out[1]
        variables = Jet.variables(np.concatenate([vals, ders]), hessian=tangent)
        nf = self.disc.nf
        w = self.density(variables[:nf], variables[nf:], lam)
        return w.g, w.h

    # -- mixed-integration-point Newton (independent stresses at the quadrature points) ----------
    def mixed_reset(self) -> None:
        """Back to the consistent tangent (stresses from the displacements)."""
        self._stress = None

    def converged_stress(self) -> np.ndarray | None:
        """C e(u) (ne, nq, ns) at the points of the last Newton evaluation (mixed systems)."""
        if self.point_stress is not None:
            return self.point_stress
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
        cached = self.__dict__.get("_roundoff")
        if cached is None or cached[0] is not self.props:
            cached = self._roundoff = (self.props, _roundoff_floor(self.props))
        return cached[1]

    # -- point terms (tip loads, lumped magnets) --------------------------------
    def point_terms(self, U: np.ndarray, lam: float) -> tuple[np.ndarray, list]:
        """Residual of the point loads (all dofs) and their tangent blocks [(dofs, matrix)]."""
        nf = self.disc.nf
        R = np.zeros(self.disc.n)
        blocks = []
        tip = np.arange(self.tip * nf, self.tip * nf + nf)
        rod = self.rod
        if self.model == PLANAR:
            R[tip[0]] -= lam * rod.tip_force[0]
            R[tip[1]] -= lam * rod.tip_force[2]
            R[tip[2]] -= lam * rod.tip_moment[1]
            for node, F, M in self.point_nodes:  # dead loads in the plane: potential -F.r - M theta
                R[node * nf : node * nf + 3] -= lam * np.array([F[0], F[2], M[1]])
            for node, m in self.magnet_nodes:
                th = U[node * nf + 2]
                # -m (sin th Bx + cos th Bz): derivative and second derivative in theta
                R[node * nf + 2] -= lam * m * (np.cos(th) * rod.B[0] - np.sin(th) * rod.B[2])
                k = lam * m * (np.sin(th) * rod.B[0] + np.cos(th) * rod.B[2])
                blocks.append((np.array([node * nf + 2]), np.array([[k]])))
            return R, blocks
        R[tip[:3]] -= lam * np.asarray(rod.tip_force)
        if any(rod.tip_moment):
            g, h = _moment_work(U[tip[3:]], np.asarray(rod.tip_moment))
            R[tip[3:]] -= lam * g
            blocks.append((tip[3:], -lam * h))
        for node, m in self.magnet_nodes:
            dofs = np.arange(node * nf + 3, node * nf + 7)
            qj = Jet.variables(U[dofs].reshape(4, 1))
            e = kin.magnetic_energy(lam * m, kin.d3(qj, self.variant), rod.B)
            R[dofs] += e.g[0]
            blocks.append((dofs, e.h[0]))
        self._designer_point_terms(U, lam, R, blocks)
        return R, blocks

    def _designer_point_terms(self, U: np.ndarray, lam: float, R: np.ndarray, blocks: list) -> None:
        """Off-axis magnets (-m (R a).B) and interior dead loads (contract section 9), full model."""
        nf, B = self.disc.nf, self.rod.B
        for node, m, a in self.directed_nodes:
            dofs = np.arange(node * nf + 3, node * nf + 7)
            qj = Jet.variables(U[dofs].reshape(4, 1))
            e = sum(kin.magnetic_energy(lam * m * a[j], pointing(qj, self.variant, j), B) for j in range(3))
            R[dofs] += e.g[0]
            blocks.append((dofs, e.h[0]))
        for node, F, M in self.point_nodes:
            R[node * nf : node * nf + 3] -= lam * F
            if any(M):
                dofs = np.arange(node * nf + 3, node * nf + 7)
                g, h = _moment_work(U[dofs], M)
                R[dofs] -= lam * g
                blocks.append((dofs, -lam * h))

    def gauge_terms(self, U: np.ndarray) -> tuple[np.ndarray, list]:
        """Unity penalty c_u/2 (|q|^2 - 1)^2 at every node (normalised variant).

        With directors from q/|q| no energy depends on |q|: the penalty only fixes
        that null direction. Applied per node its stiffness does not shrink with
        the element size, so load terms coupling into |q| (a dead tip moment)
        cannot swamp it; the physical solution is the same for any c_u > 0.
        """
        nf = self.disc.nf
        Q = U.reshape(-1, nf)[:, 3:]
        e = np.sum(Q * Q, axis=1) - 1.0
        R = np.zeros_like(U).reshape(-1, nf)
        R[:, 3:] = 2.0 * self.c_u * e[:, None] * Q
        H = self.c_u * (2.0 * e[:, None, None] * np.eye(4) + 4.0 * Q[:, :, None] * Q[:, None, :])
        dofs = np.arange(Q.shape[0])[:, None] * nf + 3 + np.arange(4)[None, :]
        return R.ravel(), [(dofs, H)]

    @property
    def kernel_served(self) -> bool:
        """Whether :mod:`matid.rod.compiled` serves this system (asked once per system)."""
        ok = self.__dict__.get("_compiled")
        if ok is None:  # the kernel has none of the terms of contract section 9
            designer = self.kappa is not None or self.mu_directed is not None or self.directed_nodes
            ok = self._compiled = not (designer or self.point_nodes) and compiled.supported(self)
        return ok

    def compiled_newton(self, x0: np.ndarray, lam: float, **options):
        """:func:`matid.rod.newton.newton` in one compiled call (:mod:`matid.rod.compiled`), or None
        when this system is not one it serves."""
        return compiled.newton(self, x0, lam, **options) if self.kernel_served else None

    def load_derivative(self, X: np.ndarray) -> np.ndarray | None:
        """dR/dlam = R(X, 1) - R(X, 0) from the kernel, or None (then newton.tangent evaluates)."""
        return compiled.load_derivative(self, X) if self.kernel_served else None

    # -- residual and tangent on the free dofs ---------------------------------
    def evaluate(self, X: np.ndarray, lam: float, *, tangent: bool = True, U: np.ndarray | None = None):
        """Residual on the free dofs and, with ``tangent``, its Jacobian (CSR)."""
        U = self.expand(X) if U is None else U
        g, H = self.energy_derivatives(U, lam, tangent)
        self.last_points = (U, g, H)  # pointwise derivatives of this evaluation (bend: dR/dsigma)
        if self.banded:
            R = self.disc.residual(g)
            K = self.disc.banded(self.disc.element_matrices(H), self.symmetric) if tangent else None
        else:
            R, K = self.disc.assemble(g, H)
        Rp, blocks = self.point_terms(U, lam)
        R = R + Rp
        if self.model == FULL and self.variant == kin.NORMALISED:
            Rg, gblocks = self.gauge_terms(U)
            R = R + Rg
            blocks = blocks + gblocks
        if not tangent:
            return R[self.disc.free], None
        if self.banded:
            rows, cols, vals = self._triplets(blocks)
            if vals.size:
                K.add_blocks(rows, cols, vals)
            return R[self.disc.free], K
        return R[self.disc.free], K + self._blocks_matrix(blocks, K.shape)

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
        With a dead moment in 3D (no potential): :meth:`dead_moment_modes`.
        None when the test cannot be made.
        """
        _, K = self.evaluate(X, lam)
        if not self.symmetric:
            return self.dead_moment_modes(X, lam, K)
        return ldl_negative(K)

    def dead_moment_modes(self, X: np.ndarray, lam: float, K) -> int | None:
        """Stability with dead moments in 3D (physics.md section 8), which have no potential: the
        test of the symmetrised tangent (K + K^T)/2, i.e. positive second-order work of every
        perturbation (Hill's criterion: sufficient, coordinate-free). Measured: it rejects the
        saddle of a magnet in a reversed field (two negative eigenvalues, so det K > 0 there: a
        sign change of det K would miss it), and pure dead tip moments above ~2.2 E_b/L in
        3D (det K > 0 there too: stability is then not assured, rather than assumed)."""
        return ldl_negative(symmetric_part(K))

    def _blocks_matrix(self, blocks: list, shape: tuple[int, int]) -> sp.csr_matrix:
        """Sum of dense blocks (dofs of shape (..., m), matrices (..., m, m)) on the free dofs."""
        rows, cols, vals = self._triplets(blocks)
        if not vals.size:
            return sp.csr_matrix(shape)
        return sp.csr_matrix((vals, (rows, cols)), shape=shape)

    def _triplets(self, blocks: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rows, cols, values) in free-dof numbering of blocks (dofs (..., m), matrices (..., m, m))."""
        rows, cols, vals = [], [], []
        for dofs, block in blocks:
            dofs = np.atleast_2d(dofs)
            block = block.reshape(dofs.shape[0], dofs.shape[1], dofs.shape[1])
            idx = self.index[dofs]
            ii = np.broadcast_to(idx[:, :, None], block.shape)
            jj = np.broadcast_to(idx[:, None, :], block.shape)
            ok = (ii >= 0) & (jj >= 0)
            rows.append(ii[ok]), cols.append(jj[ok]), vals.append(block[ok])
        if not rows:
            return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
        return np.concatenate(rows), np.concatenate(cols), np.concatenate(vals)

    def expand(self, X: np.ndarray) -> np.ndarray:
        U = self._reference().copy()
        U[self.disc.free] = X
        return U

    def reduce(self, U: np.ndarray) -> np.ndarray:
        return U[self.disc.free].copy()


def pointing(q, variant: str, j: int) -> list:
    """The director d_j (j = 0, 1, 2) from q, raw or from q/|q| (a magnetisation along it)."""
    R = kin.directors(q)
    col = [R[0][j], R[1][j], R[2][j]]
    if variant == kin.RAW:
        return col
    inv = 1.0 / kin.norm2(q)
    return [c * inv for c in col]


def ldl_negative(K) -> int | None:
    """Non-positive pivots of a symmetric K (CSR or band-stored) by SuperLU's L D L^T without
    off-diagonal pivoting (:meth:`RodSystem.negative_modes`); None when SuperLU pivoted."""
    try:
        lu = spla.splu(
            K.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        )
    except RuntimeError:  # an exactly zero pivot: singular, a bifurcation point
        return 1
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    return int(np.sum(lu.U.diagonal() <= 0.0))


def symmetric_part(K) -> sp.csr_matrix:
    """(K + K^T)/2 in free-dof numbering (CSR) of a CSR or band-stored (fem.Banded) tangent."""
    K = free_csr(K)
    return ((K + K.T) * 0.5).tocsr()


def free_csr(K) -> sp.csr_matrix:
    """A CSR or band-stored (fem.Banded) tangent as CSR in free-dof numbering, in O(n u)."""
    if hasattr(K, "ab"):  # band storage ab[u + i - j, j] = K[i, j], band position -> free dof
        n, u = K.shape[0], K.u
        offsets = list(range(-u, u + 1))
        diagonals = [K.ab[u + k, max(0, -k) : min(n, n - k)] for k in offsets]
        band = sp.diags(diagonals, [-k for k in offsets], shape=(n, n), format="coo")
        K = sp.csr_matrix((band.data, (K.order[band.row], K.order[band.col])), shape=(n, n))
    return sp.csr_matrix(K)


def _fields(disc: Discretisation, rod: ScaledRod) -> tuple[dict[str, np.ndarray], np.ndarray, float]:
    """(stiffnesses, magnetisation, round-off floor) of the rod at the mesh's quadrature points,
    remembered per mesh and rod (a cached mesh serves every solve of a scene); read-only arrays.
    The floor is :func:`_roundoff_floor` (:attr:`RodSystem.roundoff`)."""
    cache = disc.__dict__.setdefault("_fields", {})
    hit = cache.get(rod)
    if hit is None or hit[0] is not disc.s_quad:  # a moved mesh shares the dict, not the points
        if len(cache) > 32:
            cache.clear()
        props = rod.stiffness_at(disc.s_quad)
        hit = cache[rod] = (disc.s_quad, props, rod.mu_at(disc.s_quad), _roundoff_floor(props))
    return hit[1], hit[2], hit[3]


def _roundoff_floor(props: dict[str, np.ndarray]) -> float:
    """Smallest Newton correction distinguishable from round-off: eps times the stiffness spread."""
    stiff = max(float(np.max(v)) for v in props.values())
    return 1e-15 * max(stiff, 1.0)


def _moment_work(q: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Generalised force of a dead moment M on q and its Jacobian.

    dphi = 2 (q0 dv - dq0 v + v x dv)/|q|^2, so Q0 = -2 M.v/|q|^2 and
    Qv = 2 (q0 M + M x v)/|q|^2.
    """
    qj = Jet.variables(q.reshape(4, 1))
    q0, v = qj[0], qj[1:]
    inv = 1.0 / kin.norm2(qj)
    Mxv = [M[1] * v[2] - M[2] * v[1], M[2] * v[0] - M[0] * v[2], M[0] * v[1] - M[1] * v[0]]
    Q = [-2.0 * (M[0] * v[0] + M[1] * v[1] + M[2] * v[2]) * inv]
    Q += [2.0 * (q0 * M[i] + Mxv[i]) * inv for i in range(3)]
    g = np.array([c.v[0] for c in Q])
    jac = np.array([c.g[0] for c in Q])
    return g, jac
