"""The three-point-bend scene: deflection-controlled path, nose force, sensitivities.

Scaled by the span S and E_b: lengths /S, forces /(E_b/S^2). Unknowns are the
free planar dofs of the half rod (:mod:`matid.rod.contact`), the two contact
multipliers and sigma, the arc length of the support vertex; the system is

    [K - sum lam_c d2g_c   -G^T   dR/dsigma] [du    ]   = -[R - G^T lam]
    [-G                      0       0     ] [dlam  ]      [-g        ]
    [dh/du                   0       0     ] [dsigma]      [h         ]

and the load factor moves the nose: d = lam d_max. A point contact puts a
corner into the centreline of a shear-deformable rod, so each contact sits on
a mesh vertex: the nose on vertex 0 (mid-span, by symmetry), the support on the
vertex at sigma, the mesh built around it, and h = 0 makes that vertex the
contact section. Sensitivities of the nose
force to the stiffnesses come from the linearised equilibrium at each converged
point: A dX/dp = -dR/dp, one back-substitution with the factorised tangent
(the energy is linear in each stiffness, so dR/dp is the residual of that one
energy term). The force is homogeneous of degree one in (E_b, E_s, E_e), so
dF/dE_b = (F - E_s dF/dE_s - E_e dF/dE_e) / E_b.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from matid.errors import ConvergenceError, SlipOffError
from matid.rod.bordered import Bordered
from matid.rod.contact import Circle
from matid.rod.fem import Discretisation
from matid.rod.models import PLANAR, RodSystem, ScaledRod
from matid.rod.newton import NewtonFailure, NewtonInfo, follow, newton

#: Default elements of the half model (measured: see ``matid bench``).
DEFAULT_ELEMENTS = 24


@dataclass(frozen=True)
class BendGeometry:
    """Set-up of a three-point bend (SI)."""

    span: float
    specimen_length: float
    support_radius: float
    nose_radius: float
    outer_diameter: float

    def __post_init__(self) -> None:
        if not self.specimen_length > self.span > 0:
            raise ValueError("three-point bend needs specimen_length > span > 0")
        if not (self.outer_diameter > 0 and self.support_radius >= 0 and self.nose_radius >= 0):
            raise ValueError("three-point bend needs outer_diameter > 0 and radii >= 0")


@dataclass
class BendPath:
    """Nose force along a deflection path (SI) with the converged states for warm starts."""

    deflection: np.ndarray
    force: np.ndarray
    dforce: dict[str, np.ndarray]  # parameter -> dF/dp at each deflection
    support_s: np.ndarray  # arc length of the support contact section from mid-span [m]
    states: list[np.ndarray] = field(repr=False, default_factory=list)
    #: (scaled E_s, scaled E_e) of the states and dX/dp for each (when sensitivities ran): the
    #: first-order predictor of a warm start at other stiffnesses
    scaled: tuple[float, float] | None = field(repr=False, default=None)
    tangents: list[dict] = field(repr=False, default_factory=list)
    #: dF/dd along the path [N/m] (at fixed stiffnesses)
    dforce_dd: np.ndarray | None = field(repr=False, default=None)
    newton_iterations: int = 0
    load_steps: int = 0
    runtime_s: float = 0.0


class BendSystem:
    """Residual and tangent of the half-model bend at nose deflection lam * d_max (scaled).

    Unknowns X = (free planar dofs, lam_support, lam_nose, sigma): sigma is the
    arc length of the support vertex, on which the mesh is built (uniform
    elements on each side of it). Its equation is h(vertex) = 0: the vertex is
    the contact section. dR/dsigma is a central difference of the residual on
    the rescaled mesh (nodal values held), which is smooth in sigma.
    """

    def __init__(self, rod: RodSystem, model: BendModel, support: Circle, d_max: float):
        self.rod, self.model, self.support, self.d_max = rod, model, support, d_max
        self.base = rod.disc
        self.k = model.support_vertex
        self.nu = int(rod.disc.free.sum())

    def at(self, sigma: float) -> None:
        if not 0.0 < sigma < self.model.half:
            raise NewtonFailure(f"the support contact section left the rod (s = {sigma:.4g} span)")
        if getattr(self, "_sigma", None) != sigma:
            self.rod.disc = self.base.moved(self.model.vertices(sigma))
            self._sigma = sigma

    def nose(self, lam: float) -> Circle:
        rho = self.model.nose_rho
        return Circle((rho - lam * self.d_max, 0.0), rho)

    @property
    def roundoff(self) -> float:
        return self.rod.roundoff

    def step_size(self, dx: np.ndarray) -> float:
        """Trust region and convergence on the displacements and sigma (multipliers follow them)."""
        return float(max(np.max(np.abs(dx[: self.nu])), abs(dx[-1])))

    def contacts(self, U: np.ndarray, lam: float):
        """[(gap, dofs, grad, hess, normal)] for the support and the nose, each at its vertex."""
        nodes = U.reshape(-1, 3)
        out = []
        for circle, vertex in ((self.support, self.k), (self.nose(lam), 0)):
            g, grad, hess = circle.vertex_gap(nodes, vertex)
            out.append((g, vertex * 3 + np.arange(3), grad, hess, grad[:2]))
        return out

    def evaluate(self, X: np.ndarray, lam: float, *, tangent: bool = True):
        u, mult, sigma = X[: self.nu], X[self.nu : self.nu + 2], X[-1]
        self.at(sigma)
        U = self.rod.expand(u)
        R, K = self.rod.evaluate(u, 0.0, tangent=tangent, U=U)
        index = self.rod.index
        G = np.zeros((2, self.nu))
        gaps = np.zeros(2)
        blocks = []
        for c, (g, dofs, grad, hess, _) in enumerate(self.contacts(U, lam)):
            idx = index[dofs]
            ok = idx >= 0
            G[c, idx[ok]] = grad[ok]
            gaps[c] = g
            blocks.append((dofs, -mult[c] * hess))
        h, dh = self.support.section(U.reshape(-1, 3), self.k)
        R_all = np.concatenate([R - G.T @ mult, -gaps, [h]])
        if not tangent:
            return R_all, None
        n = self.nu
        rows, cols, vals = self.rod._triplets(blocks)
        K.add_blocks(rows, cols, vals)
        idx = index[self.k * 3 + np.arange(3)]
        B = np.empty((n, 3))
        B[:, :2] = -G.T
        B[:, 2] = self._mesh_derivative(u, U, sigma)
        C = np.zeros((3, n))
        C[:2] = -G
        C[2, idx[idx >= 0]] = dh[idx >= 0]
        return R_all, Bordered(K, B, C)

    def _mesh_derivative(self, u: np.ndarray, U: np.ndarray, sigma: float) -> np.ndarray:
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
        geff = dg.copy()
        geff[..., :nf] += g[..., :nf] / h
        dh = np.where(np.arange(ne) < k, 1.0 / k, -1.0 / (ne - k))[:, None, None]
        return disc.residual(geff * dh)[disc.free]

    def load_derivative(self, X: np.ndarray, lam: float) -> np.ndarray:
        """dR/dlam in closed form: lam moves only the nose centre, c = (rho - lam d_max, 0).

        With n = (r - c)/|r - c|: dg/dlam = n_x d_max and dn/dlam = (I - n n^T)(d_max, 0)/|r - c|,
        which enters the residual through -G^T lam (zero when the nose vertex stays on the
        axis, z = 0, as symmetry holds it).
        """
        out = np.zeros(X.size)
        U = self.rod.expand(X[: self.nu])
        r = U[:2]  # vertex 0: (x, z)
        c = self.nose(lam).centre
        dist = max(float(np.hypot(r[0] - c[0], r[1] - c[1])), 1e-300)
        n = (r - c) / dist
        dn = (np.array([1.0, 0.0]) - n * n[0]) * self.d_max / dist
        idx = self.rod.index[:2]
        ok = idx >= 0
        out[idx[ok]] = -X[self.nu + 1] * dn[ok]
        out[self.nu + 1] = -n[0] * self.d_max  # the nose gap row holds -g
        return out

    def stiffness_derivative(self, X: np.ndarray, name: str) -> np.ndarray:
        """dR/dp for a scaled stiffness p of the rod (the residual of that energy term alone)."""
        rod = self.rod
        self.at(X[-1])
        saved = rod.props
        rod.props = {k: (np.ones_like(v) if k == name else np.zeros_like(v)) for k, v in saved.items()}
        try:
            R, _ = rod.evaluate(X[: self.nu], 0.0, tangent=False)
        finally:
            rod.props = saved
        return np.concatenate([R, np.zeros(3)])

    def force_derivative(self, X: np.ndarray, lam: float, dX: np.ndarray) -> float:
        """Scaled nose force change along a state change dX. The nose vertex stays on the axis
        (z = 0 by symmetry), so its contact normal is (+-1, 0) whatever X and lam: only the
        multiplier moves the force."""
        normal = self.contacts(self.rod.expand(X[: self.nu]), lam)[1][4]
        return float(2.0 * dX[self.nu + 1] * (-normal[0]))

    def force(self, X: np.ndarray, lam: float) -> float:
        """Scaled nose force of the whole tube."""
        self.at(X[-1])
        normal = self.contacts(self.rod.expand(X[: self.nu]), lam)[1][4]
        return 2.0 * X[self.nu + 1] * (-normal[0])

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


class BendModel:
    """A three-point bend on a fixed number of elements, solved for any stiffnesses and deflections."""

    def __init__(self, geometry: BendGeometry, *, elements: int = DEFAULT_ELEMENTS):
        if elements < 2:
            raise ValueError("the bend half model needs at least 2 elements")
        self.geometry, self.elements = geometry, elements
        S = geometry.span
        self.half = 0.5 * geometry.specimen_length / S
        R_o = 0.5 * geometry.outer_diameter
        self.support_rho = (geometry.support_radius + R_o) / S
        self.nose_rho = (geometry.nose_radius + R_o) / S
        self.support_vertex = min(max(1, round(elements * 0.5 / self.half)), elements - 1)

    def vertices(self, s_contact: float) -> np.ndarray:
        """Uniform elements on each side of the support's contact section."""
        k = self.support_vertex
        if "_fractions" not in self.__dict__:
            self._fractions = (np.linspace(0.0, 1.0, k + 1), np.linspace(0.0, 1.0, self.elements - k + 1)[1:])
        inner, outer = self._fractions
        return np.concatenate([s_contact * inner, s_contact + (self.half - s_contact) * outer])

    def system(self, E_b: float, E_s: float, E_e: float, d_max: float) -> BendSystem:
        S = self.geometry.span
        disc = Discretisation(self.vertices(0.5), 3, intorder=2)
        scaled = ScaledRod(E_t=1.0, E_s=E_s * S**2 / E_b, E_e=E_e * S**2 / E_b)
        rod = RodSystem(disc, scaled, model=PLANAR, fixed=(1, 2), banded=True)  # z(0) = 0, theta(0) = 0
        support = Circle((-self.support_rho, 0.5), self.support_rho)
        return BendSystem(rod, self, support, d_max / S)

    def solve(
        self,
        E_b: float,
        E_s: float,
        E_e: float,
        deflections: np.ndarray,
        *,
        sensitivities: tuple[str, ...] = (),
        start: BendPath | None = None,
    ) -> BendPath:
        """Nose force at each deflection (increasing from 0), following the path by continuation.

        ``start``: the path of an earlier solve at the same deflections (warm
        start: Newton from each of its states, continuation as the fallback).
        ``sensitivities``: any of "E_s", "E_e", "E_b" for dF/dp.
        """
        t0 = time.perf_counter()
        d = np.asarray(deflections, float)
        if d.size == 0 or np.any(d < 0) or np.any(np.diff(d) < 0):
            raise ValueError("deflections must be non-negative and increasing")
        d_max = float(d[-1]) if d[-1] > 0 else 1.0
        S, scale_F = self.geometry.span, E_b / self.geometry.span**2
        system = self.system(E_b, E_s, E_e, d_max)
        X = system.initial()
        info, lam = NewtonInfo(), 0.0
        rec: dict[str, list] = {"X": [], "F": [], "dF": [], "dFdd": []}
        scaled = (system.rod.rod.E_s, system.rod.rod.E_e)
        tangents: list[dict] = []
        slope, d_last = None, 0.0  # dX/dd at the last converged point: the predictor of the next
        curvature = None  # d2X/dd2 from the last two slopes
        for i, target in enumerate(d / d_max):
            guess = _predict(start, i, scaled, d[i])
            if guess is None and slope is not None:
                h = d[i] - d_last
                guess = X + slope * h + (0.5 * h * h * curvature if curvature is not None else 0.0)
            X = self._step(system, X, lam, target, guess, info, d_max)
            lam, d_last, previous = target, d[i], (slope, d_last)
            self._check(system, X, lam)
            F = system.force(X, lam)
            rec["X"].append(X.copy()), rec["F"].append(F)
            dX: dict = {}
            rec["dF"].append(
                _sensitivities(system, X, info.lu, sensitivities, E_s, E_e, F * scale_F, E_b, dX)
            )
            dX["d"] = slope = info.lu.solve(-system.load_derivative(X, lam)) / d_max
            if previous[0] is not None and d_last > previous[1]:
                curvature = (slope - previous[0]) / (d_last - previous[1])
            rec["dFdd"].append(system.force_derivative(X, lam, slope) * scale_F)
            tangents.append(dX)
        dF = {p: np.array([r[p] for r in rec["dF"]]) for p in sensitivities}
        return BendPath(
            deflection=d,
            force=np.array(rec["F"]) * scale_F,
            dforce=dF,
            support_s=np.array([x[-1] for x in rec["X"]]) * S,
            states=rec["X"],
            scaled=scaled,
            tangents=tangents,
            dforce_dd=np.array(rec["dFdd"]),
            newton_iterations=info.iterations,
            load_steps=info.steps,
            runtime_s=time.perf_counter() - t0,
        )

    def half_state(self, path: BendPath, index: int = -1) -> tuple[np.ndarray, ...]:
        """(s, x, z, theta) of the half model at one path state, SI, sorted by s from mid-span."""
        return self.half_state_of(path.states[index])

    def half_state_of(self, X: np.ndarray) -> tuple[np.ndarray, ...]:
        """(s, x, z, theta) of the half model at a state X (see :meth:`half_state`)."""
        S = self.geometry.span
        system = self.__dict__.get("_shape_system")
        if system is None:  # geometry only: built once per model
            system = self._shape_system = self.system(1.0, 1.0, 1.0, 1.0)
        system.at(X[-1])
        order = np.argsort(system.rod.disc.s_dof)
        x, z, theta = system.rod.expand(X[: system.nu]).reshape(-1, 3)[order].T
        return system.rod.disc.s_dof[order] * S, x * S, z * S, theta

    def shape(self, path: BendPath, index: int = -1) -> dict:
        """The deformed whole tube (mirrored half model) at one path state, SI, with the cylinders.

        Coordinates: z along the span from mid-span, x up; cylinder centres as (z, x).
        """
        S, g = self.geometry.span, self.geometry
        d = float(path.deflection[index])
        _, x, z, _ = self.half_state(path, index)
        return {
            "z": np.concatenate([-z[::-1], z[1:]]),
            "x": np.concatenate([x[::-1], x[1:]]),
            "outer_radius": 0.5 * g.outer_diameter,
            "deflection": d,
            "supports": [((side * 0.5 * S, -self.support_rho * S), g.support_radius) for side in (-1, 1)],
            "nose": ((0.0, self.nose_rho * S - d), g.nose_radius),
            "support_contact_s": float(path.states[index][-1] * S),
        }

    def _step(self, system, X, lam, target, warm, info: NewtonInfo, d_max: float) -> np.ndarray:
        if warm is not None:
            try:
                X_new, its, lu = newton(system, warm, target)
                if system.reject(X_new, target) is None:
                    info.iterations += its
                    info.steps += 1
                    info.lu = lu
                    return X_new
                info.rejected += 1
            except NewtonFailure:
                info.rejected += 1
        if target == lam:  # e.g. a d = 0 row: converge there for the tangent the sensitivities need
            if info.lu is None:
                X, its, info.lu = newton(system, X, lam)
                info.iterations += its
            return X
        try:
            X, _ = follow(system, X, [target], lam0=lam, first_step=max(target - lam, 1e-3), info=info)
        except ConvergenceError as exc:
            if X[-1] > 0.98 * self.half or "left the rod" in str(exc):
                raise SlipOffError(
                    "the tube end reached the support: it slips off",
                    deflection=(exc.load_factor or lam) * d_max,
                ) from exc
            raise
        return X

    @staticmethod
    def _check(system: BendSystem, X: np.ndarray, lam: float) -> None:
        mult = X[system.nu : system.nu + 2]
        if np.any(mult < -1e-9 * max(1.0, np.max(np.abs(mult)))):
            raise ConvergenceError(
                "a contact pulls (the tube lifts off a support or the nose)", load_factor=lam
            )


def _predict(start: BendPath | None, i: int, scaled: tuple[float, float], d: float) -> np.ndarray | None:
    """Warm-start state i: the earlier state plus dX/dp dp for the scaled E_s, E_e and
    dX/dd dd for the deflection, as far as they are known (first order).

    Measured on the E_s fit: Newton from this first-order prediction needs 2 iterations
    per point where the bare earlier state needs 3.
    """
    if start is None:
        return None
    X = start.states[i]
    if start.scaled is None or i >= len(start.tangents) or not start.tangents[i]:
        return X
    t = start.tangents[i]
    steps = [(name, new - old) for name, new, old in zip(("E_s", "E_e"), scaled, start.scaled, strict=True)]
    steps.append(("d", d - start.deflection[i]))
    return X + sum(t[name] * step for name, step in steps if name in t and step != 0.0)


def _sensitivities(system, X, lu, names, E_s, E_e, F, E_b, dX_out: dict | None = None) -> dict[str, float]:
    """dF/dp from the linearised equilibrium (SI; see the module docstring); dX/dp (scaled) into dX_out."""
    out: dict[str, float] = {}
    if not names:
        return out
    system.at(X[-1])
    normal = system.contacts(system.rod.expand(X[: system.nu]), 0.0)[1][4]
    for name in ("E_s", "E_e"):
        if name in names or "E_b" in names:
            dX = lu.solve(-system.stiffness_derivative(X, name))
            if dX_out is not None:
                dX_out[name] = dX
            out[name] = float(2.0 * dX[system.nu + 1] * (-normal[0]))
    if "E_b" in names:
        out["E_b"] = (F - E_s * out["E_s"] - E_e * out["E_e"]) / E_b
    return {k: v for k, v in out.items() if k in names}
