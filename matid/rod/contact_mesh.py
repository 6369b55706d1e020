"""Mesh vertices at interior contacts (issue 31): the rounds of :func:`contact_rounds` put a vertex
at every interior point contact and one at each end of a short stretch (where each end goes:
:mod:`matid.rod.contact_ends`, which also caps the error estimate's order where a stretch leaves
its wall inside an element).

A short stretch: a shearable tube (E_s L^2/E_b ~ 300, the precurved and the tip-twist examples in a
lumen) lies flat on its wall over a length shorter than the node spacing. There the shear strain
turns the director while the centreline stays on the wall, so the reaction is spread over the
stretch (Timoshenko: phi'' = (GA/EI) phi on it) and the rod leaves it smoothly at each end (gap
~ c (s - end)^2). A point contact on one vertex cannot hold it: its nodes beside the vertex stay
loaded, the P2 gap's smallest point hops between the two ends from round to round (0.618 <-> 0.628 L
on the tip-twist scene in a 3 mm lumen, 6 rounds, exit 1). Measured on that scene with a vertex at
each end, each end moved to the smallest point of the quadratic through the gaps of the element
outside it: the ends settle to 1e-7 L in 4 solves on 16 elements, and the tip and the contact force
then converge at P2's order (differences 4.7e-6, 3.0e-7, 1.9e-8 L at 16, 32, 64, 128 elements),
where the uniform meshes hopped (differences 1e-2 ... 1e-6, no order) up to 2048 elements.
"""

from __future__ import annotations

import numpy as np

from matid.errors import ConvergenceError
from matid.rod.contact_ends import AHEAD, end_secant, known_off, mesh_of, stretch_ends, unsettled

#: Interior contact points are mesh vertices once the next step would move them less than this
#: (x L) and less than the scene's tolerance, within at most CONTACT_ROUNDS rounds.
CONTACT_MOVE = 1e-4
#: (16: on the magnetic workspace in a bent 0.6 mm lumen, 36 states, the contact set settles in up
#: to 5 rounds, three stretches and a corner contact, and their ends in up to 8 more.)
CONTACT_ROUNDS = 16
#: A point contact is a short stretch between its last two vertices when its next step goes back
#: to within HOP of the last step of the vertex before, or when it is on its vertex in both rounds
#: and its secant step is more than HOP times the last (a true touching point: superlinear steps;
#: a short stretch: the slope there keeps one sign, 4e-4 to 5e-3 on the precurved example in a
#: 1.5 mm lumen at 12 elements, and the steps crawl, 0.0023 then 0.0020 L; on the tip-twist
#: example in a 3 mm lumen at 12 elements the vertex cycled 0.6266 <-> 0.6026 L).
HOP = 0.5
#: A point contact whose last step was below this (x L) has settled: its next step is not read as
#: crawling (the corner contact of the workspace in a bent lumen, settled at 0.4992391 L, stepped
#: 5e-10 then 5e-10 again and became a stretch of no length, whose ends then moved by 1e-3 L).
SETTLED = 1e-8
#: A short stretch whose ends come closer than this (x L) is a point contact again.
SHORTEST = 1e-6


def contact_rounds(meshes_at, tolerance: float):
    """(answer, its Estimate, the Estimates of every round, the last step) of ``meshes_at(points,
    enough[, stretches])`` (refine on meshes with a vertex at each scaled s in points, stopping the
    doubling early once ``enough(answer)``; ``stretches``: the (from, to) of short stretches among
    the points, for :func:`matid.rod.contact_ends.stretch_order`).

    First without points, then with a vertex at each interior contact point, all of them together,
    until the points move less than CONTACT_MOVE (a contact on a vertex of every nested mesh left
    the estimate blind to its O(h) position error). A point starts where the P2 gap is smallest;
    once the contact sits on its vertex, secant steps on the gap's slope there (zero where the rod
    touches the wall tangentially). A point on its vertex whose nodes on both sides stay loaded is a
    short stretch: a vertex at each end, moved by :func:`stretch_ends`. A round stops doubling its
    meshes as soon as a contact is off its vertex (or none is given) and its last two meshes found
    the same kinds of contact: its nodal contact then hops between nodes as the mesh doubles, so
    its Richardson estimate need not converge, and only the touching point is wanted from it
    (measured, a channel with the tip on one wall and the rod on the other: a round with its
    vertex 1e-2 L off went to 1024 elements, then failed to settle). A mesh that has not found the
    contacts yet tells nothing of where they go: the magnetic workspace in a bent 0.6 mm lumen
    (three stretches, a corner contact and the tip) stopped every round at 8 elements, where the
    contacts came and went from round to round, and 29 of its 36 states raised after 10 rounds.
    Stretches that reach each other are merged (:func:`_merged`). A settled point contact whose
    shear kink would cross the wall between nodes becomes the stretch it needs (:func:`_kink`).
    A round goes on doubling while its stretches' ends, read on its last two meshes, still differ
    by CONTACT_MOVE (:func:`_stops`).
    Raises ConvergenceError naming the round when the points still move after CONTACT_ROUNDS (not
    refined without points instead: on that sweep, that took 146 and 215 s per state at 4096
    elements, order 1, and still reported 7e-5 and 1.2e-4 for a tolerance of 1e-6)."""

    cut = []  # whether the last round stopped its doubling early

    def solve(contacts):
        points = tuple(sorted(x for c in contacts for x in c[1:] if 0.0 < x < 1.0))
        stretches = tuple(c[1:] for c in contacts if c[0] == "stretch")
        enough, more = _stops(contacts, tolerance, cut)
        extra = {"stretches": stretches, "more": more} if stretches else {}
        return meshes_at(points, enough=enough, **extra)

    result, est = solve(())
    rounds, (contacts, last) = [est], _fresh(result)
    for _ in range(1, CONTACT_ROUNDS + 1):
        if not contacts:  # no interior contact (left): refined to the tolerance without a point
            if any(cut):
                result, est = meshes_at(())
                rounds.append(est)
            return result, est, rounds, 0.0
        result, est = solve(contacts)
        rounds.append(est)
        seen = _observe(result, contacts)
        if seen is None:  # the contact set changed: start again where they touch
            contacts, last = _fresh(result)
            continue
        moved = [_next(c, obs, old) for c, (obs, _), old in zip(contacts, seen, last, strict=True)]
        step = max(_distance(a, b) for a, b in zip(moved, contacts, strict=True))
        kinks = [_kink(c, m, obs) for c, m, (obs, _) in zip(contacts, moved, seen, strict=True)]
        settled = all(on for _, on in seen) and step < min(CONTACT_MOVE, tolerance)
        if settled and not any(kinks):
            _report_ends(result, moved)
            return result, est, rounds, step
        moved = [("stretch", *k) if k and settled else m for m, k in zip(moved, kinks, strict=True)]
        contacts, last = _merged(moved, [_last(c, obs) for c, (obs, _) in zip(contacts, seen, strict=True)])
    points = [x for c in contacts for x in c[1:] if 0.0 < x < 1.0]
    raise ConvergenceError(
        f"interior contact points still moved after round {CONTACT_ROUNDS} of meshing at them: "
        f"{', '.join(f'{s:.6g} L' for s in points)}",
        round=CONTACT_ROUNDS,
    )


def _stops(contacts: list, tolerance: float, cut: list):
    """(enough, more) of a round meshed at ``contacts`` for :func:`matid.rod.accuracy.refine`:
    stop its doubling early once a contact is off its vertex (recorded in ``cut``); go on doubling
    past the tolerance while a stretch's ends read on its last two meshes differ by more than
    CONTACT_MOVE, and past a contact off its vertex while a stretch shorter than an element beside
    it does (:func:`matid.rod.contact_ends.unsettled`: a 0.004 L corner stretch of a bent lumen
    read 0.49807, 0.498134 L on 64, 128 elements, and rounds cut at 64 by another stretch's end
    took it back and forth: 6.8 s where 1 s did before)."""
    cut.clear()
    kinds, looks = [], [None]  # the kinds of contact each mesh of the round found; its looks

    def enough(result) -> bool:
        seen = _observe(result, contacts)
        off = seen is None or not all(on for _, on in seen)
        off = off or known_off(contacts, seen, looks[-1], min(CONTACT_MOVE, tolerance))
        looks.append(seen)
        kinds.append([c[0] for c in _fresh(result)[0]])
        cut[:] = [off]
        return off and len(kinds) > 1 and kinds[-1] == kinds[-2] and not more(result, True)

    def more(result, short: bool = False) -> bool:
        return unsettled(result, contacts, looks[-1], looks[-2], CONTACT_MOVE, short)

    return enough, more


def _merged(contacts: list, last: list) -> tuple[list, list]:
    """The next round's contacts in order of s, a stretch and the contacts its range reaches (their
    vertices met or crossed) one stretch over all of them, its ends' steps started afresh: two
    stretches that touch are one contact, whichever round finds them touching."""
    out, steps = [], []
    for c, old in sorted(zip(contacts, last, strict=True), key=lambda x: (x[0][1], x[0][-1])):
        if out and c[1] <= out[-1][-1] and "stretch" in (c[0], out[-1][0]):
            a, b = out[-1][1], max(out[-1][-1], c[-1])
            out[-1], steps[-1] = ("stretch", a, b), ("stretch", a, b, a, b)
        else:
            out.append(c)
            steps.append(old)
    return out, steps


def _fresh(result) -> tuple[list, list]:
    """The contacts of a result, each with what the next round's step needs of it: a point contact
    where each touch is (:func:`interior_contacts`), a short stretch with a vertex at each end of
    every stretch whose ends are both inside the rod (:func:`interior_runs`)."""
    touches = [(t[0], ("point", t[0], t)) for t in interior_contacts(result)]
    runs = [(a, ("stretch", a, b, a, b)) for a, b in interior_runs(result)]
    both = sorted(touches + runs, key=lambda x: x[0])
    return [x[1][:2] if x[1][0] == "point" else x[1][:3] for x in both], [x[1] for x in both]


def interior_runs(result, besides=()) -> list[tuple[float, float]]:
    """(from, to) of the stretches of a converged cantilever that start inside the rod (beyond its
    first element), apart from those overlapping ``besides``; an end on the tip's element is 1
    (held there: no vertex, :func:`stretch_ends`). A stretch that reaches the tip needs a vertex at
    its inner end as a short one does at both: left inside an element, that end cost the estimate
    its order (the magnetic workspace in a bent 0.6 mm lumen, a stretch from 0.61 L to the tip:
    4096 elements, 55 s, error 5.6e-4 for a tolerance of 1e-6; with the vertex: 64 elements,
    1.6 s, 7e-7). A stretch from the clamp keeps the one-element estimate of where it leaves its
    wall (:meth:`Contact._span`): an unshearable rod lying on a wall leaves it tangentially (gap
    ~ (s - a)^3), where the smallest point of :func:`stretch_ends` was 8e-4 L off the reference
    (lying on a wall, q L^3/E_b = 3, P L^2/E_b = 1) and its rounds did not settle."""
    contact = getattr(result, "contact", None)
    if contact is None or not hasattr(result, "disc"):
        return []
    v = result.disc.vertices
    out = []
    for c in contact[0]:
        a, b = c["s"]
        b = 1.0 if b >= v[-2] else b
        if a != b and a > v[1] and a < 1.0 and not any(max(a, lo) <= min(b, hi) for lo, hi in besides):
            out.append((float(a), float(b)))
    return out


def _last(contact: tuple, obs) -> tuple:
    """What the next round's step needs of this one: ("point", vertex, touch) or ("stretch", from,
    to, next from, next to, the nodes of the mesh they were read on)."""
    return (*contact, *obs) if contact[0] == "stretch" else (*contact, obs)


def _observe(result, contacts) -> list | None:
    """Per contact (in order) (what the result says of it, on its vertices): a point contact's touch
    (:meth:`Contact.touch_points`), a short stretch's next ends (:func:`stretch_ends`); None when
    the contacts are not those given (one more or fewer, a stretch lifted off)."""
    stretches = [c for c in contacts if c[0] == "stretch"]
    ends = {c: stretch_ends(result, c[1], c[2]) for c in stretches}
    if any(e is None for e in ends.values()):
        return None
    touches = [t for t in interior_contacts(result) if not any(_part_of(result, t, c) for c in stretches)]
    runs = [(a, b, None, ("run", a, b), None) for a, b in interior_runs(result, [c[1:] for c in stretches])]
    touches = sorted(touches + runs, key=lambda t: t[0])  # a point whose nodes now form a stretch
    if len(touches) != len(contacts) - len(stretches):
        return None
    out, it = [], iter(touches)
    for c in contacts:
        if c[0] == "point":
            t = next(it)
            out.append((t, _on_vertex(c[1], t)))
        else:
            qa, qb, on = ends[c]
            out.append(((qa, qb, mesh_of(result)), on))
    return out


def _part_of(result, touch: tuple, stretch: tuple) -> bool:
    """Whether a point touch lies on a stretch's elements or the ones beside them (a coarse mesh
    loads only a stretch's two vertices and its mid-point: a point contact by its nodes)."""
    v = result.disc.vertices
    i, j = np.searchsorted(v, stretch[1] - 1e-12), np.searchsorted(v, stretch[2] + 1e-12)
    return v[max(i - 1, 0)] <= touch[1] <= v[min(j, v.size - 1)]


def _next(contact: tuple, obs, last) -> tuple:
    """The next vertices of a contact. A point on its vertex loaded on both sides becomes a short
    stretch from its first to its last loaded node; a stretch whose ends meet, a point; so does a
    point whose slopes there and at its last most loaded node are level (secant zero > AHEAD times
    their distance away): a tube along its wall keeps grad g . d3 at its shear tilt (1 % wider lumen,
    E_b = 9e-5 N m^2, B = (10, 0, 17.3) mT: 0.0019587, 0.0019958 at 0.2344, 0.25 L: to -0.59 L)."""
    if contact[0] == "stretch":
        qa, qb, mesh = obs
        if last[0] == "stretch":  # a secant on each end's move (rate ~0.05)
            same = last[5:] == (mesh,)
            qa = end_secant(contact[1], qa, last[1], last[3], same)
            qb = end_secant(contact[2], qb, last[2], last[4], same)
        return ("point", 0.5 * (qa + qb)) if qb - qa < SHORTEST else ("stretch", qa, qb)
    p = contact[1]
    span = obs[3] if len(obs) > 3 else None
    if span is not None and span[0] == "run":  # its nodes form a stretch now
        return ("stretch", span[1], span[2])
    if _on_vertex(p, obs) and span is not None and span[1] - span[0] >= SHORTEST:
        return ("stretch", *span)
    if last[0] == "stretch":
        return ("point", obs[0])
    p0, t0 = last[1], last[2]
    secant = obs[1] == p and t0[1] != p
    nxt = _secant(p, obs[2], t0[1], t0[2]) if secant else obs[0]
    if secant and abs(p - t0[1]) >= SETTLED and abs(nxt - p) > AHEAD * abs(p - t0[1]):
        return ("stretch", min(p, t0[1]), max(p, t0[1]))  # level slopes: it lies along its wall
    if abs(p - p0) < SETTLED:  # a step at the secant's round-off says nothing of a stretch
        return ("point", nxt)
    twice = secant and t0[1] == p0  # on its vertex in both rounds
    if twice and obs[2] * t0[2] < 0.0:  # the slopes bracket the touching point: the secant is
        return ("point", nxt)  # between the vertices (0.3659, 0.3670 -> 0.3662 L, the channel at 160 mm)
    crawls = twice and abs(nxt - p) > HOP * abs(p - p0)
    if crawls or abs(nxt - p0) < HOP * abs(p - p0):  # or back towards the last vertex
        return ("stretch", min(p, p0), max(p, p0))
    return ("point", nxt)


def _kink(contact: tuple, moved: tuple, touch) -> tuple[float, float] | None:
    """The short stretch (from, to) a point contact that stays one needs for its shear kink (its
    touch's fifth item, from :func:`matid.rod.contact_rounds.report`), or None. Measured on the
    workspace in a bent 0.6 mm lumen, E_b = 9e-5 N m^2, B along (-17.3, 0, -10) mT: its inner
    corner, settled as a point on 56 elements, left the tip 2.7e-5 L off a 512-element solve for an
    estimate of 6.5e-7; opened into a stretch (0.0050 L, as on 512 elements): 64 elements, 1.4e-8 L
    off, estimate 1.2e-6."""
    point = contact[0] == moved[0] == "point"
    return touch[4] if point and len(touch) > 4 else None


def _distance(new: tuple, old: tuple) -> float:
    """How far a contact's vertices moved (inf when it changed kind)."""
    if new[0] != old[0]:
        return float("inf")
    return max(abs(a - b) for a, b in zip(new[1:], old[1:], strict=True))


def _on_vertex(p: float, touch: tuple) -> bool:
    """Whether a point contact sits on its vertex p (its most loaded node is p)."""
    return touch[1] == p


def _secant(s: float, slope: float, s0: float, slope0: float) -> float:
    """The zero of the line through (s0, slope0), (s, slope) (s0 != s); s itself when level."""
    return s if slope == slope0 else s - slope * (s - s0) / (slope - slope0)


def _report_ends(result, contacts: list) -> None:
    """The reported s range of each short stretch: its settled ends (not the one-element estimate
    of :meth:`Contact._span`, made for stretches without vertices)."""
    contact = getattr(result, "contact", None)
    if contact is None:
        return
    for c in contacts:
        if c[0] != "stretch":
            continue
        for entry in contact[0]:
            lo, hi = entry["s"]
            if max(lo, c[1]) <= min(hi, c[2]) or c[1] <= lo <= c[2]:
                entry["s"] = (c[1], c[2])
                break


def interior_contacts(result) -> list[tuple]:
    """:meth:`Contact.touch_points` of a converged cantilever away from its tip (a contact on its
    last element is a tip contact), sorted by s: point contacts and the ends of stretches."""
    contact = getattr(result, "contact", None)
    if contact is None or not hasattr(result, "disc"):
        return []
    tip = 1.0 - float(result.disc.vertices[-1] - result.disc.vertices[-2])
    return sorted((t for t in contact[2] if t[1] < tip and t[0] < tip), key=lambda t: (t[0], t[1]))

