"""Many full-model (r, q) cantilever scenes on one mesh as one stacked system (physics.md section 10).

:class:`FullStack` is :class:`matid.rod.batch.Stack` with the full model's kernel and 7 fields per
node: the point values by the same batched matmul, the strain energy's gradient and Hessian by
:func:`matid.physics.full.derivatives` on all points of all scenes, the element matrices by the
tables of :meth:`matid.rod.fem.Discretisation.element_blocks` (one product for every scene), the
nodal terms (the unity gauge at every node, lumped magnets) as 4 x 4 blocks on the q of their
nodes, and the tangent factorised by :class:`matid.rod.chain.Chain` with 7 x 7 blocks: the same
chain, newton and follow as the planar stack (:func:`matid.rod.batch.newton`, :func:`follow`).

Per scene the terms are those of :class:`matid.rod.system.RodSystem` (normalised variant): the
field on magnetisation and magnets is :func:`matid.physics.full.magnet` with each scene's maps
:func:`matid.physics.full.directed_maps` (its own B: the scenes of an [aim] differ in nothing
else), which is the d3 row of the kernel for a moment along d3. Only scenes with a symmetric
tangent stack (no dead moment: its tangent has no potential, and the chain assumes symmetry);
contact, walls and supports run alone (:func:`stackable`).
"""

from __future__ import annotations

import numpy as np

from matid.physics import full
from matid.physics import kinematics as kin
from matid.rod.batch import STACKED, Stack
from matid.rod.cantilever import default_penalty
from matid.rod.chain import Chain, ChainLayout
from matid.rod.fem import Discretisation
from matid.rod.newton import roundoff_floor
from matid.rod.terms import DistributedForce, Magnetisation, Magnets, PointLoads, Tip

NF = 7
#: Points per call of the strain kernel: its temporaries ((n, 14, 14) and more) then stay in cache
#: (measured at load 11: 832 points in one call 17.8 ms, in chunks of 128 points 6.5 ms, of 32 11 ms).
KERNEL_POINTS = 128


def stackable(loads) -> bool:
    """Whether a full-model scene's terms are all evaluated by :class:`FullStack` (symmetric ones)."""
    for t in loads:
        if type(t) not in STACKED:  # the term types the planar stack takes too
            return False
        if isinstance(t, Tip) and any(t.moment):
            return False
        if isinstance(t, PointLoads) and any(any(M) for _, _, M in t.loads):
            return False
    return True


class FullStack(Stack):
    """Residual and tangent of N full-model cantilevers on one mesh (see the module docstring).

    ``parts``: (scaled rod, its load terms) per scene, as :func:`matid.rod.cantilever.scaled` gives
    (with e_a None); every scene must be :func:`stackable`.
    """

    PER_SCENE = ("kappa", "maps", "lumped_maps", "f", "dead", "c_u", "roundoff", "probe")
    STRESSES = 6

    def __init__(self, disc: Discretisation, parts: list[tuple]):
        if disc.nf != NF:
            raise ValueError(f"a full-model stack needs {NF} fields per node, not {disc.nf}")
        self.disc, self.work, self.N = disc, {}, len(parts)
        disc.clamp()
        s, N = disc.s_quad, self.N
        stiff = [rod.stiffness_at(s) for rod, _ in parts]
        self.props = {k: np.stack([p[k] for p in stiff]) for k in ("E_b", "E_t", "E_s", "E_e")}
        self.kappa = np.empty((N,) + s.shape + (3,))
        for i, (rod, _) in enumerate(parts):
            kappa = rod.kappa_ref_at(s)
            self.kappa[i] = rod.kappa_ref if kappa is None else kappa
        self.c_u = np.array([default_penalty(rod, kin.NORMALISED) for rod, _ in parts])
        self.moments = np.zeros((N,) + s.shape + (3,))  # magnetisation mu a per length, director frame
        self.B, self.f = np.zeros((N, 3)), np.zeros((N, 3))
        self.dead = np.zeros((N, disc.n))  # dead nodal forces at lam = 1 (tip, point loads)
        self.lumped = np.zeros((N, disc.nscalar, 3))  # lumped magnets' m a at their vertex
        for i, (_, loads) in enumerate(parts):
            for t in loads:
                self._add(i, t)
        self.probe = np.zeros(N, bool)  # the full model never probes (cantilever.probe_start)
        self._layout()
        # the field's maps (physics.full.directed_maps) at the points and the vertices: built once
        v = self.chain.vertices
        self.maps = full.directed_maps(
            np.repeat(self.B, self.moments[0, ..., 0].size, 0), self.moments.reshape(-1, 3)
        ).reshape(self.moments.shape[:-1] + (4, 4))
        self.lumped_maps = full.directed_maps(np.repeat(self.B, v.size, 0), self.lumped[:, v].reshape(-1, 3))
        self.lumped_maps = self.lumped_maps.reshape(N, v.size, 4, 4)
        self.loaded = {
            "maps": bool(self.moments.any()),
            "f": bool(self.f.any()),
            "lumped_maps": bool(self.lumped.any()),
        }
        stiffest = np.max([v.reshape(N, -1).max(1) for v in self.props.values()], 0)
        self.roundoff = roundoff_floor(stiffest)

    def _add(self, i: int, t) -> None:
        d, s = self.disc, self.disc.s_quad
        vertex = d.nearest_vertex_dof  # as the terms place them (matid.rod.terms.base.node)
        if isinstance(t, Magnetisation):
            self.B[i] = t.B
            self.moments[i, ..., 2] += t.mu_at(s)
            directed = t.directed_at(s)
            if directed is not None:
                self.moments[i] += directed
        elif isinstance(t, Magnets):
            self.B[i] = t.B
            for at, m in t.along_d3:
                self.lumped[i, vertex(at), 2] += m
            for at, m, a in t.directed:
                self.lumped[i, vertex(at)] += m * np.asarray(a, float)
        elif isinstance(t, DistributedForce):
            self.f[i] = t.f
        elif isinstance(t, Tip):
            tip = d.vertex_dof(d.vertices.size - 1)
            self.dead[i, tip * NF : tip * NF + 3] -= t.force
        elif isinstance(t, PointLoads):
            for at, F, _ in t.loads:
                self.dead[i, vertex(at) * NF : vertex(at) * NF + 3] -= F

    def _layout(self) -> None:
        """The chain of the mesh and the reference state (straight, identity rotation), once per mesh."""
        d = self.disc
        self.n = int(d.free.sum())
        built = d.__dict__.get("_full_stack_layout")
        if built is None or built[0] is not d.s_dof:
            U = np.zeros((d.nscalar, NF))
            U[:, 2], U[:, 3] = d.affine(0.0, 1.0), d.affine(1.0, 0.0)
            built = d.__dict__["_full_stack_layout"] = (d.s_dof, ChainLayout(d), U.ravel())
        self.chain, self.ref = built[1:]
        if self.lumped[:, self.chain.mids].any():  # never: magnets sit on vertices (nearest_vertex_dof)
            raise ValueError("a lumped magnet off the mesh vertices")

    def project(self, X: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """:meth:`matid.rod.system.RodSystem.project` of the states X[rows]: each node's q on |q| = 1."""
        if rows.any():
            U = self.expand(X[rows]).reshape(int(rows.sum()), -1, NF)
            U[..., 3:] /= np.linalg.norm(U[..., 3:], axis=2, keepdims=True)
            X[rows] = U.reshape(U.shape[0], -1)[:, self.disc.free]
        return X

    def evaluate(self, X, lam, *, tangent=True, stress=None, want_strain=False):
        """(R (N, n free), block-tridiagonal tangent or None, strain) at states X, load factors lam (N,)."""
        d, N = self.disc, X.shape[0]
        U = self.expand(X)
        z = self.point_values(U)  # (N, ne, nq, 14)
        g, H, strain = self._kernel(z, lam, tangent, stress, want_strain)
        if self.loaded["maps"]:  # the field on the magnetisation, each scene's B
            gq, Hq = full.magnet(
                z.reshape(-1, 14)[:, 3:7], None, kin.NORMALISED, M=self.maps.reshape(-1, 4, 4)
            )
            lam3 = np.broadcast_to(lam[:, None, None], z.shape[:-1]).reshape(-1)
            g[..., 3:7] += (lam3[:, None] * gq).reshape(g.shape[:-1] + (4,))
            if H is not None:
                H[..., 3:7, 3:7] += (lam3[:, None, None] * Hq).reshape(H.shape[:-2] + (4, 4))
        if self.loaded["f"]:
            g[..., :3] -= (lam[:, None] * self.f)[:, None, None, :]
        R = self.residual(g, lam)
        Rn, blocks = self._nodal(U.reshape(N, d.nscalar, NF)[..., 3:], lam, tangent)
        R.reshape(N, d.nscalar, NF)[..., 3:] += Rn
        T = None
        if tangent:
            K = self._elements(H)
            lay = self.chain
            K[2, 2, 3:, 3:] += blocks[:, lay.mids].transpose(2, 3, 1, 0)  # each mid-node in its element
            vertex = np.zeros((NF, NF, lay.ne + 1, N))
            vertex[3:, 3:] = blocks[:, lay.vertices].transpose(2, 3, 1, 0)
            T = Chain(K, lay, vertex_blocks=vertex)
        return R[:, d.free], T, strain

    def _kernel(self, z, lam, tangent, stress, want_strain) -> tuple:
        """:func:`matid.physics.full.derivatives` of every scene (g, H, strain), KERNEL_POINTS at a time."""
        N, per = z.shape[0], z[0, ..., 0].size
        step = max(1, KERNEL_POINTS // per)
        kappa = lam[:, None, None, None] * self.kappa
        opts = {"want_strain": want_strain, "variant": kin.NORMALISED}
        g, H = np.empty(z.shape), np.empty(z.shape + (14,)) if tangent else None
        strain = (
            (np.empty(z.shape[:-1] + (6,)), np.empty(z.shape[:-1] + (6, 14)))
            if want_strain and tangent
            else None
        )
        for j in range(0, N, step):
            part = slice(j, j + step)
            props = {k: v[part] for k, v in self.props.items()}
            S = None if stress is None else stress[part]
            out = full.derivatives(
                z[part], 1.0, props, kappa[part], None, (0.0, 0.0, 0.0), tangent, stress=S, **opts
            )
            g[part] = out[0]
            if tangent:
                H[part] = out[1]
            if strain is not None:
                strain[0][part], strain[1][part] = out[2]
        return g, H, strain

    def _nodal(self, Q: np.ndarray, lam: np.ndarray, tangent: bool) -> tuple:
        """Residual (N, nscalar, 4) and 4 x 4 blocks (N, nscalar, 4, 4) on the q of every node: the
        unity gauge (:class:`matid.rod.terms.UnityGauge`) and the lumped magnets (:class:`Magnets`)."""
        c_u = self.c_u[:, None, None]
        e = np.einsum("nka,nka->nk", Q, Q) - 1.0
        R = (2.0 * c_u) * e[..., None] * Q
        H = None
        if tangent:
            H = (4.0 * c_u[..., None]) * (Q[..., :, None] * Q[..., None, :])
            H[..., np.arange(4), np.arange(4)] += (2.0 * c_u) * e[..., None]
        if self.loaded["lumped_maps"]:
            v = self.chain.vertices
            gm, hm = full.magnet(
                Q[:, v].reshape(-1, 4), None, kin.NORMALISED, M=self.lumped_maps.reshape(-1, 4, 4)
            )
            R[:, v] += lam[:, None, None] * gm.reshape(self.N, v.size, 4)
            if tangent:
                H[:, v] += lam[:, None, None, None] * hm.reshape(self.N, v.size, 4, 4)
        return R, H

    def _elements(self, H: np.ndarray) -> np.ndarray:
        """The element matrices (3, 3, 7, 7, ne, N) [k, l, i, j] in the chain's local node order:
        :meth:`matid.rod.fem.Discretisation.element_blocks` of every scene in one product."""
        d, N = self.disc, H.shape[0]
        ne, nq, nloc = d.ne, H.shape[2], d.edofs.shape[0]
        H4 = H.reshape(N, ne, nq, 2, NF, 2, NF).transpose(1, 2, 3, 5, 4, 6, 0).reshape(ne, nq * 4, -1)
        Ke = np.matmul(d.element_tables.transpose(0, 2, 1), H4).reshape(ne, nloc, nloc, NF, NF, N)
        local = self.chain.local
        return np.ascontiguousarray(Ke[:, local][:, :, local].transpose(1, 2, 3, 4, 0, 5))
