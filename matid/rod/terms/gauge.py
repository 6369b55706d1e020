"""The unity penalty of the normalised full model, node by node (a constraint, not a load).

c_u/2 (|q|^2 - 1)^2 at every node (the point values of q, not the Hermite's slopes) and, on an
element with slopes, c_u/2 (q.q')^2 at each vertex. With directors from q/|q| no energy depends
on |q|: the penalty only fixes that null direction. Applied per node its stiffness does not shrink
with the element size, so load terms coupling into |q| (a dead tip moment) cannot swamp it; the
physical solution is the same for any c_u > 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from matid.rod.models import FULL
from matid.rod.terms.base import Term, q_dofs

_DIAG4 = np.arange(4)
_SWAP = [4, 5, 6, 7, 0, 1, 2, 3]


@dataclass(frozen=True)
class UnityGauge(Term):
    c_u: float

    models = (FULL,)

    def prepare(self, system):
        disc, nf = system.disc, system.disc.nf
        values, slopes = disc.slope_pairs  # Hermite: (q, q') at each vertex
        # every scalar dof a point value (P1, P2): q of all of them in dof order, read by a slice
        every = disc.value_dofs.size == disc.nscalar
        dofs = q_dofs(np.arange(disc.nscalar) if every else disc.value_dofs, nf)
        pairs = np.concatenate([q_dofs(values, nf), q_dofs(slopes, nf)], axis=1)
        slope_pattern = disc.block_pattern(pairs) if values.size else None
        return (None if every else dofs), disc.block_pattern(dofs), pairs, slope_pattern

    def nodal(self, system, prep, U, lam, R, blocks) -> None:
        dofs, pattern, pairs, slope_pattern = prep
        c_u, nf = self.c_u, system.disc.nf
        # q at every node (None: all scalar dofs, by a slice: a fancy index costs 3 times as much)
        Q = U.reshape(-1, nf)[:, 3:7].copy() if dofs is None else U[dofs]
        e = np.einsum("na,na->n", Q, Q) - 1.0
        if dofs is None:
            R.reshape(-1, nf)[:, 3:7] += (2.0 * c_u) * e[:, None] * Q
        else:
            R[dofs] += (2.0 * c_u) * e[:, None] * Q
        H = (4.0 * c_u) * (Q[:, :, None] * Q[:, None, :])
        H.reshape(-1, 16)[:, ::5] += (2.0 * c_u) * e[:, None]  # the diagonals
        blocks.append((pattern, H))
        if slope_pattern is not None:
            Rs, Hs = self._slopes(U, pairs)
            R += Rs
            blocks.append((slope_pattern, Hs))

    def _slopes(self, U: np.ndarray, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """c_u/2 (q.q')^2 at each vertex of an element with slopes (the Hermite): d|q|^2/ds = 0
        there, the slopes' share of the null direction |q| (the values' is the penalty above)."""
        Y = U[pairs]  # (k, 8): q, q'
        q, p = Y[:, :4], Y[:, 4:]
        w = np.einsum("ka,ka->k", q, p)
        swapped = Y[:, _SWAP]  # d(q.q')/d(q, q') = (q', q)
        R = np.zeros_like(U)
        R[pairs] = self.c_u * w[:, None] * swapped
        H = self.c_u * (swapped[:, :, None] * swapped[:, None, :])
        H[:, _DIAG4, _DIAG4 + 4] += self.c_u * w[:, None]
        H[:, _DIAG4 + 4, _DIAG4] += self.c_u * w[:, None]
        return R, H
