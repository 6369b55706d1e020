"""Frictionless unilateral contact of the tube's outer surface with walls and a lumen
(``[[wall]]``, ``[lumen]``; contract section 12, physics.md section 9).

Contact acts at every node of the mesh (P2: vertices and mid-points, the tip included) on the
gap g of :mod:`matid.physics.boundaries` at the outer radius R_o(s) there. The reaction at a node
is f = max(0, mu - k g) along grad g: the gradient of the augmented-Lagrangian energy
(1/2k) max(0, mu - k g)^2, with the multiplier estimate mu held during a Newton solve. Newton
on it is a semismooth Newton (its tangent k grad g grad g^T - f H_g on the nodes where f > 0);
between Newton solves :func:`settle` updates mu <- f (Uzawa) until every gap is >= -tol and the
reactions no longer change. ``method = "penalty"`` keeps mu = 0 and multiplies k by 10 instead
(a penalty with continuation), until the penetration f/k is below tol.

The choice, measured (tests/rod/test_contact.py::test_method_comparison, P2, 16 elements,
E L^2/E_b = 1e9, against the shooting reference of tests/rod/contact_reference.py; Newton
iterations of the continuation and the settling, the smallest gap (scaled by L), tip error / L,
contact force relative error):

    case                       method       Newton   gap min    tip      force
    tip force on a wall        augmented      19     -9e-15    3.2e-9   3.1e-9
                               penalty        33     -2.4e-10  3.2e-9   1.2e-8
    tip magnet on a wall       augmented      14     -2e-17    5.1e-8   3.4e-7
                               penalty        30     -2.3e-10  5.1e-8   3.8e-7
    propped cantilever 30 deg  augmented      10     -1e-16    1.5e-12  1.3e-9
                               penalty        19     -1.8e-10  2.1e-10  5.3e-8

The augmented Lagrangian is kept: half the Newton iterations (its k = 1e4 stays moderate, two or
three multiplier updates meet the walls to round-off), while the penalty must climb to k ~ 1e10 to
bring f/k below the tolerance and stops just inside it (a residual penetration of 2e-10 L, which
costs it an order of magnitude in the force). One case went the other way: a wall the whole
straight rod touches (x = R_o) with a point load at L/2 pressing the rod along it (a contact
stretch, E L^2/E_b = 1e9, 16 elements): the augmented run stopped on Newton's round-off
stagnation, the penalty converged in 25 iterations. Stiff rods lying along a wall are the weak case.
The active set with a semismooth Newton on min(lambda, c g) (multipliers as unknowns) was not
built: the terms' interface has no extra unknowns, and the augmented Lagrangian's inner Newton is
already a semismooth Newton on the same active set.

Every state :func:`settle` returns satisfies gap >= -tol at every node, has no reaction where the
gap is open (complementarity: f = 0 where g > tol) and no pulling one (f >= 0 by construction),
and is stable with its contacts: the stability test of :meth:`RodSystem.reject` factorises the
tangent including the contact stiffness k grad g grad g^T of the active nodes (stability on the
tangent space of the active constraints, as k grows).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from matid.errors import ConvergenceError
from matid.physics import kinematics as kin
from matid.physics.boundaries import Centreline, lumen_gap, wall_gap
from matid.rod.models import PLANAR
from matid.rod.newton import NewtonFailure
from matid.rod.terms.base import Scale, Term

#: Multiplier of the augmented Lagrangian (scaled E_b/L^3) and the penalty's first k.
K_AUGMENTED, K_PENALTY = 1e4, 1e2
#: Outer iterations (multiplier updates or penalty increases) before giving up.
MAX_OUTER = 30
#: contact_tolerance = CONTACT_FRACTION x the scene's tolerance x L (penetration allowed).
CONTACT_FRACTION = 1e-3
METHODS = ("augmented", "penalty")
#: The method every scene uses (see the module docstring for the measurements that chose it).
METHOD = "augmented"


@dataclass
class ContactState:
    """What a system's contact term carries between Newton solves (mutable, one per system)."""

    k: float
    mu: np.ndarray  # (boundaries, nodes) multiplier estimates
    checking: bool = False  # reject states that break the walls (set by settle)
    outer: int = 0
    newton: int = 0


@dataclass(frozen=True)
class Contact(Term):
    """Walls (point, normal) and a lumen (points, radius, corner radius), scaled by L; the planar
    model sees them in its (transverse, normal, axial) frame."""

    walls: tuple[tuple[tuple[float, ...], tuple[float, ...]], ...]
    lumen: tuple | None  # (centreline points, radius, corner radius)
    radii: tuple[tuple[float, float, float], ...]  # (from, to, R_o) scaled; last wins
    R_o: float
    tolerance: float  # scaled penetration allowed
    method: str = "augmented"
    names: tuple[str, ...] = field(default=())

    label = "contact"

    @classmethod
    def from_scene(cls, scene, scale: Scale) -> Contact | None:
        if not scene.walls and scene.lumen is None:
            return None
        L = scale.L
        walls = tuple((scale.vec(w.point, 1 / L), scale.vec(w.normal, 1.0)) for w in scene.walls)
        lumen = None
        if scene.lumen is not None:
            lu = scene.lumen
            lumen = (tuple(scale.vec(p, 1 / L) for p in lu.centreline), lu.radius / L, lu.corner_radius / L)
        radii = tuple(
            (seg.start / L, seg.end / L, 0.5 * seg.overrides["outer_diameter"] / L)
            for seg in scene.rod.segments
            if "outer_diameter" in seg.overrides
        )
        names = tuple(f"wall {i + 1}" for i in range(len(walls))) + (("lumen",) if lumen else ())
        tol = CONTACT_FRACTION * scene.tolerance
        return cls(walls, lumen, radii, 0.5 * scene.rod.outer_diameter / L, tol, METHOD, names)

    # -- binding ---------------------------------------------------------------
    def prepare(self, system):
        disc = system.disc
        s = disc.s_dof
        R = np.full(s.shape, self.R_o)
        tip = s.max()
        for a, b, r in self.radii:  # [a, b), and the tip node on a segment that reaches the tip
            R = np.where((s >= a) & ((s < b) | ((s == tip) & (b >= tip - 1e-9))), r, R)
        cols = [0, 1] if system.model == PLANAR else [0, 1, 2]
        nodes = np.arange(disc.nscalar)
        dofs = nodes[:, None] * disc.nf + np.asarray(cols)
        line = None if self.lumen is None else Centreline.rounded(self.lumen[0], self.lumen[2])
        k = K_AUGMENTED if self.method == "augmented" else K_PENALTY
        state = ContactState(k, np.zeros((len(self.names), nodes.size)))
        return {"s": s, "R": R, "dofs": dofs, "pattern": disc.block_pattern(dofs), "line": line,
                "planar": system.model == PLANAR, "state": state}  # fmt: skip

    def positions(self, prep, U: np.ndarray) -> np.ndarray:
        """(n, 3) centreline points at the nodes in the term's frame (planar: (x, 0, z))."""
        r = U[prep["dofs"]]
        return np.stack([r[:, 0], np.zeros(len(r)), r[:, 1]], axis=1) if prep["planar"] else r

    def gaps(self, prep, U: np.ndarray, hessian: bool = True) -> list:
        """[(g, grad g, H_g or None)] per boundary at the nodes (3D frame)."""
        r, R = self.positions(prep, U), prep["R"]
        out = [(*wall_gap(r, p, n, R), None) for p, n in self.walls]
        if self.lumen is not None:
            out.append(lumen_gap(r, prep["line"], self.lumen[1], R))
        return out

    def forces(self, prep, U: np.ndarray) -> tuple[np.ndarray, list]:
        """(f (boundaries, nodes) >= 0, gaps) at U."""
        state, gaps = prep["state"], self.gaps(prep, U)
        f = np.array([np.maximum(0.0, state.mu[b] - state.k * g) for b, (g, _, _) in enumerate(gaps)])
        return f, gaps

    # -- what the system sums --------------------------------------------------
    def nodal(self, system, prep, U, lam, R, blocks) -> None:
        f, gaps = self.forces(prep, U)
        k, planar = prep["state"].k, prep["planar"]
        n = f.shape[1]
        grad_sum = np.zeros((n, 3))
        K = np.zeros((n, 3, 3))
        for b, (_, grad, H) in enumerate(gaps):
            fb = f[b]
            grad_sum -= fb[:, None] * grad
            active = (fb > 0.0).astype(float)
            K += (k * active)[:, None, None] * grad[:, :, None] * grad[:, None, :]
            if H is not None:
                K -= fb[:, None, None] * H
        if planar:
            grad_sum, K = grad_sum[:, [0, 2]], K[:, [0, 2]][:, :, [0, 2]]
        R[prep["dofs"]] += grad_sum
        blocks.append((prep["pattern"], K))

    def reject(self, system, prep, U, lam) -> str | None:
        state = prep["state"]
        if not state.checking:
            return None
        f, gaps = self.forces(prep, U)
        g = np.array([gb for gb, _, _ in gaps])
        if g.min() < -self.tolerance:
            return f"the tube crosses a wall by {-g.min():.3g} L (contact tolerance {self.tolerance:.3g} L)"
        if np.any((f > 0) & (g > self.tolerance)):
            return "a contact reaction acts across an open gap (not complementary)"
        return None

    # -- what a solution reports -------------------------------------------------
    def contacts(self, system, prep, U: np.ndarray) -> list[dict]:
        """One entry per run of consecutive loaded nodes per boundary (scaled): boundary, s range
        (a point: the force-weighted s twice when the run spans at most two nodes' intervals),
        force-weighted position, resultant force (3D frame), smallest gap of the boundary."""
        f, gaps = self.forces(prep, U)
        r, s = self.positions(prep, U), prep["s"]
        order = np.argsort(s)
        out = []
        for b, (g, grad, _) in enumerate(gaps):
            fb = f[b][order]
            loaded = np.flatnonzero(fb > 0)
            if loaded.size == 0:
                continue
            runs = np.split(loaded, np.flatnonzero(np.diff(loaded) > 1) + 1)
            for run in runs:
                idx = order[run]
                w = f[b][idx]
                F = (w[:, None] * grad[idx]).sum(axis=0)  # the reaction on the tube: f grad g
                sc = float(w @ s[idx] / w.sum())
                span = (sc, sc) if run.size <= 3 else (float(s[idx].min()), float(s[idx].max()))
                out.append({
                    "boundary": self.names[b], "s": span,
                    "position": (w @ r[idx]) / w.sum(), "force": F,
                    "gap_min": float(g.min()),
                })  # fmt: skip
        return out

    def touch_points(self, system, prep, U: np.ndarray) -> list[tuple[float, float, float]]:
        """Per point contact (a run of at most three loaded nodes, as :meth:`contacts`), in order:
        (s where the P2 interpolant of its boundary's gap is smallest on the elements holding the
        loaded nodes, s of its most loaded node, the gap's slope dg/ds = grad g . d3 there), scaled.
        A contact on a node away from the true touching point leaves the rod crossing the wall
        beside it (where the gap is smallest) and not tangent to it (slope != 0): what
        matid.rod.api.contact_rounds moves a mesh vertex by (issue 31)."""
        f, gaps = self.forces(prep, U)
        s, nf = prep["s"], system.disc.nf
        order = np.argsort(s)
        ss, out = s[order], []
        for b, (g, grad, _) in enumerate(gaps):
            fb, gb = f[b][order], g[order]
            loaded = np.flatnonzero(fb > 0)
            for run in np.split(loaded, np.flatnonzero(np.diff(loaded) > 1) + 1):
                if run.size == 0 or run.size > 3:
                    continue
                firsts = {2 * (i // 2) for i in run} | {2 * ((i - 1) // 2) for i in run if i % 2 == 0 and i > 0}
                best = min(_smallest(ss[e : e + 3], gb[e : e + 3]) for e in firsts if e + 2 < ss.size)
                node = int(order[run[np.argmax(fb[run])]])
                if prep["planar"]:
                    theta = U[node * nf + 2]
                    d3 = np.array([np.sin(theta), 0.0, np.cos(theta)])
                else:
                    d3 = np.array(kin.d3(U[node * nf + 3 : node * nf + 7]))
                out.append((best[1], float(s[node]), float(grad[node] @ d3)))
        return out

    def quantities(self, system, prep, U: np.ndarray) -> np.ndarray:
        """Per boundary: the resultant force (3) and the force-weighted s: what the error estimate
        follows beyond the tip."""
        f, gaps = self.forces(prep, U)
        s = prep["s"]
        out = []
        for b, (_, grad, _) in enumerate(gaps):
            F = (f[b][:, None] * grad).sum(axis=0)
            total = f[b].sum()
            out += list(F) + [float(f[b] @ s / total) if total > 0 else 0.0]
        return np.array(out)


def _smallest(s: np.ndarray, g: np.ndarray) -> tuple[float, float]:
    """(smallest value, its s) of the quadratic through three (s, g) on [s0, s2]."""
    a, b, c = np.polyfit(s - s[0], g, 2)
    candidates = [0.0, float(s[2] - s[0])]
    if a > 0 and 0.0 < -b / (2 * a) < candidates[1]:
        candidates.append(-b / (2 * a))
    return min((float(a * x * x + b * x + c), float(s[0] + x)) for x in candidates)


def contact_of(system) -> tuple[Contact, dict] | None:
    return next(((t, p) for t, p in system.nodal if isinstance(t, Contact)), None)


def settle(system, X: np.ndarray, info, newton, admissible) -> np.ndarray:
    """The converged state X (at load 1) of a system with contact brought to the walls: multiplier
    updates (augmented) or penalty increases, each followed by Newton, until the penetration is
    below tol and the reactions settle; then checked (:meth:`Contact.reject`, stability).
    ``newton`` and ``admissible`` are :func:`matid.rod.newton.newton` and its check (passed in:
    newton sits above the terms). Raises ConvergenceError when it cannot."""
    bound = contact_of(system)
    if bound is None:
        return X
    term, prep = bound
    state = prep["state"]
    lu = info.lu
    for outer in range(MAX_OUTER + 1):
        f, gaps = term.forces(prep, system.expand(X))
        penetration = max(0.0, -min(float(g.min()) for g, _, _ in gaps))
        if term.method == "penalty":
            if penetration <= term.tolerance:
                break
            state.k *= 10.0
        else:
            change = float(np.abs(f - state.mu).max())
            if penetration <= term.tolerance and change <= 1e-10 * max(1.0, float(f.max())):
                break
            state.mu = f
        if outer == MAX_OUTER:
            raise ConvergenceError(
                f"contact: the walls are not met within {term.tolerance:.3g} L after {MAX_OUTER} "
                f"{'penalty increases' if term.method == 'penalty' else 'multiplier updates'}",
                load_factor=1.0,
            )
        try:
            X, its, lu = newton(system, X, 1.0)
        except NewtonFailure as exc:
            message = f"contact: Newton failed while settling the contacts ({exc})"
            raise ConvergenceError(message, load_factor=1.0) from exc
        state.outer += 1
        state.newton += its
        info.iterations += its
    state.checking = True
    try:
        admissible(system, X, 1.0, lu)
    except NewtonFailure as exc:
        raise ConvergenceError(f"contact: {exc}", load_factor=1.0) from exc
    info.lu = lu
    return X


def to_lab(entries: list[dict], e_a, L: float, E_b: float) -> list[dict]:
    """Contacts of :meth:`Contact.contacts` in SI and the lab frame (planar: from the
    (transverse, normal, axial) frame of the plane e_a)."""
    if e_a is None:
        frame = np.eye(3)
    else:
        a0, a1 = float(e_a[0]), float(e_a[1])
        frame = np.array([[a0, a1, 0.0], [-a1, a0, 0.0], [0.0, 0.0, 1.0]])  # rows: the frame's axes
    return [
        {
            "boundary": c["boundary"],
            "s": [c["s"][0] * L, c["s"][1] * L],
            "position": (np.asarray(c["position"]) @ frame * L).tolist(),
            "force": (np.asarray(c["force"]) @ frame * E_b / L**2).tolist(),
            "gap_min": c["gap_min"] * L,
        }
        for c in entries
    ]
