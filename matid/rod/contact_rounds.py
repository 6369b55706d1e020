"""Solving with walls and a lumen (issue 31): the multipliers settled after Newton (:func:`settle`),
carried from one mesh to the next (:func:`carry`) and the returned state checked (:func:`check`);
the rounds that put mesh vertices at interior contacts are in :mod:`matid.rod.contact_mesh`.

The contact itself is a load term (:mod:`matid.rod.terms.contact`); this module sits above it and
above Newton, so that the term needs neither.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import nnls

from matid.errors import ConvergenceError
from matid.rod.newton import NewtonFailure, check_admissible, newton
from matid.rod.terms.contact import MAX_OUTER, ContactState, contact_of, quadratic_slopes

#: The augmented Lagrangian's k grows x10 (up to K_MAX) when an update shrinks the multipliers'
#: change (in gap units, change / k) by less than 1/SLOW. Uzawa's rate is ~1/(1 + k sigma), sigma
#: the smallest eigenvalue of the loaded nodes' compliance, small when two loaded nodes sit close
#: together (a contact between a vertex and a mid-point; the tip on one wall of a channel and the
#: rod on the other): measured rate 0.7 per update at k = 1e4 on the 6 mT channel at 140 mm, where
#: 30 updates left the multipliers 1e-8 from their fixed point (exit 1, issue 31).
SLOW, K_MAX = 0.25, 1e8
#: The multipliers' complementarity problem (_multiplier_newton) is solved up to this many loaded
#: nodes (S dense: one back-substitution per node), Uzawa's steps beyond.
MAX_DUAL = 2000
#: S = G K^-1 G^T is built from back-substitutions on this many columns at a time. At 256 the
#: solves' threaded BLAS made examples/scenes/point_load.toml against one wall (tolerance 1e-8, up
#: to 512 elements, full model) take 34 s CPU and 135 s wall on 2 shared cores (load 6, OpenBLAS
#: 0.3.31 with 2 threads; 2.7 s CPU with one thread): the scene fuzz counted such scenes as hangs.
#: At 16, measured alternately in one run: 3.8-5.6 s CPU and 12-24 s wall with 2 threads, 2.3 s with
#: one (1: 7.6, 8: 7.3, 32: 4.5 s CPU), the same tip to 1e-17 m.
COLUMNS = 16
#: Multiplier updates before giving up (the penalty has terms.contact.MAX_OUTER increases): plain
#: Uzawa, when a stiffer k fails Newton, converges at its own rate (0.7 per update, measured).
MAX_UPDATES = 80
#: Settled when the multipliers change less than CHANGE_TOL x the largest reaction (scaled, at
#: least 1) or than k x GAP_ROUNDOFF (a gap at the round-off of O(1) scaled positions), or when
#: every loaded node is within GAP_SETTLED x contact_tolerance of its wall: the state is then in
#: equilibrium with its reactions f (Newton converged with them), f >= 0, and complementary to
#: 0.1 of the tolerance (1e-10 L at the default tolerance; Newton's round-off floor at 2048
#: elements of E L^2/E_b = 1e9 left gaps of 1.9e-11 L that Uzawa could not close). Along a
#: stretch the split of the reactions between neighbouring nodes is set by shear strains at
#: Newton's round-off (E_s L^2/E_b = 1e9) and never settles to 1e-10; their resultant and moment
#: do (equilibrium).
CHANGE_TOL, GAP_ROUNDOFF, GAP_SETTLED = 1e-10, 1e-15, 0.1


class ContactStateError(ConvergenceError):
    """A converged state breaks a wall beyond contact_tolerance, pulls on one, or is unstable with
    its contacts: never returned (exit 1)."""


def settle(system, X: np.ndarray, info) -> np.ndarray:
    """The converged state X (at load 1) of a system with contact brought to the walls: multiplier
    updates (augmented: the multipliers' complementarity problem on the loaded nodes, Uzawa's
    step where it cannot be solved, k stiffened while they crawl) or penalty increases, each
    followed by Newton, until the penetration is below tol and the reactions settle; then checked
    (:func:`check`).
    When Newton fails after an update (the semismooth Newton chatters on a node whose reaction and
    gap are both ~0) the last state is kept if it meets the walls within tol, complementary within
    tol (it is in equilibrium with its reactions). Raises ConvergenceError when it cannot."""
    bound = contact_of(system)
    if bound is None:
        return X
    term, prep = bound
    state = prep["state"]
    lu, last, stiffen, newton_steps = info.lu, np.inf, True, True
    limit = MAX_OUTER if term.method == "penalty" else MAX_UPDATES
    for outer in range(limit + 1):
        f, gaps = term.forces(prep, system.expand(X))
        penetration = max(0.0, -min(float(g.min()) for g, _, _ in gaps))
        before = (X, state.mu, state.k)
        if term.method == "penalty":
            if penetration <= term.tolerance:
                break
            state.k *= 10.0
        else:
            change = float(np.abs(f - state.mu).max())
            floor = max(CHANGE_TOL * max(1.0, float(f.max())), state.k * GAP_ROUNDOFF)
            loaded = [np.abs(g[fb > 0]) for fb, (g, _, _) in zip(f, gaps, strict=True)]
            closed = max([float(a.max()) for a in loaded if a.size] + [0.0])
            if penetration <= term.tolerance and (change <= floor or closed <= GAP_SETTLED * term.tolerance):
                break
            step = _multiplier_newton(system, prep, X, f, gaps) if newton_steps else None
            if step is not None:
                state.mu = step
            else:
                if stiffen and change / state.k > SLOW * last and state.k < K_MAX:  # Uzawa crawls
                    state.k *= 10.0
                state.mu = f
            last = change / state.k
        if outer == limit:
            raise ConvergenceError(
                f"contact: the walls are not met within {term.tolerance:.3g} L after {limit} "
                f"{'penalty increases' if term.method == 'penalty' else 'multiplier updates'}",
                load_factor=1.0,
            )
        try:
            X, its, lu = newton(system, X, 1.0)
        except NewtonFailure as exc:
            if term.method != "penalty" and penetration <= term.tolerance and closed <= term.tolerance:
                X, state.mu, state.k = before  # chatter at a kink: the last state is an answer
                break
            if term.method == "penalty" or (state.k == before[2] and not newton_steps):
                message = f"contact: Newton failed while settling the contacts ({exc})"
                raise ConvergenceError(message, load_factor=1.0) from exc
            if newton_steps and state.k == before[2]:  # the multipliers' Newton step overshot
                X, state.mu, newton_steps = before[0], before[1], False
                continue
            X, _, state.k = before  # too stiff for Newton: plain Uzawa updates from here on
            stiffen = False
            continue
        state.outer += 1
        state.newton += its
        info.iterations += its
    info.lu = lu
    check(system, X, lu)
    return X


def _multiplier_newton(system, prep, X: np.ndarray, f: np.ndarray, gaps: list) -> np.ndarray | None:
    """The multipliers of the loaded nodes A that meet the walls to first order, released where
    they would pull: the linear complementarity problem mu >= 0, w = g + S (mu - mu_now) >= 0,
    mu . w = 0, with S = G K^-1 G^T (G the gaps' gradients on the free dofs, K the tangent with the
    contact stiffness at the settled state X: dx = K^-1 G^T dmu is how the state answers a change
    of the multipliers at fixed k). S is symmetric positive definite at a stable state, so this is
    min 1/2 mu.S mu + q.mu over mu >= 0, q = g - S mu_now: scipy.optimize.nnls on the Cholesky
    factor of S (Lawson-Hanson, exact). Uzawa's step mu <- f is the first-order step with S
    replaced by I / k: it crawls when loaded nodes are close (a contact between two nodes, rate 0.7
    at k = 1e4; a stretch, every node loaded, rate ~1 - k sigma_min with sigma_min ~ h^3), and
    Newton's step on the multipliers with the clipping of the negative ones thrashed along a
    stretch (17 loaded nodes -> 2: the reactions' zig-zag modes are set by shear strains at
    round-off). None (then Uzawa's step) when nothing is loaded, more than MAX_DUAL nodes are, or
    S is not positive definite (a dead moment in 3D: no potential)."""
    active = np.argwhere(f > 0.0)  # (boundary, node)
    if active.size == 0 or len(active) > MAX_DUAL:
        return None
    dofs, index = prep["dofs"], system.index
    rows, cols, vals = [], [], []
    for r, (b, i) in enumerate(active):
        grad = gaps[b][1][i][[0, 2]] if prep["planar"] else gaps[b][1][i]
        for c, v in zip(index[dofs[i]], grad, strict=True):
            if c >= 0 and v != 0.0:
                rows.append(r)
                cols.append(c)
                vals.append(v)
    keep = np.unique(rows)
    if keep.size == 0:
        return None
    G = sp.csr_matrix((vals, (rows, cols)), shape=(len(active), X.size))[keep]
    K = system.evaluate(X, 1.0)[1]
    K = sp.csc_matrix(K.tocsr())  # banded (matid.rod.band) or CSR: RodSystem.evaluate
    try:
        lu = spla.splu(K)
    except RuntimeError:  # singular tangent
        return None
    Gt = G.T.tocsc()
    S = np.hstack([G @ lu.solve(Gt[:, j : j + COLUMNS].toarray()) for j in range(0, Gt.shape[1], COLUMNS)])
    S = 0.5 * (S + S.T)
    b, i = active[keep].T
    now = prep["state"].mu[b, i]
    g = np.array([gaps[bb][0][ii] for bb, ii in zip(b, i, strict=True)])
    q = g - S @ now
    try:
        C = np.linalg.cholesky(S)  # S = C C^T
    except np.linalg.LinAlgError:
        return None
    # 1/2 mu.S mu + q.mu = 1/2 |C^T mu + C^-1 q|^2 - const
    mu_new, _ = nnls(C.T, -np.linalg.solve(C, q), maxiter=50 * keep.size)
    if not np.isfinite(mu_new).all():
        return None
    mu = f.copy()  # nodes whose dofs are all fixed (the clamp) keep Uzawa's value
    mu[b, i] = mu_new
    return mu


def check(system, X: np.ndarray, lu=None) -> None:
    """Raise ContactStateError unless the state meets every wall within contact_tolerance, no
    reaction pulls (f >= 0) or acts across an open gap, and the state is stable with its contacts
    (the tangent including the contact stiffness k grad g grad g^T of the loaded nodes:
    :meth:`RodSystem.reject`)."""
    bound = contact_of(system)
    if bound is None:
        return
    term, prep = bound
    f, gaps = term.forces(prep, system.expand(X))
    g = np.array([gb for gb, _, _ in gaps])
    reason = None
    if not (np.isfinite(f).all() and np.isfinite(g).all()):
        reason = "non-finite contact forces or gaps"
    elif g.min() < -term.tolerance:
        reason = f"the tube crosses a wall by {-g.min():.3g} L (contact tolerance {term.tolerance:.3g} L)"
    elif f.min() < 0.0:
        reason = f"a contact reaction pulls ({f.min():.3g} E_b/L^2)"
    elif np.any((f > 0) & (g > term.tolerance)):
        reason = "a contact reaction acts across an open gap (not complementary)"
    if reason is None:
        prep["state"].checking = True
        try:
            check_admissible(system, X, 1.0, lu)
        except NewtonFailure as exc:
            reason = str(exc)
    if reason is not None:
        raise ContactStateError(f"contact: {reason}", load_factor=1.0)


def carry(system, start) -> None:
    """Start ``system``'s multipliers from those a converged state on another mesh settled
    at (``start.contact[3]``): each node's reaction split between the two nodes of the new mesh
    around it, so the resultant and its moment are kept (on a nested mesh the same nodes: exactly
    the old reactions). Without them a warm Newton starts the contact as a penalty with the new
    mesh's interpolant and must find the penetration again (measured: it then failed on the 6 mT
    channel at 140 mm and the cold continuation behind it stagnated)."""
    bound = contact_of(system)
    carried = getattr(start, "contact", None)
    if bound is None or carried is None or len(carried) < 4:
        return
    s_old, f_old = carried[3][:2]
    prep = bound[1]
    s = prep["s"]
    order = np.argsort(s)
    ss = s[order]
    mu = np.zeros((f_old.shape[0], s.size))
    j = np.clip(np.searchsorted(ss, s_old, side="right") - 1, 0, ss.size - 2)
    t = np.clip((s_old - ss[j]) / (ss[j + 1] - ss[j]), 0.0, 1.0)
    for b in range(f_old.shape[0]):
        np.add.at(mu[b], order[j], (1.0 - t) * f_old[b])
        np.add.at(mu[b], order[j + 1], t * f_old[b])
    prep["state"] = ContactState(prep["state"].k, mu)  # k from its start: a stiff one (K_MAX) failed Newton


def reset(system) -> None:
    """Forget carried multipliers (a cold continuation starts from the straight rod)."""
    bound = contact_of(system)
    if bound is not None:
        state = bound[1]["state"]
        state.mu[:] = 0.0


def report(system, X: np.ndarray) -> tuple | None:
    """(contacts, quantities, touch points, (node s, reactions, k, gaps)) of a settled state,
    scaled (reactions and gaps: (boundaries, nodes)); None without walls."""
    bound = contact_of(system)
    if bound is None:
        return None
    term, prep = bound
    U = system.expand(X)
    f = with_clamp(system, term, prep, X, U)
    f0, gaps = term.forces(prep, U)
    touches = [_kinked(system, term, prep, U, f0, gaps, t) for t in term.touch_points(system, prep, U, f)]
    return (
        term.contacts(system, prep, U, f),
        term.quantities(system, prep, U, f),
        touches,
        (prep["s"].copy(), f0, prep["state"].k, np.array([g for g, _, _ in gaps])),
    )


def _kinked(system, term, prep, U, f, gaps, touch: tuple) -> tuple:
    """A point contact's touch (:meth:`Contact.touch_points`) and, last, the short stretch (from,
    to) a shearable rod needs there when a point reaction on its vertex would leave the centreline
    inside the wall beside it by more than the contact tolerance (between nodes, where no gap is
    checked), else None: :func:`matid.rod.contact_mesh.contact_rounds` then returns no point there.

    At a point reaction F the shear force jumps by F, so the centreline's slope towards the wall
    jumps by F / E_s while the director (the bending moment) stays continuous: the gap beside the
    node is at best g(d) = -sigma |d| + c d^2 / 2 (sigma = F / (2 E_s), the sides split evenly;
    c = g'' = grad g . d3' + d3 . H_g d3, the rod's bending against the wall's curvature), below
    zero over |d| < 2 sigma / c and sigma^2 / (2 c) deep. Lying on the wall, the centreline
    follows it and the shear strain turns at the rate c, so the reaction spreads over
    F / (E_s c) = 2 sigma / c: the stretch returned, centred on the vertex. Measured on the
    magnetic workspace in a bent 0.6 mm lumen (E_s L^2/E_b = 1000, E_b = 9e-5 N m^2, B along
    (-17.3, 0, -10) mT): at the lumen's inner corner F L^2/E_b = 37.6, c L = 7.48 on every mesh
    from 16 to 64 elements, 2.4e-5 L deep, a stretch of 0.0050 L, where 512 elements found one of
    0.0051 L; as a point contact the tip was 2.7e-5 L off and the estimate 6.5e-7. The channel of
    tests/rod/test_contact.py (E_s L^2/E_b = 1e9): 1e-19 L deep, point contacts."""
    _, at, _, span = touch
    s = prep["s"]
    order = np.argsort(s)
    ss, node = s[order], int(np.flatnonzero(s == at)[0])
    v = int(np.flatnonzero(ss == at)[0])
    if span is not None or v % 2 or v < 2 or v + 2 >= ss.size:  # loaded on both sides; not a vertex
        return (*touch, None)
    b = int(np.argmax(f[:, node]))
    _, grad, H = gaps[b]
    near = order[v - 1 : v + 2]
    F = float(f[b][near] @ np.maximum(grad[near] @ grad[node], 0.0))  # this side's reaction
    sigma = 0.5 * F / float(system.rod.stiffness_at(np.array([at]))["E_s"][0])
    d3 = term.directors(system, prep, U, [node])[0]
    bend = 0.0 if H is None else float(d3 @ H[node] @ d3)
    c = np.inf
    for lo in (v - 2, v):  # d3' at the vertex from the element on each side
        d = term.directors(system, prep, U, order[lo : lo + 3])
        dd3 = quadratic_slopes(ss[lo : lo + 3], d)[v - lo]  # the quadratic's slope at the vertex
        c = min(c, float(grad[node] @ dd3) + bend)
    h = min(at - ss[v - 1], ss[v + 1] - at)  # as far as the next node on either side
    half = sigma / c if sigma < c * h else h
    depth = sigma * half - 0.5 * max(c, 0.0) * half**2
    return (*touch, None if depth <= term.tolerance else (at - half, at + half))


def with_clamp(system, term, prep, X: np.ndarray, U: np.ndarray) -> np.ndarray:
    """The nodal reactions with, on a wall along which the rod lies from the clamp (the clamp's gap
    within the contact tolerance and a loaded node on the first element), the clamp's reaction
    along the wall's normal: the clamp's section lies on that wall, and the two share one support.
    Exactly, a cantilever lying on a wall from the clamp under a load pressing it there carries it
    all into the wall and the clamp nothing. On a mesh the split between the clamp and the loaded
    nodes next to it is set by shear strains of ~1e-10 at E_s L^2/E_b = 1e9, where Newton stops:
    the wall's resultant alone came out 7.5 to 8.0 of an exact 8 on the meshes of one estimate
    (and without a lift-off, q h / 6 short: an O(h) error no tolerance below 1e-3 could reach);
    with the clamp's normal reaction it is 8 to 1e-10."""
    f, gaps = term.forces(prep, U)
    node = int(system.disc.vertex_dof(0))
    first = prep["s"] <= system.disc.vertices[1] * (1 + 1e-12)
    R = system.evaluate(X, 1.0, tangent=False, full=True)[0]
    F = R[prep["dofs"][node]]
    F = np.array([F[0], 0.0, F[1]]) if prep["planar"] else F
    f = f.copy()
    for b, (g, grad, _) in enumerate(gaps):
        if g[node] <= term.tolerance and np.any(f[b][first] > 0.0):
            f[b, node] = float(F @ grad[node])
    return f
