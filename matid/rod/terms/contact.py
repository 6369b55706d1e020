"""Frictionless unilateral contact of the tube's outer surface with walls and a lumen
(``[[wall]]``, ``[lumen]``; contract section 12, physics.md section 9).

Contact acts at every node of the mesh (P2: vertices and mid-points, the tip included) on the
gap g of :mod:`matid.physics.boundaries` at the outer radius R_o(s) there. The reaction at a node
is f = max(0, mu - k g) along grad g: the gradient of the augmented-Lagrangian energy
(1/2k) max(0, mu - k g)^2, with the multiplier estimate mu held during a Newton solve. Newton
on it is a semismooth Newton (its tangent k grad g grad g^T - f H_g on the nodes where f > 0);
between Newton solves :func:`matid.rod.contact_rounds.settle` updates mu, until every gap is
>= -tol and the loaded nodes meet their walls: by the linear complementarity problem of the loaded
nodes (their multipliers >= 0 that close their gaps to first order, released where they would
pull), Uzawa's mu <- f where it cannot be solved (issue 31: Uzawa alone crawled when loaded nodes
sit close together, a contact between two nodes or a stretch). ``method = "penalty"`` keeps
mu = 0 and multiplies k by 10 instead (a penalty with continuation), until the penetration f/k is
below tol.

The choice, measured (tests/rod/test_contact.py::test_method_comparison, P2, 16 elements,
E L^2/E_b = 1e9, against the shooting reference of tests/rod/contact_reference.py; Newton
iterations of the continuation and the settling, the smallest gap (scaled by L), tip error / L,
contact force relative error):

    case                       method       Newton   gap min    tip      force
    tip force on a wall        augmented      16     1.5e-11   3.2e-9   3.1e-9
                               penalty        33     -2.4e-10  3.2e-9   1.2e-8
    tip magnet on a wall       augmented       9     2.2e-11   5.1e-8   3.4e-7
                               penalty        30     -2.3e-10  5.1e-8   3.8e-7
    propped cantilever 30 deg  augmented       7     2.2e-14   1.5e-12  1.3e-9
                               penalty        19     -1.8e-10  2.1e-10  5.3e-8

The augmented Lagrangian is kept: half the Newton iterations or fewer (its k = 1e4 stays
moderate, one or two multiplier updates meet the walls within 1e-10 L), while the penalty must
climb to k ~ 1e10 to bring f/k below the tolerance and stops just inside it (a residual
penetration of 2e-10 L, which costs it an order of magnitude in the force). (With Uzawa's updates
alone, before the complementarity step: 19, 14 and 10 iterations.) One case went the other way
then: a wall the whole straight rod touches (x = R_o) with a point load at L/2 pressing the rod
along it (a contact stretch, E L^2/E_b = 1e9, 16 elements): the augmented run stopped on Newton's
round-off stagnation, the penalty converged in 25 iterations; stretches now settle
(tests/rod/test_contact_stretch.py). The active set with a semismooth Newton on min(lambda, c g)
(multipliers as unknowns) was not built: the terms' interface has no extra unknowns, and the
complementarity step on the multipliers between Newton solves does its work.

Every state :func:`matid.rod.contact_rounds.settle` returns is checked
(:func:`matid.rod.contact_rounds.check`, ContactStateError otherwise): gap >= -tol at every node,
no reaction where the gap is open (complementarity: f = 0 where g > tol), no pulling one (f >= 0),
and stable with its contacts: the stability test of :meth:`RodSystem.reject` factorises the
tangent including the contact stiffness k grad g grad g^T of the active nodes (stability on the
tangent space of the active constraints, as k grows).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from matid.physics import kinematics as kin
from matid.physics.boundaries import Centreline, lumen_gap, wall_gap
from matid.rod.models import PLANAR
from matid.rod.terms.base import Scale, Term

#: Multiplier of the augmented Lagrangian (scaled E_b/L^3) and the penalty's first k.
K_AUGMENTED, K_PENALTY = 1e4, 1e2
#: Outer iterations (multiplier updates or penalty increases) before giving up.
MAX_OUTER = 30
#: contact_tolerance = CONTACT_FRACTION x the scene's tolerance x L (penetration allowed).
CONTACT_FRACTION = 1e-3
METHODS = ("augmented", "penalty")
#: Two loaded nodes belong to one contact only on the same side of their boundary: their walls'
#: normals (the gaps' gradients) within 60 degrees. A lumen is one boundary; a tube pressed
#: through a bend touches its outer side, its inner corner and its outer side again within a few
#: nodes of a coarse mesh (issue 31, the magnetic workspace in a bent 0.6 mm lumen at 12-14
#: elements: three point contacts and a short stretch were one "stretch" from 0.32 to 1 L whose
#: forces cancelled, -1.1 of +12.9, -26.5, +12.6, and the rounds chased its ends).
SAME_SIDE = 0.5
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
    active: bytes = b""  # the loaded nodes of the last evaluation (Contact.branch)


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
        held = ~np.any(system.disc.free[dofs], axis=1)  # the clamp: its node carries no contact force
        return {"s": s, "R": R, "dofs": dofs, "pattern": disc.block_pattern(dofs), "line": line,
                "planar": system.model == PLANAR, "state": state, "held": held}  # fmt: skip

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
        f[:, prep["held"]] = 0.0
        return f, gaps

    # -- what the system sums --------------------------------------------------
    def nodal(self, system, prep, U, lam, R, blocks) -> None:
        f, gaps = self.forces(prep, U)
        k, planar = prep["state"].k, prep["planar"]
        prep["state"].active = np.packbits(f > 0.0).tobytes()
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

    def branch(self, prep) -> bytes:
        """The loaded nodes of the last :meth:`nodal`: Newton's residual is smooth while they stay."""
        return prep["state"].active

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
    def runs(self, f: np.ndarray, gaps: list, s: np.ndarray) -> list[tuple[int, np.ndarray]]:
        """(boundary, node indices of one contact) per contact, in order of s: runs of consecutive
        loaded nodes, merged across unloaded nodes that stay within the scene's tolerance of the
        wall (at the round-off of the complementarity a node of a stretch can carry nothing), and
        across at most two unloaded nodes next to a stretch (more than three loaded nodes): a coarse
        mesh lifts a few nodes by up to 1e-5 L where the rod leaves a wall and loads the node
        beyond, which is no point contact of its own."""
        order = np.argsort(s)
        near = self.tolerance / CONTACT_FRACTION
        out = []
        for b, (g, grad, _) in enumerate(gaps):
            fb, gb, nb = f[b][order], g[order], grad[order]
            loaded = np.flatnonzero(fb > 0)
            if loaded.size == 0:
                continue
            pairs = list(zip(loaded[:-1], loaded[1:], strict=True))
            apart = [np.any(gb[i + 1 : j] > near) or nb[i] @ nb[j] < SAME_SIDE for i, j in pairs]
            cuts = [k + 1 for k, cut in enumerate(apart) if cut]
            runs = np.split(loaded, cuts)
            k = 0
            while k + 1 < len(runs):  # a stretch takes in a run at most two unloaded nodes away
                a, c = runs[k], runs[k + 1]
                if c[0] - a[-1] <= 3 and max(a.size, c.size) > 3 and nb[a[-1]] @ nb[c[0]] >= SAME_SIDE:
                    runs[k : k + 2] = [np.concatenate([a, c])]
                    k = max(k - 1, 0)
                else:
                    k += 1
            out += [(b, order[run]) for run in runs]
        return sorted(out, key=lambda run: (float(s[run[1]].min()), run[0]))

    def contacts(self, system, prep, U: np.ndarray, f: np.ndarray | None = None) -> list[dict]:
        """One entry per contact (:meth:`runs`) (scaled): boundary, s range (a point: the
        force-weighted s twice when the run spans at most three nodes), force-weighted position,
        resultant force (3D frame), smallest gap of the boundary. ``f``: the reactions (default
        :meth:`forces`; :func:`matid.rod.contact_rounds.report` adds the clamp's on a wall it touches)."""
        f0, gaps = self.forces(prep, U)
        f = f0 if f is None else f
        r, s = self.positions(prep, U), prep["s"]
        out = []
        for b, idx in self.runs(f, gaps, s):
            g, grad = gaps[b][0], gaps[b][1]
            w = f[b][idx]
            F = (w[:, None] * grad[idx]).sum(axis=0)  # the reaction on the tube: f grad g
            sc = float(w @ s[idx] / w.sum())
            span = (sc, sc) if idx.size <= 3 else self._span(system, prep, U, gaps[b], idx)
            out.append({
                "boundary": self.names[b], "s": span,
                "position": (w @ r[idx]) / w.sum(), "force": F,
                "gap_min": float(g.min()),
            })  # fmt: skip
        return out

    def directors(self, system, prep, U: np.ndarray, nodes) -> np.ndarray:
        """d3 (n, 3) at the given nodes, in the term's frame."""
        nf, nodes = system.disc.nf, np.asarray(nodes)
        if prep["planar"]:
            theta = U[nodes * nf + 2]
            return np.stack([np.sin(theta), np.zeros(theta.size), np.cos(theta)], axis=1)
        q = U[nodes[:, None] * nf + np.arange(3, 7)]
        return np.array(kin.d3(q.T)).T

    def touch_points(self, system, prep, U: np.ndarray, f: np.ndarray | None = None) -> list[tuple]:
        """Per point contact (a run of at most three nodes, :meth:`runs`), in order: (s where the
        P2 interpolant of its boundary's gap is smallest on the elements holding the loaded nodes,
        s of its most loaded node, the gap's slope dg/ds = grad g . d3 there, and (s of the first,
        of the last loaded node) when nodes on both sides of the most loaded one are loaded, else
        None: a short stretch, :mod:`matid.rod.contact_mesh`), scaled. A contact on
        a node away from the true touching point leaves the rod crossing the wall beside it and not
        tangent to it (slope != 0): what matid.rod.contact_mesh.contact_rounds moves a mesh
        vertex by (issue 31). A stretch gets no touch point: where it leaves the wall is estimated
        on one element (:meth:`_leaves`), 3e-3 L off on the coarse meshes that settle the tip, and
        rounds on it did not settle in 6 (measured: a cantilever pressed on a wall by a load and
        pulled off by a tip force, q L^3/E_b = 10, P L^2/E_b = 2); the estimate covers its O(h)
        end on nested meshes (tests/rod/test_contact_stretch.py). A stretch with both ends inside
        the rod gets a vertex at each end from :mod:`matid.rod.contact_mesh`."""
        f0, gaps = self.forces(prep, U)
        f = f0 if f is None else f
        s = prep["s"]
        order = np.argsort(s)
        ss, rank = s[order], np.argsort(order)
        out = []
        for b, idx in self.runs(f, gaps, s):
            g, grad, H = gaps[b]
            sorted_idx = np.sort(rank[idx])
            if idx.size > 3:  # a stretch
                continue
            gb = g[order]
            firsts = {2 * (i // 2) for i in sorted_idx}
            firsts |= {2 * ((i - 1) // 2) for i in sorted_idx if i % 2 == 0 and i > 0}
            best = min(_smallest(ss[e : e + 3], gb[e : e + 3]) for e in firsts if e + 2 < ss.size)
            node = int(idx[np.argmax(f[b][idx])])
            d3 = self.directors(system, prep, U, [node])[0]
            both = sorted_idx[0] < rank[node] < sorted_idx[-1]  # loaded on both sides of it
            span = (float(ss[sorted_idx[0]]), float(ss[sorted_idx[-1]])) if both else None
            out.append((best[1], float(s[node]), float(grad[node] @ d3), span))
        return out

    def _span(self, system, prep, U, gap, idx) -> tuple[float, float]:
        """(from, to) of a stretch: each end where the rod leaves the wall (:meth:`_leaves`) when
        that lies within an element of its last loaded node, else that node (the clamp, the tip)."""
        s = prep["s"]
        order = np.argsort(s)
        ss, rank = s[order], np.argsort(order)
        ranks = np.sort(rank[idx])
        ends = []
        for end, side in ((ranks[0], -1), (ranks[-1], 1)):
            point = self._leaves(system, prep, U, gap, order, ss, end, side)
            near = ss[np.clip(end - 2 * side, 0, ss.size - 1)], ss[np.clip(end + 2 * side, 0, ss.size - 1)]
            ok = point is not None and min(near) <= point <= max(near)
            ends.append(float(point) if ok else float(ss[end]))
        return ends[0], ends[1]

    def _leaves(self, system, prep, U, gap, order, ss, end: int, side: int) -> float | None:
        """Where the rod leaves the wall beyond the stretch node ``end`` (sorted index) on ``side``
        (+1 towards the tip, -1 towards the clamp), or None at the clamp's or the tip's element."""
        v = end + (end % 2) if side > 0 else end - (end % 2)  # the vertex closing the loaded nodes
        lo = v if side > 0 else v - 2
        if lo < 2 or lo + 2 > ss.size - 3:  # the clamp's element, or the tip's: no vertex wanted
            return None
        nodes = order[lo : lo + 3]
        se = ss[lo : lo + 3]
        d3 = self.directors(system, prep, U, nodes)
        dd3 = quadratic_slopes(se, d3)
        _, grad, H = gap
        psi = np.einsum("ij,ij->i", grad[nodes], dd3)
        if H is not None:
            psi += np.einsum("ij,ijk,ik->i", d3, H[nodes], d3)
        dx = se - se.mean()  # the least-squares line through (se, psi), centred: no Vandermonde
        slope = float(dx @ psi) / float(dx @ dx)
        if slope == 0.0:
            return None
        h = se[2] - se[0]
        return float(np.clip(se.mean() - psi.mean() / slope, se[0] - h, se[2] + h))

    def quantities(self, system, prep, U: np.ndarray, f: np.ndarray | None = None) -> np.ndarray:
        """Per boundary: the resultant force (3) and the force-weighted s: what the error estimate
        follows beyond the tip."""
        f0, gaps = self.forces(prep, U)
        f = f0 if f is None else f
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


def quadratic_slopes(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The slopes at x (3,) of the quadratic through (x, y (3, k)), Lagrange's form in differences
    from the first node (exact however close the nodes: np.polyfit's Vandermonde warned RankWarning
    on the terminal when a contact put thousands of vertices on a rod)."""
    t, dy = x - x[0], y - y[0]
    d01, d02, d12 = t[0] - t[1], t[0] - t[2], t[1] - t[2]
    den = np.array([d01 * d02, -d01 * d12, d02 * d12])
    others = np.array([t[1] + t[2], t[0] + t[2], t[0] + t[1]])
    return ((2.0 * t[:, None] - others[None, :]) / den[None, :]) @ dy
