"""Is a converged state of the clamped rod stable? (contract section 9, physics.md section 8)

**Conservative loads** (the tangent K is a Hessian, symmetric): stable iff K is positive definite
on the free dofs: a successful banded Cholesky, read off Newton's last factorisation
(:class:`matid.rod.band.BandFactor`), or no non-positive pivot of L D L^T (:func:`ldl_negative`).
A saddle (two negative eigenvalues, det K > 0) is refused; a sign change of det K would miss it.

**Loads without a potential** (a dead moment in 3D): no energy, so no second variation decides.
The criterion is Lyapunov's indirect method on the linearised *overdamped* dynamics
D dx/dt = -K dx: the state is stable iff every eigenvalue of the pencil (K, D) has a positive
real part (:func:`unstable_modes`). For a non-conservative load that verdict depends on the
dissipation D (Ziegler's destabilisation by damping, 1952; Kirillov, Nonconservative Stability
Problems of Modern Physics, 2013, ch. 1), so D is stated, that of a slender tube in a viscous
medium (resistive-force theory, Gray & Hancock 1955; Batchelor 1970): isotropic translational
drag per length, and a rotational drag per length smaller by ~(a/L)^2 (tube radius a): D is the
L2 Gram matrix of the basis on r and ROTARY_DRAG times it on q. The eigenvalues of K alone have
no such meaning (a change of coordinates is a congruence J^T K J, which keeps the pencil's
eigenvalues, not those of a non-symmetric K).

Measured (16 P2 elements, dead tip moment about (1, 1, 0.5), E_s L^2/E_b = E_e L^2/E_b = 1e8):
at M L/E_b = 5.2 the lowest real part of the pencil is +52.5 with ROTARY_DRAG = 1e-4 and 1e-6
(the slender limit, reached), +53.6 at 1e-3, -7.0 with equal drags (1), -0.22 for K alone; the
symmetric part is indefinite from M L/E_b ~ 2.25 on (Hill's positive second-order work, which
refused the state before). At M L/E_b = 10 a complex pair crosses between load factors 0.6 and
0.7 (real part +46.8, then -6.7): refused there. The tip magnet with a small twist lands on a
saddle with two real eigenvalues near -5.7e3: refused under any D.

Cheap path: a positive definite symmetric part (K + K^T)/2 gives Re lambda > 0 for every D
(Re x* K x > 0), so the eigenvalues are computed only when its L D L^T has a non-positive pivot.
Up to DENSE free dofs all eigenvalues (LAPACK QZ); beyond, the NEAREST ones to zero by ARPACK in
shift-invert mode on the factorised tangent. The gauge direction |q| of the normalised model is
held by the unity penalty (eigenvalue ~ 4 c_u / ROTARY_DRAG: positive, far from the physical ones).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spla

#: Rotational over translational drag per length (scaled): ~(a/L)^2 of a slender tube, a/L ~ 1e-2.
ROTARY_DRAG = 1e-4
#: All eigenvalues up to this many free dofs (LAPACK QZ: 0.2-6 s at 224 on this machine under
#: load); ARPACK beyond (0.03-0.06 s at 224 and 672, the same unstable pairs to 4 digits).
DENSE = 64
#: ARPACK: this many eigenvalues nearest zero (measured: the pair that crosses at M L/E_b = 10 is
#: within the 4 nearest zero on 16 elements).
NEAREST = 24


def ldl_negative(K: sp.spmatrix) -> int | None:
    """Non-positive pivots of a symmetric K by L D L^T: 0 iff positive definite; None if the test
    cannot be made.

    SuperLU in symmetric mode without off-diagonal pivoting (checked: perm_r == perm_c) computes
    K = L D L^T, and every pivot of D is positive iff K is (for a positive definite K this
    elimination is backward stable, so a pivot <= 0 is no round-off)."""
    try:
        lu = spla.splu(
            sp.csc_matrix(K),
            permc_spec="MMD_AT_PLUS_A",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
    except RuntimeError:  # an exactly zero pivot: singular, a bifurcation point
        return 1
    if not np.array_equal(lu.perm_r, lu.perm_c):
        return None
    return int(np.sum(lu.U.diagonal() <= 0.0))


def drag(disc, rotary: float = ROTARY_DRAG) -> sp.csr_matrix:
    """D on the free dofs of the full model (r, q): the L2 Gram matrix of the basis on each field,
    times ``rotary`` on q (built once per system)."""
    nf = disc.nf
    weights = np.ones(nf)
    weights[3:] = rotary
    H = np.zeros(disc.dx.shape + (2 * nf, 2 * nf))
    H[..., np.arange(nf), np.arange(nf)] = weights
    return disc.tangent(H, True).tocsr()


def unstable_modes(K: sp.spmatrix, D: sp.spmatrix, factor=None) -> np.ndarray:
    """The eigenvalues of the pencil (K, D) with a non-positive real part (empty: stable).

    ``factor``: a callable that factorises K (``.solve``), for the shift-invert of large systems."""
    n = K.shape[0]
    if n <= DENSE:
        w = sl.eigvals(K.toarray(), D.toarray())
    else:
        solve = (factor() if factor is not None else spla.splu(sp.csc_matrix(K))).solve
        inverse = spla.LinearOperator((n, n), matvec=solve, dtype=float)
        w = spla.eigs(
            K, k=min(NEAREST, n - 2), M=D, sigma=0.0, OPinv=inverse, v0=np.ones(n), return_eigenvectors=False
        )
    w = w[np.isfinite(w)]
    return np.sort_complex(w[w.real <= 0.0])
