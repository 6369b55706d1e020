"""The three-point-bend scene: deflection-controlled path, nose force, sensitivities.

Scaled by the span S and E_b: lengths /S, forces /(E_b/S^2). Unknowns are the
free planar dofs of the half rod (:mod:`matid.physics.contact`), the two contact
multipliers and sigma, the arc length of the support vertex; the system is

    [K - sum lam_c d2g_c   -G^T   dR/dsigma] [du    ]   = -[R - G^T lam]
    [-G                      0       0     ] [dlam  ]      [-g        ]
    [dh/du                   0       0     ] [dsigma]      [h         ]

and the load factor moves the nose: d = lam d_max. A point contact puts a
corner into the centreline of a shear-deformable rod, so each contact sits on
a mesh vertex: the nose on vertex 0 (mid-span, by symmetry), the support on the
vertex at sigma, the mesh built around it, and h = 0 makes that vertex the
contact section.

Sensitivities of the nose force to the stiffnesses come from the linearised
equilibrium at each converged point: A dX/dp = -dR/dp, one back-substitution
with the factorised tangent (the energy is linear in each stiffness, so dR/dp
is the residual of that one energy term). The force is homogeneous of degree
one in (E_b, E_s, E_e), so dF/dE_b = (F - E_s dF/dE_s - E_e dF/dE_e) / E_b.
The same back-substitution gives the load tangent dX/dd (dR/dlam in closed
form), which predicts the next point of the path and gives dF/dd.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from matid.errors import ConvergenceError, SlipOffError
from matid.physics.contact import Circle
from matid.rod.bend_system import BendSystem
from matid.rod.fem import Discretisation
from matid.rod.models import PLANAR, ScaledRod
from matid.rod.newton import NewtonFailure, NewtonInfo, check_admissible, follow, newton
from matid.rod.system import RodSystem

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


#: Meshes of n and 2n elements nest from 2 BASE elements up (:func:`support_vertex`).
BASE = 4


def support_vertex(elements: int, fraction: float) -> int:
    """The vertex of the support's contact section on ``elements`` elements of the half model, near
    ``fraction`` of them, chosen so that meshes of n and 2n elements nest (2n puts it at twice the
    vertex of n, so every element halves, as Richardson's estimate assumes): ``elements`` = m 2^p
    with BASE <= m < 2 BASE (or m odd) has it at 2^p times its place on m elements."""
    m, p = elements, 0
    while m % 2 == 0 and m // 2 >= BASE:
        m, p = m // 2, p + 1
    return 2**p * min(max(1, round(m * fraction)), m - 1)


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
        k = self.support_vertex = support_vertex(elements, 0.5 / self.half)
        self._fractions = (np.linspace(0.0, 1.0, k + 1), np.linspace(0.0, 1.0, elements - k + 1)[1:])

    def vertices(self, s_contact: float) -> np.ndarray:
        """Uniform elements on each side of the support's contact section."""
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

        Each point starts Newton from a prediction: the last point moved along the load
        tangent dX/dd (second order), or with ``start``, the path of an earlier solve at
        as many deflections (other stiffnesses, deflections moved a little: the centreline
        fit), each of its states moved by dX/dp dp + dX/dd dd, whichever guess was closer
        at the last point; continuation is the fallback.
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
        curvature = miss = None  # d2X/dd2 from the last two slopes; the last warm prediction's error
        errors = [np.inf, np.inf]  # of the warm and the along-the-path guess at the last point
        for i, target in enumerate(d / d_max):
            # two guesses: the earlier path's state moved to these stiffnesses (warm), and this
            # path's last state moved along its tangent (second order); Newton starts from the one
            # that was closer at the last point (warm wins for small changes, along for large ones)
            warm = predicted = _predict(start, i, scaled, d[i])
            if warm is not None and miss is not None:  # the last point's prediction error: smooth in d
                warm = warm + miss
            along = None
            if slope is not None:
                h = d[i] - d_last
                along = X + slope * h + (0.5 * h * h * curvature if curvature is not None else 0.0)
            guess = warm if along is None or (warm is not None and errors[0] <= errors[1]) else along
            X = self._step(system, X, lam, target, guess, info, d_max)
            errors = [np.inf if g is None else float(np.max(np.abs(X - g))) for g in (warm, along)]
            miss = X - predicted if predicted is not None else None
            lam, d_last, previous = target, d[i], (slope, d_last)
            if system.reject(X, lam):  # a row with no Newton step (lam == target)
                raise ConvergenceError(
                    "a contact pulls (the tube lifts off a support or the nose)", load_factor=lam
                )
            F = system.force(X, lam)
            rec["X"].append(X.copy()), rec["F"].append(F)
            dX = system.derivatives(X, lam, info.lu, stiffness=bool(sensitivities))
            dX["d"] = slope = dX.pop("lam") / d_max
            rec["dF"].append(_sensitivities(system, X, lam, dX, sensitivities, E_s, E_e, F * scale_F, E_b))
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

    def geometry_system(self) -> BendSystem:
        """A system of this model for its geometry only (meshes, dof numbering), built once per
        model; its mesh is wherever the last caller moved it (:meth:`BendSystem.at`)."""
        system = self.__dict__.get("_geometry_system")
        if system is None:
            system = self._geometry_system = self.system(1.0, 1.0, 1.0, 1.0)
        return system

    def half_state(self, path: BendPath, index: int = -1) -> tuple[np.ndarray, ...]:
        """(s, x, z, theta) of the half model at one path state, SI, sorted by s from mid-span."""
        return self.half_state_of(path.states[index])

    def half_state_of(self, X: np.ndarray) -> tuple[np.ndarray, ...]:
        """(s, x, z, theta) of the half model at a state X (see :meth:`half_state`)."""
        S = self.geometry.span
        system = self.geometry_system()
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
                check_admissible(system, X_new, target)
                info.iterations += its
                info.steps += 1
                info.lu = lu
                return X_new
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


def _sensitivities(system, X, lam, dX: dict, names, E_s, E_e, F, E_b) -> dict[str, float]:
    """dF/dp (SI) from dX/dp of the linearised equilibrium (see the module docstring)."""
    if not names:
        return {}
    out = {name: system.force_derivative(X, lam, dX[name]) for name in ("E_s", "E_e")}
    if "E_b" in names:
        out["E_b"] = (F - E_s * out["E_s"] - E_e * out["E_e"]) / E_b
    return {k: v for k, v in out.items() if k in names}
