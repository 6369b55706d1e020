"""Where a short stretch leaves its wall (issue 31), read between the rounds of
:func:`matid.rod.contact_mesh.contact_rounds`: each end's next estimate from the gaps beside it
(:func:`stretch_ends`, read by :func:`_lowest`), its secant across rounds (:func:`end_secant`),
when a round may stop doubling its meshes (:func:`known_off`) and when it must go on
(:func:`unsettled`), and the order the error estimate may assume where a
stretch leaves its wall inside an element (:func:`stretch_order`).
"""

from __future__ import annotations

import numpy as np

from matid.rod.accuracy import P2_ORDER

#: The order the error estimate may assume at most when a stretch leaves its wall inside the rod.
STRETCH_ORDER = 1.0
#: An end of a short stretch is off its vertex when its next estimate is farther from it than this
#: fraction of the element outside it (as a point contact is off its vertex when another node
#: carries more).
OFF_END = 0.25
#: A stretch end's secant step is taken up to AHEAD times its plain move (a fixed point that the
#: plain moves approach at rate rho lies 1 / (1 - rho) moves ahead: rho up to 0.9). At 2 (rho up
#: to 0.5) the ends of the stretches along a bent 0.6 mm lumen crawled 1e-4 L a round at rate ~0.7
#: and were still moving after 10 rounds (the magnetic workspace, E_b = 6e-5 N m^2, B along
#: (10, 0, -17.3) mT).
AHEAD = 10.0
#: A node beyond a stretch's vertex carries it on (its end moves out to the last such node) when its
#: reaction is above LOADED times the wall's largest: below, the multipliers' round-off (a rod
#: lying straight on a wall, pressed at its tip by 2 E_b/L^2: nodes at 1.7e-14 and 4e-14 walked its
#: end from 0.95 to 0.62 L in 16 rounds).
LOADED = 1e-9
#: Gaps beside a stretch end all below FLAT (x L, ~50 ulps of O(1) scaled positions) say nothing
#: of where it leaves its wall: the end stays (that rod's gaps were 6.9e-18; the cubic through them
#: walked its end as LOADED's round-off reactions did).
FLAT = 1e-14
#: A stretch end is known to be off its vertex when its estimate is farther from it than KNOWN
#: times the estimate's change between the round's last two meshes (:func:`known_off`).
KNOWN = 2.0


def known_off(contacts, seen, before, step: float) -> bool:
    """Whether a stretch end is known to be off its vertex on this mesh (``seen``, ``before``: what
    contact_mesh observed of each contact on this mesh and the last one of the round): its next
    estimate is farther from it than the settling ``step`` and than KNOWN times the estimate's
    change since the last mesh (converging at order 1 or more, what is left of that change is at
    most the change itself). The round then stops doubling: its finer meshes cannot settle a
    vertex that is off. Measured on examples/scenes/magnet_direction.toml at tolerance 1e-8 with
    B = (0, 400, 200) mT between two walls (a stretch on each; one thread, process CPU): a vertex
    1.3e-4 L from the end stayed within OFF_END of its element up to 1280 elements and rounds went
    to 4096 elements (11 rounds, 25 s); the end's estimates on 160, 320, 640, 1280 elements were
    0.2435212, 0.2435270, 0.2435288, 0.2435292 L. With this rule: 9 rounds, none past the 1024
    elements of the answer, 3.9 s, the same tip within 2e-12 L."""
    if seen is None or before is None:
        return False
    for c, (now, _), (then, _) in zip(contacts, seen, before, strict=True):
        if c[0] == "stretch":
            for x, q, p in ((c[1], now[0], then[0]), (c[2], now[1], then[1])):
                if abs(q - x) > max(step, KNOWN * abs(q - p)):
                    return True
    return False


def unsettled(result, contacts, seen, before, move: float, short: bool = False) -> bool:
    """Whether a round must go on doubling: a stretch among ``contacts`` is on its vertices and its
    ends read on this mesh and the last one (``seen``, ``before``: as in :func:`known_off`) differ
    by more than ``move`` (or the last is missing); with ``short``, only a stretch shorter than an
    element beside it on ``result``'s mesh. An end's read depends on the mesh (the cubic of
    :func:`_lowest` is O(h^2) off), and a vertex put at a read that has not settled is that far off
    while the estimate, on meshes nested at it, cannot see it: in a lumen 1 % wider than the tube
    (E_b = 6e-5 N m^2, B = 20 mT along x) rounds settled on 12 elements with an end 2.6e-4 L from
    the shooting reference's 0.181835 L and an estimate of 2.7e-7; reads agreeing to 1e-4 L took
    48 elements, 9e-7 L off. Beside a stretch shorter than an element the read is not yet the
    stretch's own: the bent lumen's 0.005 L corner stretch read 0.4946, 0.4974, 0.49752, 0.49753 L
    on 32, 64, 128, 256 elements, and rounds ending on 64 or 256 cycled (round 16). One off its
    vertices moves anyway: a point opened into a stretch of 2e-6 L read ends 5e-3 L away, apart by
    1e-4 to 4e-4 L up to 1024 elements."""
    if seen is None:
        return False
    v = result.disc.vertices
    for k, c in enumerate(contacts):
        if c[0] != "stretch" or not seen[k][1]:
            continue
        i, j = np.searchsorted(v, c[1] - 1e-12), np.searchsorted(v, c[2] + 1e-12) - 1
        if short and c[2] - c[1] >= max(v[i] - v[max(i - 1, 0)], v[min(j + 1, v.size - 1)] - v[j]):
            continue
        if before is None:
            return True
        now, then = seen[k][0], before[k][0]
        if max(abs(now[0] - then[0]), abs(now[1] - then[1])) > move:
            return True
    return False


def mesh_of(result) -> int | None:
    """The contact nodes of the mesh a result was solved on: a stretch end's secant takes two
    rounds read on the same mesh (its estimate depends on the mesh: on the two-wall scene of
    :func:`known_off`, rounds read on 5120 and 1280 elements put a secant step 1e-4 L ahead)."""
    contact = getattr(result, "contact", None)
    return None if contact is None else int(contact[3][0].size)


def end_secant(x: float, q: float, x0: float, q0: float, same: bool) -> float:
    """The zero of the move q - x of a stretch end through its last two rounds (x0 -> q0, x -> q),
    taken when it lies between 0.5 and AHEAD moves ahead and both rounds read their ends on the
    same mesh (``same``: the fixed point's rate is steady; an end's estimate depends on the mesh,
    :func:`mesh_of`) or when the two moves point at each other (the end lies between x0 and x, and
    the secant too: an end that alternated 0.687436 <-> 0.688118 L for 12 rounds, the magnetic
    workspace in a bent lumen at E_b = 1.2e-4 N m^2, B = 20 mT along x); else the move itself."""
    r, r0 = q - x, q0 - x0
    if r == 0.0 or r == r0 or x == x0:
        return q
    step = -r * (x - x0) / (r - r0)
    return x + step if (same and 0.5 <= step / r <= AHEAD) or r * r0 < 0.0 else q


def stretch_ends(result, a: float, b: float) -> tuple[float, float, bool] | None:
    """(next from, next to, both on their vertices) of a short stretch with mesh vertices at a < b,
    or None when nothing between them is loaded. Each end moves to where the gap beside its
    outermost loaded node is smallest (:func:`_lowest`; an end inside the loaded nodes first moves
    out to the last of them); on its vertex within OFF_END of the element outside it. (A quadratic
    through one element is c3 h^2 / (4 (c2 + 1.5 c3 h)) off where the gap is c2 d^2 + c3 d^3: in a
    lumen 1 % wider than the tube, E_b = 6e-5 N m^2, B = 20 mT along x, the end at 0.1156 L read
    0.1075 L on 12 elements and 0.1131 on 48, and rounds ending on either cycled; the cubic
    through four nodes reads 0.115606 and 0.115605 on 1024.)"""
    s, f, _, g = result.contact[3][:4]
    order = np.argsort(s)
    ss = s[order]
    ia, ib = int(np.argmin(np.abs(ss - a))), int(np.argmin(np.abs(ss - b)))
    F = f[:, order][:, ia : ib + 1].sum(axis=1)
    if F.max() <= 0.0:
        return None
    wall = int(np.argmax(F))
    gb, loaded = g[wall][order], f[wall][order] > LOADED * f[wall].max()
    ja, jb = ia, ib  # its outermost loaded nodes: beyond a vertex that lies inside the stretch
    while ja > 0 and loaded[ja - 1]:
        ja -= 1
    while jb + 1 < ss.size and loaded[jb + 1]:
        jb += 1
    qa, qb, on = float(ss[ja]) if ja < ia else a, float(ss[jb]) if jb > ib else b, ja == ia and jb == ib
    if ja >= 2:
        qa = _lowest(ss[max(ja - 3, 0) : ja + 1][::-1], gb[max(ja - 3, 0) : ja + 1][::-1])
        on = on and abs(qa - a) <= OFF_END * (ss[ia] - ss[ia - 2])
    if jb + 2 < ss.size and b < 1.0:
        qb = _lowest(ss[jb : jb + 4], gb[jb : jb + 4])
        on = on and abs(qb - b) <= OFF_END * (ss[ib + 2] - ss[ib])
    if qb <= qa:  # the ends crossed: the stretch is a point
        qa = qb = 0.5 * (qa + qb)
    return float(qa), float(qb), bool(on)


def _lowest(s: np.ndarray, g: np.ndarray) -> float:
    """Where the gap is smallest beside a stretch end, from nodes s (3 or 4: the end's, then
    outwards) and their gaps g: the local minimum nearest the end of the cubic through four (within
    an element beyond the first three), else :func:`_smallest_point` of the first three; the end's
    node where the gaps are all below FLAT."""
    if float(np.abs(g).max()) <= FLAT:  # it lies on along its wall, unloaded: nothing to read
        return float(s[0])
    near = _smallest_point(np.sort(s[:3]), g[:3][np.argsort(s[:3])])
    if s.size < 4:
        return near
    h = s[2] - s[0]  # the element outside the end (signed: towards the stretch's outside)
    t = (s - s[0]) / h  # 0, 0.5, 1, 1.5 on a uniform mesh: a well-conditioned Vandermonde
    c = np.linalg.solve(np.vander(t, 4, increasing=True), g)  # g = c0 + c1 t + c2 t^2 + c3 t^3
    roots = np.roots([3.0 * c[3], 2.0 * c[2], c[1]]) if c[3] != 0.0 else np.roots([2.0 * c[2], c[1]])
    minima = [float(r.real) for r in roots if r.imag == 0.0 and 2.0 * c[2] + 6.0 * c[3] * r.real > 0.0]
    if not minima:
        return near
    return float(s[0] + np.clip(min(minima, key=abs), -1.0, 2.0) * h)


def _smallest_point(s: np.ndarray, g: np.ndarray) -> float:
    """Where the quadratic through three (s, g) is smallest, within an element beyond them; the
    node of the smallest g when it is not convex."""
    A, B, _ = np.polyfit(s - s[0], g, 2)
    if A <= 0.0:
        return float(s[int(np.argmin(g))])
    h = s[2] - s[0]
    return float(np.clip(s[0] - B / (2.0 * A), s[0] - h, s[2] + h))


def stretch_order(result, stretches: tuple = ()) -> float:
    """The highest order the error estimate may assume for a converged cantilever: STRETCH_ORDER
    when a stretch (a contact over more than three nodes) leaves its wall inside the rod, else
    P2's. That end lies inside an element and the discrete lift-off hops between nodes as the
    mesh doubles: the differences of successive meshes then follow no C h^p, and with the observed
    order (2.3-4) the estimate was 6x below the true tip error (a cantilever pressed on a wall by
    q L^3/E_b = 100 and pulled off by a tip force P L^2/E_b = 10: 3.9e-7 for 2.4e-6 at 128
    elements, against tests/rod/contact_reference.lying_on_a_wall). A short stretch with a vertex
    at each end (``stretches``, its (from, to)) leaves its wall on a vertex: P2's order."""
    contact = getattr(result, "contact", None)
    if contact is None or not hasattr(result, "disc"):
        return P2_ORDER
    v = result.disc.vertices
    for c in contact[0]:
        a, b = c["s"]
        ours = any(max(a, lo) <= min(b, hi) for lo, hi in stretches)
        if a != b and (a > v[1] or b < v[-2]) and not ours:
            return STRETCH_ORDER
    return P2_ORDER
