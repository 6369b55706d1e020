"""Many planar cantilever scenes on one mesh as one stacked system (physics.md section 10).

:class:`Stack` holds N scenes on one :class:`~matid.rod.fem.Discretisation` (same mesh, element
and model): their stiffnesses, precurvatures, fields and dead loads as arrays with a leading scene
axis. One :meth:`Stack.evaluate` gives every residual and tangent: the point values by one batched
matmul, the strain kernel :func:`matid.physics.planar.derivatives` on all points of all scenes
(its Hessian's seven non-zero entries), the element matrices by one product per element with
tables built once per mesh, factorised for all scenes at once by :class:`matid.rod.chain.Chain`.
Per scene the arithmetic is that of :class:`matid.rod.system.RodSystem` (the same kernels, the
same terms' data): :func:`newton` and :func:`follow` are :func:`matid.rod.newton.newton` and
:func:`matid.rod.newton.follow` with their tests applied per scene, so a scene that converges,
diverges or lands on an unstable state leaves the stack with its answer or its reason. They take
any stack with this interface: the full model's is :class:`matid.rod.batch_full.FullStack`.
"""

from __future__ import annotations

import math

import numpy as np

from matid.physics import planar
from matid.rod import newton as nw
from matid.rod.cantilever import probe_start
from matid.rod.chain import Chain, ChainLayout
from matid.rod.fem import Discretisation
from matid.rod.models import PLANAR
from matid.rod.terms import DistributedForce, Magnetisation, Magnets, PointLoads, Tip

#: The terms a stack evaluates (planar model); a scene with any other runs alone.
STACKED = (Magnetisation, DistributedForce, Tip, Magnets, PointLoads)
#: Scenes per BLAS product of the element matrices: OpenBLAS ran the product of 81 x 7 nq by 1000
#: columns on its threads (300 columns: not), and on a loaded machine their start-up cost dominates
#: (measured at load 11 on 2 cores, N = 1000 in one product: 260 ms against 0.8 ms in 5 products).
PRODUCT_SCENES = 200
UNSTABLE = "unstable equilibrium (the tangent stiffness is not positive definite: buckling or snap)"


def stackable(loads) -> bool:
    """Whether a planar scene's terms are all evaluated by :class:`Stack`."""
    return all(type(t) in STACKED and not getattr(t, "directed", ()) for t in loads)


class Stack:
    """Residual and tangent of N planar cantilevers on one mesh (see the module docstring).

    ``parts``: (scaled rod, its load terms) per scene, as :func:`matid.rod.cantilever.scaled` gives;
    ``probe``: their :func:`matid.rod.cantilever.probe_start` when known (it is the same on every mesh).
    """

    #: per-scene arrays (leading scene axis) that :meth:`take` selects; the point stresses' size
    PER_SCENE = ("k2", "mu", "B", "f", "dead", "magnet", "roundoff", "probe")
    STRESSES = 2

    def __init__(self, disc: Discretisation, parts: list[tuple], probe: np.ndarray | None = None):
        self.disc = disc
        self.work: dict = {}  # scratch arrays, shared with the stacks taken from this one
        disc.clamp()
        self.N, s = len(parts), disc.s_quad
        # uniform rods: their values at every point, in one product; rods with segments: their own
        base = np.array([(1.0, rod.E_s, rod.E_e, rod.kappa_ref[1]) for rod, _ in parts]).T
        fields = base[:, :, None, None] * np.ones(s.shape)
        for i in (i for i, (rod, _) in enumerate(parts) if rod.segments):
            stiff, kappa = parts[i][0].stiffness_at(s), parts[i][0].kappa_ref_at(s)
            fields[:3, i] = [stiff[k] for k in ("E_b", "E_s", "E_e")]
            fields[3, i] = fields[3, i] if kappa is None else kappa[..., 1]
        self.props = {"E_b": fields[0], "E_s": fields[1], "E_e": fields[2]}
        self.k2 = fields[3]
        self.mu, self.B = np.zeros((self.N,) + s.shape), np.zeros((self.N, 3))
        self.f = np.zeros((self.N, 2))
        self.dead = np.zeros((self.N, disc.n))  # dead nodal loads at lam = 1 (tip, point loads)
        self.magnet = np.zeros((self.N, disc.nscalar))  # lumped moment at each scalar dof
        tip, pieces = disc.vertex_dof(disc.vertices.size - 1), []
        for i, (_, loads) in enumerate(parts):
            for t in loads:
                self._add(i, t, tip, pieces)
        if pieces:  # Magnetisation.mu_at of every scene, piece by piece in each scene's order
            i, a, b, m = (np.array(c) for c in zip(*pieces, strict=True))
            inside = (s >= a[:, None, None]) & (s <= b[:, None, None])
            np.add.at(self.mu, i, np.where(inside, m[:, None, None], 0.0))
        #: whose first load step is halved until the straight rod's tangent is definite there
        if probe is None:
            probe = np.array([probe_start(rod, loads, PLANAR) for rod, loads in parts], bool)
        self.probe = probe
        self.loaded = {name: bool(getattr(self, name).any()) for name in ("mu", "f", "magnet")}
        stiffest = np.max([v.reshape(self.N, -1).max(1) for v in self.props.values()], 0)
        self.roundoff = nw.roundoff_floor(stiffest)
        self._layout()

    def _add(self, i: int, t, tip: int, pieces: list) -> None:
        if isinstance(t, Magnetisation):
            pieces.extend((i, *piece) for piece in t.along_d3)
            self.B[i] = t.B
        elif isinstance(t, DistributedForce):
            self.f[i] = t.f[0], t.f[2]
        elif isinstance(t, Tip):
            self.dead[i, tip * 3 : tip * 3 + 3] -= (t.force[0], t.force[2], t.moment[1])
        elif isinstance(t, PointLoads):
            for s, F, M in t.loads:
                k = self.disc.nearest_vertex_dof(s)
                self.dead[i, k * 3 : k * 3 + 3] -= (F[0], F[2], M[1])
        elif isinstance(t, Magnets):
            self.B[i] = t.B
            for s, m in t.along_d3:
                self.magnet[i, self.disc.nearest_vertex_dof(s)] += m

    def _layout(self) -> None:
        """The chain of the mesh, the element tables in its node order, the reference state: built
        once per mesh (the cached meshes of cantilever.mesh keep them)."""
        d = self.disc
        self.n = int(d.free.sum())
        built = d.__dict__.get("_stack_layout")
        if built is None or built[0] is not d.s_dof:  # a moved mesh shares the dict, not s_dof
            chain = ChainLayout(d)
            U = np.zeros((d.nscalar, 3))
            U[:, 1] = d.affine(0.0, 1.0)
            built = d.__dict__["_stack_layout"] = (d.s_dof, chain, _tables(d, chain.local), U.ravel())
        self.chain, self.tables, self.ref = built[1:]
        if self.magnet[:, self.chain.mids].any():  # lumped magnets sit on vertices (vertex_dof)
            raise ValueError("a lumped magnet off the mesh vertices")

    def scratch(self, name: str, shape: tuple) -> np.ndarray:
        """A work array of ``shape``, the same memory at every call (for the stack and the stacks it
        takes; what is written there is overwritten by the next call). Fresh arrays of a megabyte
        at each Newton iteration cost page faults: measured, 40 % of an iteration at N = 100."""
        size = math.prod(shape)
        buffer = self.work.get(name)
        if buffer is None or buffer.size < size:
            buffer = self.work[name] = np.empty(size)
        return buffer[:size].reshape(shape)

    def take(self, ids: np.ndarray) -> Stack:
        """The stack of the scenes ``ids`` (shares the mesh and its layout)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        new.N = len(ids)
        new.props = {k: v[ids] for k, v in self.props.items()}
        for name in self.PER_SCENE:
            setattr(new, name, getattr(self, name)[ids])
        new.loaded = {name: bool(getattr(new, name).any()) for name in self.loaded}
        return new

    def expand(self, X: np.ndarray) -> np.ndarray:
        U = np.broadcast_to(self.ref, (X.shape[0], self.ref.size)).copy()
        U[:, self.disc.free] = X
        return U

    def reference(self) -> np.ndarray:
        return np.broadcast_to(self.ref[self.disc.free], (self.N, self.n)).copy()

    def project(self, X: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """:meth:`matid.rod.system.RodSystem.project` of the states X[rows]: planar, X unchanged."""
        return X

    def point_values(self, U: np.ndarray) -> np.ndarray:
        d = self.disc
        Ue = U.reshape(-1, d.nscalar, d.nf)[:, d.edofs.T]  # (N, ne, nloc, nf)
        return np.matmul(d.point_table, Ue).reshape(U.shape[0], d.ne, -1, 2 * d.nf)

    def residual(self, g: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """R (N, all dofs) from the pointwise gradients g (N, ne, nq, 2 nf) and the dead loads:
        :meth:`matid.rod.fem.Discretisation.residual` of every scene in one product and one bincount."""
        d, N, nf = self.disc, g.shape[0], self.disc.nf
        ne, nq = d.ne, g.shape[2]
        Wt = d.weighted.transpose(2, 1, 0, 3).reshape(ne, -1, 2 * nq)
        ge = g.reshape(N, ne, nq, 2, nf).transpose(0, 1, 3, 2, 4).reshape(N, ne, 2 * nq, nf)
        Re = np.matmul(Wt, ge)
        index = self.work.get(("index", N))
        if index is None:
            index = self.work[("index", N)] = (d.gdofs.ravel()[None, :] + d.n * np.arange(N)[:, None]).ravel()
        R = np.bincount(index, weights=Re.ravel(), minlength=N * d.n).reshape(N, d.n)
        R += lam[:, None] * self.dead
        return R

    def evaluate(self, X, lam, *, tangent=True, stress=None, want_strain=False):
        """(R (N, n free), block-tridiagonal tangent or None, strain) at states X, load factors lam (N,)."""
        d, N = self.disc, X.shape[0]
        U = self.expand(X)
        z = self.point_values(U)
        lam3 = lam[:, None, None]
        kappa = np.zeros(z.shape[:-1] + (3,))
        kappa[..., 1] = lam3 * self.k2
        opts = {"stress": stress, "want_strain": want_strain, "compact": True}
        g, H, strain = planar.derivatives(z, 1.0, self.props, kappa, tangent, **opts)
        if self.loaded["mu"]:
            B = np.broadcast_to(self.B[:, None, None, :], z.shape[:-1] + (3,))
            planar.magnetic(
                g, H, z, lam3 * self.mu, (B[..., 0].ravel(), 0.0, B[..., 2].ravel()), compact=True
            )
        if self.loaded["f"]:
            g[..., 0] -= lam3 * self.f[:, None, None, 0]
            g[..., 1] -= lam3 * self.f[:, None, None, 1]
        ne, nq = d.ne, g.shape[2]
        R = self.residual(g, lam)
        T = K = None
        if tangent:  # K_e = tables_e @ H's entries: (ne, node pairs x field pairs, N)
            hs = np.ascontiguousarray(H.reshape(7, N, ne, nq).transpose(2, 3, 0, 1)).reshape(ne, 7 * nq, N)
            K = self.scratch("K", (ne, 81, N))
            for j in range(0, N, PRODUCT_SCENES):  # single-threaded BLAS products (PRODUCT_SCENES)
                np.matmul(self.tables, hs[..., j : j + PRODUCT_SCENES], out=K[..., j : j + PRODUCT_SCENES])
            K = K.reshape(ne, 3, 3, 3, 3, N).transpose(1, 2, 3, 4, 0, 5)
        diagonal = None
        if self.loaded["magnet"]:
            th, m = U.reshape(N, -1, 3)[:, :, 2], lam[:, None] * self.magnet
            Bx, Bz = self.B[:, None, 0], self.B[:, None, 2]
            R.reshape(N, -1, 3)[:, :, 2] -= m * (np.cos(th) * Bx - np.sin(th) * Bz)
            if tangent:
                v = self.chain.vertices
                diagonal = np.zeros((3, v.size, N))
                diagonal[2] = (m[:, v] * (np.sin(th[:, v]) * Bx + np.cos(th[:, v]) * Bz)).T
        if K is not None:
            T = Chain(K, self.chain, diagonal)
        return R[:, d.free], T, strain

    def solve(self, T: Chain, R: np.ndarray) -> np.ndarray:
        """-T^-1 R in free-dof numbering."""
        free = self.disc.free
        r = np.zeros((R.shape[0], free.size))
        r[:, free] = -R
        return T.solve(r)[:, free]

    def stress_step(self, strain, dx, alpha, old) -> np.ndarray:
        """:meth:`matid.rod.system.RodSystem.mixed_update` for the stack: sigma after a step alpha dx."""
        sigma_u, CJ = strain
        dU = np.zeros((dx.shape[0], self.disc.n))
        dU[:, self.disc.free] = dx
        target = sigma_u + np.matmul(CJ, self.point_values(dU)[..., None])[..., 0]
        old = np.where(np.isnan(old), sigma_u, old)
        return old + alpha[:, None, None, None] * (target - old)


def _tables(disc: Discretisation, local: np.ndarray) -> np.ndarray:
    """(ne, 81, 7 nq): the element matrices' node blocks [k, l, i, j] (k, l in the chain's local
    node order, i, j fields x, z, theta) from the entries of planar.COMPACT at each point.

    With z = (x, z, t, x', z', t'), x' and z' read phi' of x and z, t phi and t' phi' of theta, so
    (w the weights, phi_k of local node k): (x, x) w phi'_k phi'_l H_x'x', (x, z) and (z, x)
    ... H_x'z', (z, z) ... H_z'z', (theta, theta) w phi_k phi_l H_tt + w phi'_k phi'_l H_t't',
    (theta, x) w phi_k phi'_l H_tx' and (x, theta) w phi'_k phi_l H_tx'; the same with z."""
    W, B = disc.weighted[:, local], disc.both[:, local]  # (2, 3, ne, nq)
    ne, nq = disc.dx.shape
    P = np.einsum("keq,leq->eklq", W[0], B[0])
    D = np.einsum("keq,leq->eklq", W[1], B[1])
    Mv = np.einsum("keq,leq->eklq", W[0], B[1])  # value of node k, slope of node l
    Ms = np.einsum("keq,leq->eklq", W[1], B[0])
    t = np.zeros((ne, 3, 3, 3, 3, nq, 7))  # [e, k, l, i, j, q, entry]
    x, z, th = 0, 1, 2
    tt, tx, tz, xx, xz, zz, ss = range(7)
    t[:, :, :, x, x, :, xx] = D
    t[:, :, :, x, z, :, xz] = t[:, :, :, z, x, :, xz] = D
    t[:, :, :, z, z, :, zz] = D
    t[:, :, :, th, th, :, tt], t[:, :, :, th, th, :, ss] = P, D
    t[:, :, :, th, x, :, tx], t[:, :, :, x, th, :, tx] = Mv, Ms
    t[:, :, :, th, z, :, tz], t[:, :, :, z, th, :, tz] = Mv, Ms
    return t.reshape(ne, 81, nq * 7)


def newton(stack: Stack, X0: np.ndarray, lam: np.ndarray, stress0: np.ndarray, first: tuple | None = None):
    """:func:`matid.rod.newton.newton` for every scene of ``stack`` at once, each at its own load
    factor; ``stress0``: first mixed tangent's point stresses (NaN: consistent). Returns
    (X, iterations, positive definite, converged stress, failure reason or None) per scene, and
    the last factorised tangents: (tangent, its rows, their scenes) per iteration where some
    converged; a scene leaves the stack as soon as it converges or fails. ``first``: (R, tangent,
    strain) at (X0, lam) already evaluated, with consistent stresses (a probe of definite_steps)."""
    N = stack.N
    X, its = X0.copy(), np.zeros(N, int)
    pd, reason = np.zeros(N, bool), [None] * N
    out_stress = np.full(stress0.shape, np.nan)
    floor = np.minimum(np.maximum(nw.XTOL, stack.roundoff), nw.FLOOR_CAP)
    sizes = np.full((N, nw.MAX_ITER + 1), np.nan)
    live, sub, x, S = np.arange(N), stack, X0.copy(), stress0.copy()
    factors: list = []
    for it in range(1, nw.MAX_ITER + 1):
        if first is not None and it == 1:
            R, T, strain = first
        else:
            R, T, strain = sub.evaluate(x, lam[live], stress=S, want_strain=True)
        dx = sub.solve(T, R)
        size = np.abs(dx).max(1) if dx.shape[1] else np.zeros(len(live))
        h = sizes[live]
        prev, third, count = h[:, it - 2] if it > 1 else np.nan, h[:, it - 4] if it > 3 else np.nan, it - 1
        bad = ~np.isfinite(R).all(1) | ~np.isfinite(size)
        done = ~bad & ((size <= nw.XTOL) | ((size <= floor[live]) & (count > 0) & (size > 0.1 * prev)))
        diverge = ~bad & ~done & (count >= 3) & (size > prev) & (size > third)
        sizes[live, it - 1] = size
        its[live] = it
        leave = bad | done | diverge | (it == nw.MAX_ITER)
        if done.any():
            factors.append((T, np.flatnonzero(done), live[done]))
            X[live[done]] = x[done] + dx[done]
            pd[live[done]] = T.positive_definite(np.flatnonzero(done))
            out_stress[live[done]] = strain[0][done]
        for j in np.flatnonzero(leave & ~done):
            reason[live[j]] = (
                "residual is not finite"
                if bad[j]
                else f"diverging: correction {size[j]:.3g} at iteration {it}"
                if diverge[j]
                else f"no convergence in {nw.MAX_ITER} iterations (correction {size[j]:.3g})"
            )
        if leave.any():  # the scenes that stay (all of them: no copies)
            stay = ~leave
            if not stay.any():
                break
            size, dx, x, S = size[stay], dx[stay], x[stay], S[stay]
            strain = (strain[0][stay], strain[1][stay])
            live = live[stay]
            sub = stack.take(live)
        alpha = np.minimum(1.0, nw.MAX_STEP / size)
        S = stack.stress_step(strain, dx, alpha, S)
        S[size <= nw.MIXED_ABOVE] = np.nan
        x = x + dx * alpha[:, None]
        x = stack.project(x, (size > nw.PROJECT_ABOVE) & (size <= nw.MAX_STEP))
    return X, its, pd, out_stress, reason, factors


def admissible(stack: Stack, X, lam, pd) -> np.ndarray:
    """Per scene: stable (every Schur complement of the tangent at X positive definite). As
    :meth:`RodSystem.reject`: the last Newton factorisation first, the tangent at X when it failed."""
    pd = pd.copy()
    again = np.flatnonzero(~pd)
    if again.size:
        T = stack.take(again).evaluate(X[again], lam[again])[1]
        pd[again] = T.positive_definite(np.arange(again.size))
    return pd


def definite_steps(stack: Stack, X0: np.ndarray, step: np.ndarray) -> tuple | None:
    """:func:`matid.rod.newton.definite_step` for the scenes that probe (``stack.probe``): their first
    step halved, in place, while the tangent at the start is not positive definite at its load.
    Returns the last probe's (R, tangent, strain) when it was of every scene and all were definite:
    the first Newton iteration of the first step (as newton.follow's ``first``), else None."""
    ids = np.flatnonzero(stack.probe)
    for _ in range(nw.MAX_DEFINITE_HALVINGS):
        ids = ids[step[ids] >= 2.0 * nw.MIN_STEP]
        if not ids.size:
            return None
        part = stack.take(ids)
        R, T, strain = part.evaluate(X0[ids], np.minimum(step[ids], 1.0), want_strain=True)
        bad = ~T.positive_definite(np.arange(ids.size))
        if not bad.any():
            return (R, T, strain) if ids.size == stack.N else None
        ids = ids[bad]
        step[ids] *= 0.5
    return None


def follow(stack: Stack, X0: np.ndarray, stress0: np.ndarray | None = None):
    """:func:`matid.rod.newton.follow` to lam = 1 for every scene, each with its own load steps.

    Returns (X, info per scene (iterations, steps, rejected), converged stress, reason or None).
    """
    N = stack.N
    X, lam = X0.copy(), np.zeros(N)
    step, slope = np.ones(N), np.zeros_like(X0)
    its, steps, rejected = np.zeros(N, int), np.zeros(N, int), np.zeros(N, int)
    nq = stack.disc.s_quad.shape
    stress = np.full((N,) + nq + (stack.STRESSES,), np.nan) if stress0 is None else stress0.copy()
    reason: list = [None] * N
    budget = max(nw.MIN_ITERATIONS, int(nw.WORK_BUDGET / max(X0.shape[1], 1)))
    first = definite_steps(stack, X0, step)
    live = np.arange(N)
    while live.size:
        sub = stack.take(live)
        lam_try = np.where(np.abs(1.0 - lam[live]) <= step[live], 1.0, lam[live] + step[live])
        guess = X[live] + slope[live] * (lam_try - lam[live])[:, None]
        Xn, k, pd, sn, why, factors = newton(sub, guess, lam_try, stress[live], first)
        first = None
        ok = np.array([w is None for w in why])
        ok[ok] = admissible(sub.take(np.flatnonzero(ok)), Xn[ok], lam_try[ok], pd[ok])
        for j, i in enumerate(live):
            if not ok[j]:
                rejected[i] += 1
                step[i] *= 0.5
                if step[i] < nw.MIN_STEP:
                    reason[i] = f"Newton failed at load factor {lam_try[j]:.6g} ({why[j] or UNSTABLE})"
                continue
            its[i] += k[j]
            steps[i] += 1
            lam[i], X[i], stress[i] = lam_try[j], Xn[j], sn[j]
            if its[i] > budget:
                reason[i] = f"continuation gave up after {its[i]} Newton iterations in {steps[i]} load steps"
            elif k[j] <= 2 * nw.FAST:
                step[i] = min((2.0 if k[j] <= nw.FAST else 1.5) * step[i], nw.MAX_LOAD_STEP)
        moving = ok & (lam[live] < 1.0)
        if moving.any():  # the tangent predictor dx/dlam = -K^-1 (R(x, 1) - R(x, 0)), K Newton's last
            ids = live[moving]
            part = stack.take(ids)
            one = part.evaluate(X[ids], np.ones(ids.size), tangent=False)[0]
            dR = one - part.evaluate(X[ids], np.zeros(ids.size), tangent=False)[0]
            where = np.cumsum(moving) - 1  # row of dR of each scene of live
            for T, rows, members in factors:
                take = moving[members]
                if take.any():
                    r = np.zeros((T.N, dR.shape[1]))
                    r[rows[take]] = dR[where[members[take]]]
                    slope[live[members[take]]] = stack.solve(T, r)[rows[take]]
        live = np.array([i for i in live if lam[i] < 1.0 and reason[i] is None], int)
    return X, np.stack([its, steps, rejected], 1), stress, reason
