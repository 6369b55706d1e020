"""Residual and bordered tangent of the three-point bend's half model (see :mod:`matid.rod.bend`).

The rig's support and nose are terms (:mod:`matid.rod.terms.supports`) held by multipliers on
two vertices: the system sums their gap rows, normal columns and Hessian entries, computed in
plain floats and put into the rod's banded tangent at positions found once per system; the
derivatives the E_s fit needs at a converged point (dX/dE_s, dX/dE_e and dX/dd) are one
back-substitution with three right-hand sides.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from matid.physics.contact import Circle
from matid.rod.band import Banded
from matid.rod.newton import NewtonFailure
from matid.rod.system import RodSystem
from matid.rod.terms import Term
from matid.rod.terms.supports import Nose, Support


class BendSystem:
    """Residual and tangent of the half-model bend at nose deflection lam * d_max (scaled), in the
    unknowns X = (free planar dofs, lam_support, lam_nose, sigma) of :mod:`matid.rod.bend`."""

    def __init__(self, rod: RodSystem, model, support: Circle, d_max: float):
        self.rod, self.model, self.support, self.d_max = rod, model, support, d_max
        self.base = rod.disc
        self.k = model.support_vertex
        self.nu = int(rod.disc.free.sum())
        #: the rig's terms (matid.rod.terms.supports), in the order of their multipliers in X,
        #: each with what it prepared for the rod system: the free dofs of its vertex
        rig = (Support(support, self.k), Nose(model.nose_rho, d_max))
        self.held = [(term, term.prepare(rod)) for term in rig]
        #: free-dof index of (x, z, theta) at the support vertex and at the nose vertex (0)
        self.dofs = tuple(prep for _, prep in self.held)
        self._z0 = float(rod.reference()[1])
        # unit stiffness fields: dR/dE of one energy term (the energy is linear in each stiffness)
        props = rod.props
        self._unit = {
            name: {p: (np.ones_like(v) if p == name else np.zeros_like(v)) for p, v in props.items()}
            for name in ("E_s", "E_e")
        }

    def at(self, sigma: float) -> None:
        """Build the mesh around the support vertex at arc length sigma (scaled)."""
        if not 0.0 < sigma < self.model.half:
            raise NewtonFailure(f"the support contact section left the rod (s = {sigma:.4g} span)")
        if getattr(self, "_sigma", None) != sigma:
            self.rod.disc = self.base.moved(self.model.vertices(sigma))
            self._sigma = sigma

    @property
    def loads(self) -> tuple[Term, ...]:
        """Every term of the bend: the rod's loads and the rig's support and nose."""
        return tuple(self.rod.loads) + tuple(term for term, _ in self.held)

    def nose(self, lam: float) -> Circle:
        return self.held[1][0].circle(lam)

    @property
    def roundoff(self) -> float:
        return self.rod.roundoff

    def step_size(self, dx: np.ndarray) -> float:
        """Trust region and convergence on the displacements and sigma (multipliers follow them)."""
        return float(max(np.max(np.abs(dx[: self.nu])), abs(dx[-1])))

    def evaluate(self, X: np.ndarray, lam: float, *, tangent: bool = True):
        n = self.nu
        u, mult, sigma = X[:n], X[n : n + 2], float(X[-1])
        self.at(sigma)
        U = self.rod.expand(u)
        R, K = self.rod.evaluate(u, 0.0, tangent=tangent, U=U)
        # (g, n_x, n_z, |r - c|) of the support (at vertex k) and the nose (at vertex 0)
        gaps = [term.gap(U, lam) for term, _ in self.held]
        G = np.zeros((2, n))
        for c, (term, prep) in enumerate(self.held):
            for a in term.normal_dofs(prep):
                G[c, prep[a]] = gaps[c][1 + a]
        support = self.held[0][0]
        h, dh = support.section(U)  # the support's contact section
        R_all = np.empty(n + 3)
        R_all[:n] = R - G.T @ mult
        R_all[n], R_all[n + 1], R_all[n + 2] = -gaps[0][0], -gaps[1][0], h
        if not tangent:
            return R_all, None
        rows, cols, vals = [], [], []
        for c, (term, prep) in enumerate(self.held):
            r, q, v = term.hessian(prep, gaps[c], mult[c])
            rows += r
            cols += q
            vals += v
        K.add_blocks(np.array(rows), np.array(cols), np.array(vals))
        B = np.empty((n, 3))
        B[:, :2] = -G.T
        B[:, 2] = self._mesh_derivative(U)
        C = np.zeros((3, n))
        C[:2] = -G
        free = self.dofs[0] >= 0  # dh/d(x, z, theta) at the support vertex
        C[2, self.dofs[0][free]] = dh[free]
        return R_all, Bordered(K, B, C)

    def _mesh_derivative(self, U: np.ndarray) -> np.ndarray:
        """dR/dsigma with nodal values held, in closed form from the pointwise g and H.

        Moving sigma changes only element lengths h (dh/dsigma = 1/k inside the support
        vertex, -1/(n - k) outside); with u' = phi_ref' U/h each element residual
        R_e = sum_q w_q [h g_u phi + g_u' phi_ref'] has
        dR_e/dh = sum_q [W_0 (g_u/h + dg_u/dh) + W_1 dg_u'/dh],  dg/dh = -H[:, u'] u'/h,
        with W_0 = phi dx, W_1 = phi' dx the assembly tables (checked against differences).
        """
        rod, disc = self.rod, self.rod.disc
        U_used, g, H = rod.last_points
        assert U_used is U, "the mesh derivative needs the pointwise derivatives at U"
        nf, ne, k = disc.nf, disc.ne, self.k
        h = np.diff(disc.vertices)[:, None, None]  # (ne, 1, 1)
        up = disc.point_values(U)[..., nf:]  # u' at the points (ne, nq, nf)
        dg = -np.matmul(H[..., :, nf:], up[..., None])[..., 0] / h  # dg/dh (ne, nq, 2 nf)
        dg[..., :nf] += g[..., :nf] / h
        dh = np.where(np.arange(ne) < k, 1.0 / k, -1.0 / (ne - k))[:, None, None]
        return disc.residual(dg * dh)[disc.free]

    def lam_derivative(self, X: np.ndarray, lam: float) -> np.ndarray:
        """dR/dlam in closed form: lam moves only the nose (:meth:`Nose.lam_derivative`)."""
        out = np.zeros(X.size)
        nose, prep = self.held[1]
        dofs, values, row = nose.lam_derivative(prep, self.rod.expand(X[: self.nu]), lam, X[self.nu + 1])
        out[dofs] = values
        out[self.nu + 1] = row  # the nose gap row holds -g
        return out

    def stiffness_derivative(self, X: np.ndarray, name: str) -> np.ndarray:
        """dR/dp for a scaled stiffness p (E_s or E_e) of the rod (the residual of that energy term)."""
        rod = self.rod
        self.at(X[-1])
        saved = rod.props
        rod.props = self._unit[name]
        try:
            R, _ = rod.evaluate(X[: self.nu], 0.0, tangent=False)
        finally:
            rod.props = saved
        return np.concatenate([R, np.zeros(3)])

    def derivatives(self, X: np.ndarray, lam: float, lu: Bordered, stiffness: bool) -> dict[str, np.ndarray]:
        """dX/dd (scaled, per unit lam) and, with ``stiffness``, dX/dE_s and dX/dE_e (per scaled
        stiffness) at a converged state: A dX/dq = -dR/dq, one back-substitution for all."""
        names = ("lam", "E_s", "E_e") if stiffness else ("lam",)
        rhs = np.empty((X.size, len(names)))
        rhs[:, 0] = self.lam_derivative(X, lam)
        for j, name in enumerate(names[1:], start=1):
            rhs[:, j] = self.stiffness_derivative(X, name)
        out = lu.solve(-rhs)
        return {name: out[:, j] for j, name in enumerate(names)}

    def normal_x(self, X: np.ndarray, lam: float) -> float:
        """n_x of the nose contact (+-1 while symmetry keeps the nose vertex on the axis)."""
        ix, iz = self.dofs[1][0], self.dofs[1][1]
        if ix >= 0 and iz < 0:  # z(0) held (symmetry): no expansion needed
            x0, z0 = float(X[ix]), self._z0
        else:
            x0, z0 = (float(v) for v in self.rod.expand(X[: self.nu])[:2])
        return self.nose(lam).gap(x0, z0)[1]

    def force_derivative(self, X: np.ndarray, lam: float, dX: np.ndarray) -> float:
        """Scaled nose force change along a state change dX. The nose vertex stays on the axis
        (z = 0 by symmetry), so its contact normal is (+-1, 0) whatever X and lam: only the
        multiplier moves the force."""
        return float(2.0 * dX[self.nu + 1] * (-self.normal_x(X, lam)))

    def force(self, X: np.ndarray, lam: float) -> float:
        """Scaled nose force of the whole tube."""
        return self.force_derivative(X, lam, X)  # the force is linear in the nose multiplier

    def reject(self, X: np.ndarray, lam: float, factor: object = None) -> str | None:
        """A pulling contact is no answer: g = |r - c| - rho = 0 also holds on the far side of a
        cylinder, where Newton lands after a step longer than rho (see newton.follow)."""
        mult = X[self.nu : self.nu + 2]
        if np.any(mult < -1e-9 * max(1.0, float(np.max(np.abs(mult))))):
            return "a contact pulls (the tube crossed a cylinder or lifts off)"
        return None

    def initial(self) -> np.ndarray:
        self.at(0.5)
        return np.concatenate([self.rod.reduce(self.rod.reference()), np.zeros(2), [0.5]])


class Bordered:
    """The bend tangent [[K, B], [C, 0]]: the banded rod block K bordered by three columns
    (contact normals -G^T, dR/dsigma) and three rows (-G, dh/du).

    K alone is singular (nothing but the contacts holds the tube's vertical
    translation), so the first two rows are added to the rod block with weight rho,
    K_rho = K + rho G^T G, an equivalent system whose G^T G is node-local (in the
    band). Then x = y - Z w with K_rho y = f, K_rho Z = B and the 3x3 Schur
    complement (C Z) w = C y - g: one banded factorisation and four back-solves.
    """

    def __init__(self, K, B: np.ndarray, C: np.ndarray):
        self.K, self.B, self.C = K, B, C

    def tocsr(self) -> sp.csr_matrix:
        n = self.B.shape[0]
        A = np.zeros((n + 3, n + 3))
        A[:n, :n] = self.K.tocsr().toarray()
        A[:n, n:], A[n:, :n] = self.B, self.C
        return sp.csr_matrix(A)

    def factor(self) -> Bordered:
        K, C = self.K, self.C
        u = K.u
        self.rho = max(1.0, float(np.max(np.abs(K.ab[u]))))
        aug = Banded(K.ab.copy(), u, K.order, K.position, K.symmetric)
        for row in C[:2]:  # each contact row lives on its own vertex: rho g g^T is in the band
            nz = np.flatnonzero(row)
            pos = K.position[nz]
            aug.ab[u + pos[:, None] - pos[None, :], pos[None, :]] += self.rho * np.outer(row[nz], row[nz])
        self.F = aug.factor()
        self.Z = self.F.solve(self.B)
        self.S_inv = _inverse3(C @ self.Z)  # 3 x 3: applied to every right-hand side
        return self

    def solve(self, r: np.ndarray) -> np.ndarray:
        """The solution for a right-hand side r of shape (n + 3,) or (n + 3, m)."""
        n = self.B.shape[0]
        f = r[:n] + self.rho * (self.C[:2].T @ r[n : n + 2])
        y = self.F.solve(f)
        w = self.S_inv @ (self.C @ y - r[n:])
        return np.concatenate([y - self.Z @ w, w])


def _inverse3(S: np.ndarray) -> np.ndarray:
    """Inverse of a 3 x 3 matrix by its adjugate; LinAlgError when singular or not finite."""
    (a, b, c), (d, e, f), (g, h, i) = S.tolist()
    cof = [e * i - f * h, f * g - d * i, d * h - e * g]
    det = a * cof[0] + b * cof[1] + c * cof[2]
    if not (np.isfinite(det) and abs(det) > 1e-300):
        raise np.linalg.LinAlgError("singular bordered tangent")
    adj = [
        [cof[0], c * h - b * i, b * f - c * e],
        [cof[1], a * i - c * g, c * d - a * f],
        [cof[2], b * g - a * h, a * e - b * d],
    ]
    return np.array(adj) / det
