"""An independent reference for rods touching walls: a planar shooting solver with frictionless,
unilateral contact (test-only; numpy and scipy, no matid code), and the closed forms it is checked
against (physics.md section 9, contract section 12).

Model: the inextensible, unshearable planar elastica (E_e = E_s = inf; no extensible or shearable
variant here), in the x-z plane of matid's scenes. The clamp holds s = 0 at the origin with the
tangent along +z; theta(s) is the angle of d3 from +z towards +x, so d3 = (sin theta, cos theta)
in (x, z) and a bending moment m is the e2 component of the internal moment:

    x' = sin theta,   z' = cos theta,   theta' = m / E_b(s),   m' = n_z sin theta - n_x cos theta,

the last being m' = -(r' x n).e2. With no distributed load the internal force n is constant between
point loads and jumps n(s-) = n(s+) + F at a point force F (tests/rod/reference.py's convention), so
n is known everywhere from the tip force and the point and contact forces; only m(0) is shot for.
A tip magnet of moment m along d3 in a field B = |B| (sin psi, cos psi) gives the end couple
(d3 x B).e2 = m |B| sin(psi - theta_L): m(L) = M_tip + m |B| sin(psi - theta_L).

Walls: a wall is a line through p with unit normal n_w pointing to the side the tube stays on; the
tube's outer radius R_o offsets the centreline: gap g(s) = n_w.(r(s) - p) - R_o >= 0. A contact
pushes with lambda n_w, lambda >= 0 (frictionless, unilateral):
- at the tip: unknown lambda, equation g(L) = 0, and n(L) = F_tip + lambda n_w;
- at an interior point: unknowns lambda and s_c, equations g(s_c) = 0 and n_w.d3(s_c) = 0 (the
  rod is tangent to the wall there), and n jumps by lambda n_w at s_c.
The caller gives the active set; ``solve_planar_contact`` solves it and checks complementarity
(every lambda >= 0, every gap >= -tol along the rod, sampled finely and refined at the minima).
``find_active_set`` tries candidate sets and keeps the admissible one; ``advance`` pushes the tube
out of a sheath step by step, each step started from the last. Not modelled: a contact stretch (the
rod lying along a wall over a length, where a point contact's gap turns negative right next to it);
find_active_set then raises, naming the sets it tried. A cold solve (no ``guess``) follows a path:
the loads raised on the free rod, then each wall moved in from where the free rod touches it.

Closed forms, written without the shooting code: ``elastica_tip_on_wall`` (the first integral
E_b theta'^2 / 2 = lambda cos(theta - gamma) + C through incomplete elliptic integrals, with or
without an inflection) and ``propped_cantilever_reaction`` (small-deflection beam theory).

Units: any consistent set (SI in the tests). Internally lengths are scaled by L, forces by E_b/L^2
and moments by E_b/L (E_b at the clamp) so that the shooting unknowns are O(1).
"""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar, root
from scipy.special import ellipeinc, ellipkinc

RTOL, ATOL = 1e-12, 1e-14
#: residual (scaled units) below which a shooting solve counts as converged
RESIDUAL_TOL = 1e-10


def _unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _rhs(s, y, nx, nz, eb):
    th = y[2]
    c, sn = math.cos(th), math.sin(th)
    return [sn, c, y[3] / eb, nz * sn - nx * c]


class PlanarRod:
    """A clamped planar rod with its loads and walls, in scaled units (s in [0, 1])."""

    def __init__(
        self,
        L,
        EI,
        R_o=0.0,
        walls=(),
        tip_force=(0.0, 0.0),
        tip_moment=0.0,
        B=(0.0, 0.0),
        m=0.0,
        point_loads=(),
        segments=(),
    ):
        self.L, self.EI = float(L), float(EI)
        self.fs, self.ms = self.EI / self.L**2, self.EI / self.L
        self.R_o = float(R_o) / self.L
        self.walls = [(np.asarray(p, float) / self.L, _unit(nw)) for p, nw in walls]
        self.F_tip = np.asarray(tip_force, float) / self.fs
        self.M_tip = float(tip_moment) / self.ms
        self.mB = float(m) * np.asarray(B, float) / self.ms  # m B, scaled as a moment
        # point loads: (s, (Fx, Fz)) or (s, (Fx, Fz), M)
        self.points = []
        for p in point_loads:
            s, F = p[0], p[1]
            M = p[2] if len(p) > 2 else 0.0
            self.points.append((float(s) / self.L, np.asarray(F, float) / self.fs, float(M) / self.ms))
        self.segments = [(float(a) / self.L, float(b) / self.L, float(e) / self.EI) for a, b, e in segments]

    def scaled(self, t: float, walls=None) -> PlanarRod:
        """A copy with every load times t and, if given, other walls (scaled units)."""
        out = copy.copy(self)
        out.F_tip, out.M_tip, out.mB = t * self.F_tip, t * self.M_tip, t * self.mB
        out.points = [(s, t * F, t * M) for s, F, M in self.points]
        if walls is not None:
            out.walls = walls
        return out

    def eb(self, s: float) -> float:
        out = 1.0
        for a, b, e in self.segments:
            if a <= s < b:
                out = e
        return out

    def gap(self, w: int, xz: np.ndarray) -> np.ndarray:
        p, nw = self.walls[w]
        return (np.asarray(xz).T - p) @ nw - self.R_o

    def tip_couple(self, theta: float) -> float:
        return self.M_tip + self.mB[0] * math.cos(theta) - self.mB[1] * math.sin(theta)

    def shoot(self, m0: float, contacts, dense: bool = False):
        """Integrate from the clamp; contacts: [(kind, wall, lam, s)] scaled. Returns the tip state,
        the states at every break {s: y(s-)}, and the dense solutions of the segments."""
        jumps = [(s, F, M) for s, F, M in self.points if s < 1.0]
        n_L = self.F_tip.copy()
        M_L = 0.0
        for s, F, M in self.points:
            if s >= 1.0:
                n_L, M_L = n_L + F, M_L + M
        for kind, w, lam, s in contacts:
            nw = self.walls[w][1]
            if kind == "tip":
                n_L = n_L + lam * nw
            else:
                jumps.append((s, lam * nw, 0.0))
        cuts = {0.0, 1.0} | {s for s, _, _ in jumps}
        cuts |= {c for a, b, _ in self.segments for c in (a, b) if 0.0 < c < 1.0}
        cuts = sorted(c for c in cuts if 0.0 <= c <= 1.0)
        y = np.array([0.0, 0.0, 0.0, m0])
        states, sols = {0.0: y.copy()}, []
        for a, b in zip(cuts[:-1], cuts[1:], strict=True):
            if b - a < 1e-15:
                states[b] = y.copy()
                continue
            n = n_L + sum((F for s, F, _ in jumps if s >= b), np.zeros(2))
            sol = solve_ivp(
                _rhs,
                (a, b),
                y,
                method="DOP853",
                rtol=RTOL,
                atol=ATOL,
                args=(n[0], n[1], self.eb(0.5 * (a + b))),
                dense_output=dense,
            )
            if not sol.success:
                raise RuntimeError(f"contact reference: integration failed on [{a}, {b}]: {sol.message}")
            y = sol.y[:, -1].copy()
            states[b] = y.copy()
            if dense:
                sols.append(sol)
            if b < 1.0:
                y[3] -= sum(M for s, _, M in jumps if s == b)
        return y, states, sols, M_L


def _unpack(x, contacts):
    """Shooting unknowns -> m0 and [(kind, wall, lam, s)]."""
    m0, k, out = x[0], 1, []
    for c in contacts:
        lam = x[k]
        k += 1
        if c[0] == "tip":
            out.append(("tip", c[1], lam, 1.0))
        else:
            out.append(("interior", c[1], lam, min(max(x[k], 1e-9), 1.0 - 1e-9)))
            k += 1
    return m0, out


def _residual(x, rod: PlanarRod, contacts):
    m0, state = _unpack(x, contacts)
    y, states, _, M_L = rod.shoot(m0, state)
    res = [y[3] - rod.tip_couple(y[2]) - M_L]
    for kind, w, _, s in state:
        ys = y if kind == "tip" else states[s]
        res.append(rod.gap(w, ys[:2]))
        if kind == "interior":
            res.append(rod.walls[w][1] @ np.array([math.sin(ys[2]), math.cos(ys[2])]))
    return np.array(res)


def _normalise_contacts(contacts):
    out = []
    for c in contacts:
        if c[0] == "tip":
            out.append(("tip", int(c[1])))
        elif c[0] == "interior":
            out.append(("interior", int(c[1]), float(c[2]) if len(c) > 2 else None))
        else:
            raise ValueError(f"unknown contact kind {c[0]!r}")
    return out


def solve_planar_contact(
    L,
    EI,
    R_o=0.0,
    walls=(),
    tip_force=(0.0, 0.0),
    tip_moment=0.0,
    B=(0.0, 0.0),
    m=0.0,
    point_loads=(),
    contacts=(),
    segments=(),
    guess=None,
    gap_tol=None,
    force_tol=None,
    samples=2000,
    steps=8,
) -> dict:
    """Equilibrium of a clamped planar elastica with the given active contact set.

    Vectors are (x, z) pairs in the plane; walls = [(point, normal)], normal towards the tube's side;
    contacts = [("tip", wall) | ("interior", wall, s_guess)]; point_loads = [(s, F) | (s, F, M)];
    segments = [(s_from, s_to, E_b)] override EI there; B the field (Bx, Bz), m the tip magnet's
    moment along d3. ``guess`` = a previous result's "unknowns" (m0, then per contact lambda [, s]),
    in SI; else a path from the unloaded rod (``_path``, 2 x ``steps`` solves).

    Returns tip (x, z), theta_L, m0 (moment at the clamp), contacts [{kind, wall, s, force (lambda),
    force_vector, position}], converged, residual, admissible, violations (list of strings),
    gap_min per wall [(value, s)], shape (s, x, z, theta, m sampled) and unknowns (for warm starts).
    """
    rod = PlanarRod(L, EI, R_o, walls, tip_force, tip_moment, B, m, point_loads, segments)
    cons = _normalise_contacts(contacts)
    if guess is None:
        x, resid = _path(rod, cons, steps)
    else:
        g = np.asarray(guess, float)
        x0, k = [g[0] / rod.ms], 1
        for c in cons:
            x0.append(g[k] / rod.fs)
            k += 1
            if c[0] == "interior":
                x0.append(g[k] / rod.L)
                k += 1
        x, resid = _newton(rod, cons, np.array(x0, float))
    return _result(rod, cons, x, resid, gap_tol, force_tol, samples)


def _newton(rod: PlanarRod, cons, x0: np.ndarray):
    """Root of the shooting residual from x0 (hybr, then lm if hybr stalls): (x, max |residual|)."""
    best = None
    n = x0.size
    for method in ("hybr", "lm"):
        opts = {"xtol": 1e-13, "maxfev": 40 * (n + 1)}
        if method == "lm":
            opts = {"xtol": 1e-14, "ftol": 1e-14, "maxiter": 40 * (n + 1)}
        try:
            out = root(_residual, x0, args=(rod, cons), method=method, options=opts)
        except RuntimeError:
            continue
        r = float(np.max(np.abs(out.fun)))
        if best is None or r < best[1]:
            best = (out.x, r)
        if r < RESIDUAL_TOL:
            break
    if best is None:
        raise RuntimeError("contact reference: shooting failed")
    return best


def _path(rod: PlanarRod, cons, steps: int):
    """A cold start along a path: the loads raised on the free rod in ``steps``, then each contact's
    wall moved in ``steps`` from where the free rod touches it (a contact with lambda = 0 solves
    that exactly) to where it is. Each contact has its own copy of its wall on the way."""
    x = np.array([0.0])
    for t in np.linspace(0.0, 1.0, steps + 1)[1:]:
        x, r = _newton(rod.scaled(t), [], x)
        if r > RESIDUAL_TOL:
            return x, r
    if not cons:
        return x, r
    _, _, sols, _ = rod.shoot(x[0], [], dense=True)
    ss = np.linspace(0.0, 1.0, 401)
    Y = np.concatenate([sol.sol(ss[(ss >= sol.t[0]) & (ss <= sol.t[-1])]) for sol in sols], axis=1)
    ss = np.concatenate([ss[(ss >= sol.t[0]) & (ss <= sol.t[-1])] for sol in sols])
    offsets, cons_h, x0 = [], [], [x[0]]
    for i, c in enumerate(cons):
        g = rod.gap(c[1], Y[:2])
        if c[0] == "tip":
            offsets.append(g[-1])
            cons_h.append(("tip", i))
            x0.append(0.0)
        else:
            mins = [j for j in range(1, ss.size - 1) if g[j] <= g[j - 1] and g[j] <= g[j + 1]]
            want = c[2] / rod.L if c[2] is not None else ss[int(np.argmin(g[1:-1])) + 1]
            j = min(mins, key=lambda j: abs(ss[j] - want)) if mins else int(np.argmin(np.abs(ss - want)))
            offsets.append(g[j])
            cons_h.append(("interior", i, None))
            x0 += [0.0, ss[j]]
    x = np.array(x0)
    for t in np.linspace(0.0, 1.0, steps + 1):
        walls = [
            (rod.walls[c[1]][0] + (1 - t) * d * rod.walls[c[1]][1], rod.walls[c[1]][1])
            for c, d in zip(cons, offsets, strict=True)
        ]
        x, r = _newton(rod.scaled(1.0, walls), cons_h, x)
        if r > RESIDUAL_TOL:  # lost on the way: give up (the caller sees the residual)
            break
    return x, r


def _result(rod: PlanarRod, cons, x, resid, gap_tol, force_tol, samples) -> dict:
    L = rod.L
    gap_tol = 1e-8 if gap_tol is None else gap_tol / L
    force_tol = 1e-9 if force_tol is None else force_tol / rod.fs
    m0, state = _unpack(x, cons)
    y, states, sols, _ = rod.shoot(m0, state, dense=True)
    # the shape, sampled finely (and every break)
    ss = np.unique(np.concatenate([np.linspace(0.0, 1.0, samples + 1), list(states)]))
    Y = np.empty((4, ss.size))
    for sol in sols:
        a, b = sol.t[0], sol.t[-1]
        sel = (ss >= a) & (ss <= b)
        Y[:, sel] = sol.sol(ss[sel])
    violations = []
    if resid > RESIDUAL_TOL:
        violations.append(f"not converged: residual {resid:.2e}")
    gap_min = []
    for w in range(len(rod.walls)):
        g = rod.gap(w, Y[:2])
        i = int(np.argmin(g))
        gmin, smin = float(g[i]), float(ss[i])
        # refine a sampled minimum on the dense interpolant (the breaks are exact already)
        if 0 < i < ss.size - 1:
            sol = next(so for so in sols if so.t[0] <= ss[i] <= so.t[-1])
            lo, hi = max(ss[i - 1], sol.t[0]), min(ss[i + 1], sol.t[-1])
            r = minimize_scalar(
                lambda s, sol=sol, w=w: float(rod.gap(w, sol.sol(s)[:2])),
                bounds=(lo, hi),
                method="bounded",
                options={"xatol": 1e-12},
            )
            if r.fun < gmin:
                gmin, smin = float(r.fun), float(r.x)
        gap_min.append((gmin * L, smin * L))
        if gmin < -gap_tol:
            violations.append(f"wall {w} penetrated: gap {gmin * L:.3e} at s = {smin * L:.6g}")
    contacts = []
    unknowns = [m0 * rod.ms]
    for (kind, w, lam, s), c in zip(state, cons, strict=True):
        if lam < -force_tol:
            violations.append(f"{kind} contact on wall {w} pulls: force {lam * rod.fs:.3e}")
        ys = y if kind == "tip" else states[s]
        if kind == "interior" and not (1e-6 < s < 1 - 1e-6):
            violations.append(f"interior contact on wall {w} left the rod: s = {s * L:.6g}")
        nw = rod.walls[w][1]
        contacts.append(
            {
                "kind": kind,
                "wall": w,
                "s": s * L,
                "force": lam * rod.fs,
                "force_vector": lam * rod.fs * nw,
                "position": ys[:2] * L,
            }
        )
        unknowns.append(lam * rod.fs)
        if c[0] == "interior":
            unknowns.append(s * L)
    return {
        "tip": y[:2] * L,
        "theta_L": float(y[2]),
        "m0": m0 * rod.ms,
        "contacts": contacts,
        "converged": resid <= RESIDUAL_TOL,
        "residual": float(resid),
        "admissible": not violations,
        "violations": violations,
        "gap_min": gap_min,
        "shape": {"s": ss * L, "x": Y[0] * L, "z": Y[1] * L, "theta": Y[2], "m": Y[3] * rod.ms},
        "unknowns": np.array(unknowns),
        "active_set": [(c[0], c[1]) if c[0] == "tip" else ("interior", c[1]) for c in cons],
    }


# -- active sets -------------------------------------------------------------------


def _set_key(cons) -> tuple:
    return tuple(sorted((c[0], c[1]) for c in cons))


def _warm_guess(prev: dict, cons) -> list | None:
    """The previous result's unknowns re-ordered for ``cons``, when every contact of cons was active."""
    if prev is None:
        return None
    table = {}
    for c in prev["contacts"]:
        table[(c["kind"], c["wall"])] = c
    g = [prev["m0"]]
    for c in cons:
        old = table.get((c[0], c[1]))
        g.append(old["force"] if old else 0.0)
        if c[0] == "interior":
            g.append(old["s"] if old else c[2])
    return g


def candidate_sets(n_walls: int, s_guesses) -> list:
    """Active sets to try: none; the tip on a wall; one interior contact (at each s guess) alone or
    with the tip on any wall; two interior contacts on different walls, with or without the tip."""
    out = [[]]
    out += [[("tip", w)] for w in range(n_walls)]
    for w in range(n_walls):
        for s in s_guesses.get(w, []):
            out.append([("interior", w, s)])
            out += [[("interior", w, s), ("tip", v)] for v in range(n_walls)]
    for w, v in itertools.permutations(range(n_walls), 2):
        for s, t in itertools.product(s_guesses.get(w, []), s_guesses.get(v, [])):
            if w < v:
                out.append([("interior", w, s), ("interior", v, t)])
            out += [[("interior", w, s), ("interior", v, t), ("tip", u)] for u in range(n_walls)]
    return out


def find_active_set(problem: dict, previous: dict | None = None, candidates=None, keep_all=False) -> dict:
    """The admissible equilibrium of ``problem`` (keyword arguments of solve_planar_contact without
    contacts), found by trying active sets.

    First the previous state's set (warm-started from it), then local changes of it (drop a pulling
    contact; add a contact where the rod penetrates, at the deepest point), then every candidate of
    ``candidate_sets`` (interior contacts guessed at the gap minima of the tried states). Among
    several admissible states the one whose tip is closest to the previous tip is kept (the path
    decides; physics.md section 9). Returns that result with "tried": [(set, admissible)] and, with
    keep_all, "admissible_sets": every admissible result."""
    tried, admissible, seen = [], [], set()
    n_walls = len(problem.get("walls", ()))

    def attempt(cons):
        key = _set_key(cons)
        if key in seen:
            return None
        seen.add(key)
        try:
            res = solve_planar_contact(**problem, contacts=cons, guess=_warm_guess(previous, cons))
            if not res["converged"] and previous is not None:
                res2 = solve_planar_contact(**problem, contacts=cons)
                if res2["residual"] < res["residual"]:
                    res = res2
        except RuntimeError:
            tried.append((key, False))
            return None
        tried.append((key, res["admissible"]))
        if res["admissible"]:
            admissible.append(res)
        return res

    def local_changes(res):
        """Sets one move away from res: drop pulling contacts, add the deepest penetration."""
        cons = [
            (c["kind"], c["wall"]) if c["kind"] == "tip" else ("interior", c["wall"], c["s"])
            for c in res["contacts"]
        ]
        pulling = [i for i, c in enumerate(res["contacts"]) if c["force"] < 0]
        moves = []
        if pulling:
            moves.append([c for i, c in enumerate(cons) if i not in pulling])
        near = 0.02 * problem["L"]  # a penetration next to a contact on its wall: a stretch, not a point
        pen = [
            (g, s, w)
            for w, (g, s) in enumerate(res["gap_min"])
            if g < 0 and not any(c["wall"] == w and abs(c["s"] - s) < near for c in res["contacts"])
        ]
        if pen:
            g, s, w = min(pen)
            if abs(s - problem["L"]) < 1e-9 * problem["L"]:
                moves.append(cons + [("tip", w)])
            else:
                moves.append(cons + [("interior", w, s)])
        return moves

    start = []
    if previous is not None:
        start = [
            (c["kind"], c["wall"]) if c["kind"] == "tip" else ("interior", c["wall"], c["s"])
            for c in previous["contacts"]
        ]
    queue = [start]
    results = []
    for _ in range(6):  # a few local moves from the previous set
        if not queue:
            break
        res = attempt(queue.pop(0))
        if res is None:
            continue
        results.append(res)
        if res["admissible"] and not keep_all:
            break
        queue += local_changes(res)
    if not admissible or keep_all:
        guesses = {w: set() for w in range(n_walls)}
        for res in results:
            for w, (_, s) in enumerate(res["gap_min"]):
                if problem["L"] * 1e-3 < s < problem["L"] * (1 - 1e-3):
                    guesses[w].add(round(s, 12))
        for w in range(n_walls):
            guesses[w] |= {0.5 * problem["L"]} if not guesses[w] else set()
        for cons in candidates if candidates is not None else candidate_sets(n_walls, guesses):
            if admissible and not keep_all:
                break
            attempt(cons)
    if not admissible:
        raise RuntimeError(f"contact reference: no admissible active set among {len(tried)} tried: {tried}")
    if previous is not None:
        best = min(admissible, key=lambda r: np.linalg.norm(r["tip"] - previous["tip"]))
    else:
        best = admissible[0]
    best = dict(best, tried=tried)
    if keep_all:
        best["admissible_sets"] = admissible
    return best


def advance(free_lengths, EI, R_o=0.0, walls=(), B=(0.0, 0.0), m=0.0, tube_length=None, segments=(), **loads):
    """Push the tube out of a sheath at the origin: one equilibrium per free length, in the given
    order, each started from the last (contract section 12). The tip magnet stays at the tip;
    ``segments`` [(from, to, E_b)] are measured from the tube's proximal end, of length
    ``tube_length`` (default: the last free length). Returns the list of step results."""
    total = max(free_lengths) if tube_length is None else tube_length
    steps, prev = [], None
    for ell in free_lengths:
        off = total - ell
        segs = [(max(a - off, 0.0), b - off, e) for a, b, e in segments if b - off > 0.0]
        prob = dict(L=ell, EI=EI, R_o=R_o, walls=walls, B=B, m=m, segments=segs, **loads)
        res = find_active_set(prob, prev)
        res["free_length"] = ell
        steps.append(res)
        prev = res
    return steps


# -- a straight lumen --------------------------------------------------------------


def lumen_wall(rho: float) -> tuple:
    """The wall of a straight lumen (axis +z through the clamp, inner radius rho) seen in the plane
    of the rod at x >= 0: the line x = rho with normal -e_x."""
    return ((rho, 0.0), (-1.0, 0.0))


def lumen_gap_min(result: dict, rho: float, R_o: float) -> float:
    """The smallest lumen gap rho - R_o - |x| along a planar result (its plane through the axis)."""
    return float(np.min(rho - R_o - np.abs(result["shape"]["x"])))


def rotate_about_axis(xz, beta: float) -> np.ndarray:
    """The 3D point (x cos beta, x sin beta, z) of a planar point (x, z): the plane x-z rotated by
    beta about the lumen's axis e3."""
    x, z = xz
    return np.array([x * math.cos(beta), x * math.sin(beta), z])


def planar_field(B3, axis=(0.0, 0.0, 1.0)) -> tuple:
    """A 3D field B3 as (beta, (B_perp, B_z)): the azimuth of the plane that contains it and the axis,
    and its components in that plane (B_perp >= 0)."""
    B3 = np.asarray(B3, float)
    bperp = math.hypot(B3[0], B3[1])
    beta = math.atan2(B3[1], B3[0]) if bperp > 0 else 0.0
    return beta, (bperp, float(B3[2]))


def solve_lumen_tip(L, EI, R_o, rho, B3, m, **kw) -> dict:
    """A tube on the axis of a straight lumen (along +z through the clamp) with a tip magnet in a 3D
    field B3, touching the lumen only at its tip: the planar wall solution in the plane of B3 and the
    axis, rotated about the axis. Returns the planar result plus tip3 (3D tip), force3 (the lumen's
    reaction on the tip, 3D), beta and lumen_gap_min (which must be >= 0 for the answer to hold)."""
    beta, Bp = planar_field(B3)
    res = solve_planar_contact(L, EI, R_o, [lumen_wall(rho)], B=Bp, m=m, contacts=[("tip", 0)], **kw)
    f = res["contacts"][0]["force_vector"]
    return dict(
        res,
        beta=beta,
        tip3=rotate_about_axis(res["tip"], beta),
        force3=rotate_about_axis(f, beta),
        lumen_gap_min=lumen_gap_min(res, rho, R_o),
    )


# -- closed forms ------------------------------------------------------------------


def elastica_tip_on_wall(
    E_b: float, P: float, gamma: float, theta_L: float, M_L: float, inflections: int = 0
) -> dict:
    """The clamped elastica (theta(0) = 0) loaded only at its tip by a force -P e (P > 0, e =
    (sin gamma, cos gamma)) and a couple M_L = E_b theta'(L), ending at angle theta_L: the shape of a
    tip on a wall of normal -e, in closed form. Returns L, tip (x, z), m0 = E_b theta'(0), k and the
    number of inflections.

    With phi = theta - gamma, E_b phi'' = -P sin phi, whose first integral is
    E_b phi'^2 / 2 = P cos phi + C (for gamma = pi/2: E_b theta'^2/2 = P sin theta + C). With
    omega^2 = P/E_b and k^2 = (phi'/2 omega)^2 + sin^2(phi/2):
    - k < 1 (phi oscillates; inflections where phi' = 0): sin(phi/2) = k sin xi, xi increasing with
      s, ds = dxi / (omega sqrt(1 - k^2 sin^2 xi)), phi' = 2 omega k cos xi, so
      s = F(xi, k^2)/omega, int cos phi ds = (2 E(xi, k^2) - F(xi, k^2))/omega;
    - k > 1 (phi monotone): a = phi/2, ds = +-da / (omega k sqrt(1 - sin^2 a / k^2)),
      s = +-F(a, 1/k^2)/(omega k), int cos phi ds = (1 - 2k^2) s +- (2k/omega) E(a, 1/k^2);
    and in both, int sin phi ds = -(phi'(L) - phi'(0))/omega^2 (from the first integral). The clamp
    angle phi_0 = -gamma is taken at the last xi before xi_L with ``inflections`` zeros of phi'
    between them (the same tip data end rods of different lengths on one orbit)."""
    if P <= 0:
        raise ValueError("P > 0")
    om = math.sqrt(P / E_b)
    phiL, dphiL = theta_L - gamma, M_L / E_b
    phi0 = -gamma
    if not (-math.pi < phiL < math.pi and -math.pi < phi0 < math.pi):
        raise ValueError("angles from the load line within (-pi, pi)")
    k2 = (dphiL / (2 * om)) ** 2 + math.sin(phiL / 2) ** 2
    k = math.sqrt(k2)
    if k < 1.0:
        xiL = math.atan2(math.sin(phiL / 2) / k, dphiL / (2 * om * k))
        q = math.sin(phi0 / 2) / k
        if abs(q) > 1.0:
            raise ValueError("the clamp angle is not on this orbit (k too small)")
        base = [math.asin(q), math.pi - math.asin(q)]
        cands = [b + 2 * math.pi * j for b in base for j in range(-3, 4)]

        def count(xi0):  # zeros of cos xi in (xi0, xiL)
            return sum(1 for j in range(-8, 9) if xi0 < math.pi / 2 + j * math.pi < xiL)

        ok = [c for c in cands if c < xiL - 1e-14 and count(c) == inflections]
        if not ok:
            raise ValueError(f"no rod with {inflections} inflections ends so on this orbit")
        xi0 = max(ok)
        F = ellipkinc(xiL, k2) - ellipkinc(xi0, k2)
        E = ellipeinc(xiL, k2) - ellipeinc(xi0, k2)
        L = F / om
        Cphi = (2 * E - F) / om
        dphi0 = 2 * om * k * math.cos(xi0)
    else:
        if inflections:
            raise ValueError("phi is monotone for k > 1: no inflection")
        mpar = 1.0 / k2
        sg = 1.0 if dphiL > 0 else -1.0
        if sg * (phiL - phi0) <= 0:
            raise ValueError("a monotone phi cannot reach phi_L from the clamp without a loop")
        F = sg * (ellipkinc(phiL / 2, mpar) - ellipkinc(phi0 / 2, mpar))
        E = sg * (ellipeinc(phiL / 2, mpar) - ellipeinc(phi0 / 2, mpar))
        L = F / (om * k)
        Cphi = (1 - 2 * k2) * L + (2 * k / om) * E
        dphi0 = sg * 2 * om * k * math.sqrt(1 - mpar * math.sin(phi0 / 2) ** 2)
    Sphi = -(dphiL - dphi0) / om**2
    x = math.cos(gamma) * Sphi + math.sin(gamma) * Cphi
    z = math.cos(gamma) * Cphi - math.sin(gamma) * Sphi
    return {"L": L, "tip": np.array([x, z]), "m0": E_b * dphi0, "k": k, "inflections": inflections}


def lying_on_a_wall(L, EI, q, P) -> dict:
    """A cantilever lying along a wall through its clamp (the wall x = 0, the tube on x <= 0, the
    rod along +z), pressed onto it by a uniform dead load q per length (+x) and pulled off near the
    tip by a dead tip force P (-x), q L > P > 0: the rod lies straight on the wall over [0, a] and
    leaves it at a, where its moment vanishes (the curvature is continuous and zero on the wall);
    over [a, L] it is a cantilever clamped along the wall with n(s) = (q (L - s) - P, 0). The one
    unknown ell = L - a solves m(L) = 0 (brentq on the shooting of that free piece; small
    deflection: ell = 2 P / q). The wall carries q a spread over [0, a] and a point reaction
    q ell - P at a, q L - P in all (the clamp nothing). Returns a, tip (x, z), reaction."""
    from scipy.optimize import brentq

    def shoot(ell, dense=False):
        a = L - ell

        def rhs(s, y):
            nx = q * (L - s) - P
            return [math.sin(y[2]), math.cos(y[2]), y[3] / EI, -nx * math.cos(y[2])]

        y0 = [0.0, a, 0.0, 0.0]
        return solve_ivp(rhs, (a, L), y0, method="DOP853", rtol=RTOL, atol=ATOL * EI / L, dense_output=dense)

    guess = 2 * P / q
    lo, hi = 0.5 * guess, min(1.5 * guess, L)
    ell = brentq(lambda e: shoot(e).y[3, -1], lo, hi, xtol=1e-15 * L, rtol=1e-14)
    end = shoot(ell).y[:, -1]
    return {"a": L - ell, "tip": np.array([end[0], end[1]]), "reaction": q * L - P, "point_reaction": q * ell - P}


def propped_cantilever_reaction(P: float, a: float, L: float) -> float:
    """Small-deflection reaction of a frictionless tip support under a point load P at a from the
    clamp (Euler-Bernoulli): R = P a^2 (3L - a) / (2 L^3)."""
    return P * a**2 * (3 * L - a) / (2 * L**3)


# -- a vessel bend: a lumen whose centreline turns on a circular arc ---------------------------------


class BendLumen:
    """A lumen of radius ``rho`` in the x-z plane whose centreline runs along +z up to the origin (the
    clamp), turns towards +x on an arc of radius ``Rc`` (centre (Rc, 0)) by ``turn`` rad, then runs
    straight on: the gap of a centreline point at outer radius R_o is rho - R_o - d, d its distance
    to the centreline (the nearest of the three pieces), and the lumen's reaction on it points along
    the unit vector from it to its nearest centreline point."""

    def __init__(self, rho: float, Rc: float, turn: float):
        self.rho, self.Rc, self.turn = float(rho), float(Rc), float(turn)
        self.centre = np.array([self.Rc, 0.0])
        self.end = self.centre + self.Rc * np.array([-math.cos(turn), math.sin(turn)])
        self.t_end = np.array([math.sin(turn), math.cos(turn)])

    def nearest(self, xz) -> np.ndarray:
        """Nearest centreline points (n, 2) of points xz (n, 2)."""
        P = np.atleast_2d(np.asarray(xz, float))
        before = np.column_stack([0.0 * P[:, 0], np.minimum(P[:, 1], 0.0)])
        w = P - self.centre
        phi = np.arctan2(w[:, 1], -w[:, 0])  # 0 at the clamp, growing along the arc
        phi = np.clip(phi, 0.0, self.turn)
        arc = self.centre + self.Rc * np.column_stack([-np.cos(phi), np.sin(phi)])
        u = np.maximum((P - self.end) @ self.t_end, 0.0)
        after = self.end + u[:, None] * self.t_end
        pieces = np.stack([before, arc, after])
        d = np.linalg.norm(pieces - P[None], axis=2)
        return pieces[np.argmin(d, axis=0), np.arange(P.shape[0])]

    def gap(self, xz, R_o: float) -> np.ndarray:
        P = np.atleast_2d(np.asarray(xz, float))
        return self.rho - R_o - np.linalg.norm(P - self.nearest(P), axis=1)

    def inward(self, xz) -> np.ndarray:
        """Unit vector from a point (2,) to its nearest centreline point: the lumen's push on it."""
        P = np.asarray(xz, float)
        v = self.nearest(P[None])[0] - P
        return v / np.linalg.norm(v)


def _bend_residual(x, rod: PlanarRod, lumen: BendLumen):
    """Unknowns m0 and the tip reaction (fx, fz), scaled: the tip couple, the tip on the lumen's wall,
    the reaction along the lumen's normal there."""
    tip = copy.copy(rod)
    tip.F_tip = rod.F_tip + x[1:3]
    y, _, _, M_L = tip.shoot(x[0], [])
    inward = lumen.inward(y[:2] * rod.L)
    return np.array([
        y[3] - tip.tip_couple(y[2]) - M_L,
        lumen.gap(y[:2] * rod.L, rod.R_o * rod.L)[0] / rod.L,
        x[1] * inward[1] - x[2] * inward[0],
    ])  # fmt: skip


def solve_tip_in_bend(L, EI, R_o, lumen: BendLumen, B=(0.0, 0.0), m=0.0, guess=None, samples=2000) -> dict:
    """A clamped planar elastica with a tip magnet in a bent lumen: free, or touching the lumen's wall
    at its tip only (the reaction along the wall's normal there, unknown in size and direction). The
    free rod is tried first; when it crosses the wall the tip contact is solved from ``guess``
    (a previous result's "unknowns": m0, fx, fz in SI) or from the free state. Returns tip (x, z),
    theta_L, m0, contacts [{kind "tip", s, force (lambda), force_vector, position}], admissible,
    violations, gap_min (value, s) along the rod, shape and unknowns. Interior contacts on the curved
    wall are not modelled: such a state is returned not admissible (the rod crosses the wall)."""
    free = solve_planar_contact(L, EI, R_o, (), B=B, m=m, samples=samples)
    tol = 1e-8 * L
    g = lumen.gap(np.column_stack([free["shape"]["x"], free["shape"]["z"]]), R_o)
    if free["converged"] and g.min() >= -tol:
        return dict(free, gap_min=(float(g.min()), float(free["shape"]["s"][np.argmin(g)])))
    rod = PlanarRod(L, EI, R_o, (), (0.0, 0.0), 0.0, B, m)
    x0 = (np.array([free["m0"] / rod.ms, 0.0, 0.0]) if guess is None
          else np.asarray(guess, float) / [rod.ms, rod.fs, rod.fs])  # fmt: skip
    out = root(_bend_residual, x0, args=(rod, lumen), method="hybr", options={"xtol": 1e-13})
    resid = float(np.max(np.abs(out.fun)))
    f = out.x[1:3] * rod.fs
    res = solve_planar_contact(
        L, EI, R_o, (), tip_force=f, B=B, m=m, samples=samples, guess=[out.x[0] * rod.ms]
    )
    shape = np.column_stack([res["shape"]["x"], res["shape"]["z"]])
    g = lumen.gap(shape, R_o)
    inward = lumen.inward(res["tip"])
    lam = float(f @ inward)
    violations = [] if resid < RESIDUAL_TOL and res["converged"] else [f"not converged: residual {resid:.2e}"]
    if lam < 0:
        violations.append(f"the tip contact pulls: {lam:.3e}")
    if g.min() < -tol:
        violations.append(
            f"the rod crosses the lumen: gap {g.min():.3e} at s = {res['shape']['s'][np.argmin(g)]:.6g}"
        )
    contact = {
        "kind": "tip",
        "wall": "lumen",
        "s": L,
        "force": lam,
        "force_vector": f,
        "position": res["tip"],
    }
    return dict(res, contacts=[contact], admissible=not violations, violations=violations,
                gap_min=(float(g.min()), float(res["shape"]["s"][np.argmin(g)])),
                unknowns=np.array([res["m0"], *f]))  # fmt: skip


def advance_in_bend(free_lengths, EI, R_o, lumen: BendLumen, B=(0.0, 0.0), m=0.0) -> list[dict]:
    """:func:`solve_tip_in_bend` for each free length in order (a tip magnet at the tip), each tip
    contact started from the last step's."""
    steps, prev = [], None
    for ell in free_lengths:
        guess = prev["unknowns"] if prev is not None and prev["contacts"] else None
        res = solve_tip_in_bend(ell, EI, R_o, lumen, B=B, m=m, guess=guess)
        res["free_length"] = ell
        steps.append(res)
        prev = res
    return steps


# -- a shearable tube lying flat on a lumen's wall over a short stretch ---------------------------


def _nx_on_wall(th: float, nz: float, es: float, ee: float) -> float:
    """The force n_x that keeps a shearable, extensible centreline along a wall x = const at director
    angle th: x' = (1 + n3/E_e) sin th + (n1/E_s) cos th = 0 is linear in n_x."""
    sn, c = math.sin(th), math.cos(th)
    return -(sn + nz * c * sn * (1.0 / ee - 1.0 / es)) / (sn * sn / ee + c * c / es)


def _rhs_shear(s, y, nx, nz, es, ee, k0, on_wall, ml=(0.0, 0.0)):
    """``ml``: a magnetisation per length along d3 times the in-plane field (scaled): the couple per
    length (d3 x B).e2 = ml_x cos theta - ml_z sin theta, which m' = -c adds to (m(L) = the tip's)."""
    th, m = y[2], y[3]
    sn, c = math.sin(th), math.cos(th)
    if on_wall:
        nx = _nx_on_wall(th, nz, es, ee)
    n3, n1 = nx * sn + nz * c, nx * c - nz * sn
    xp = (1.0 + n3 / ee) * sn + (n1 / es) * c
    zp = (1.0 + n3 / ee) * c - (n1 / es) * sn
    return [xp, zp, m + k0, -(zp * nx - xp * nz) - (ml[0] * c - ml[1] * sn)]


def shear_stretch_in_lumen(L, EI, E_s, E_e, w, B, m, guess, kappa0=0.0, samples=400, per_length=0.0) -> dict:
    """A planar Reissner rod (extensible E_e, shearable E_s; nu1 = n1/E_s, nu3 = 1 + n3/E_e) clamped
    at the origin along +z between the walls x = -w and x = +w (a straight lumen's section through
    its axis, w = lumen radius - outer radius), with a tip magnet m along d3 in the in-plane field
    B = (B_x, B_z) and a precurvature kappa0: its tip on x = +w and its side flat on x = -w over a
    stretch [a, b]. On the stretch the centreline stays on the wall while the director turns (the
    shear strain takes it up): n_x(theta) keeps x' = 0 and the wall's reaction, spread over the
    stretch, is -n_x'. The rod leaves the wall smoothly at both ends (no point force: n_x
    continuous, so x' = 0 there too). Unknowns m(0), n_x before the stretch, a, b; equations
    x(a) = -w, n_x(a) = n_x(theta(a)), the tip couple m(L) = m (d3 x B).e2 and x(L) = w; n_z = 0
    (no axial load). ``per_length``: a magnetisation per length (A) along d3 over the whole rod
    in the same field. ``guess``: (m0 [N m], n_x [N], a [m], b [m]). Returns tip (x, z), a, b, the
    stretch's resultant (N, along +x), the tip's reaction (N, along -x), residual and admissible
    (reactions >= 0 along the stretch and at the tip, gaps >= 0 sampled)."""
    fs, ms = EI / L**2, EI / L
    es, ee = E_s / fs, E_e / fs
    wl, k0 = w / L, kappa0 * L
    mB = m * np.asarray(B, float) / ms
    ml = tuple(per_length * np.asarray(B, float) / fs)  # couple per scaled length, in E_b / L^2

    def shoot(u, dense=False):
        m0, nx0, a, b = u
        opts = dict(method="DOP853", rtol=RTOL, atol=ATOL, dense_output=dense)
        p1 = solve_ivp(_rhs_shear, (0.0, a), [0.0, 0.0, 0.0, m0], args=(nx0, 0.0, es, ee, k0, False, ml), **opts)
        p2 = solve_ivp(_rhs_shear, (a, b), p1.y[:, -1], args=(0.0, 0.0, es, ee, k0, True, ml), **opts)
        nxb = _nx_on_wall(p2.y[2, -1], 0.0, es, ee)
        p3 = solve_ivp(_rhs_shear, (b, 1.0), p2.y[:, -1], args=(nxb, 0.0, es, ee, k0, False, ml), **opts)
        return p1, p2, p3, nxb

    def residual(u):
        p1, _, p3, _ = shoot(u)
        ya, yL = p1.y[:, -1], p3.y[:, -1]
        couple = mB[0] * math.cos(yL[2]) - mB[1] * math.sin(yL[2])
        return [ya[0] + wl, u[1] - _nx_on_wall(ya[2], 0.0, es, ee), yL[3] - couple, yL[0] - wl]

    u0 = [guess[0] / ms, guess[1] / fs, guess[2] / L, guess[3] / L]
    out = root(residual, u0, method="hybr", options={"xtol": 1e-14})
    resid = float(np.max(np.abs(residual(out.x))))
    p1, p2, p3, nxb = shoot(out.x, dense=True)
    m0, nx0, a, b = out.x
    ss = np.linspace(a, b, samples)
    nx_on = np.array([_nx_on_wall(th, 0.0, es, ee) for th in p2.sol(ss)[2]])
    gaps = []
    for sol, lo, hi in ((p1, 0.0, a), (p3, b, 1.0)):
        x = sol.sol(np.linspace(lo, hi, samples))[0]
        gaps += [float(np.min(x + wl)), float(np.min(wl - x))]
    admissible = bool(resid < RESIDUAL_TOL and np.all(np.diff(nx_on) <= 1e-12) and -nxb >= 0 and 0 < a < b < 1
                      and min(gaps) >= -1e-10)  # fmt: skip
    yL = p3.y[:, -1]
    return {
        "tip": np.array([yL[0], yL[1]]) * L, "a": a * L, "b": b * L, "theta_L": yL[2],
        "stretch_force": (nx0 - nxb) * fs, "tip_force": -nxb * fs,
        "residual": resid, "admissible": admissible, "m0": m0 * ms,
    }  # fmt: skip
