r"""Standard linear solid responses (physics.md section 1), exact for piecewise-linear strain.

A spring k1 in parallel with a Maxwell arm (spring k2 in series with a dashpot eta),
in force units against engineering strain eps, from rest::

    F(t) = k1 eps(t) + f2(t),      f2' + (k2/eta) f2 = k2 eps'(t),      f2(0) = 0

For a strain history linear between samples (rate r_i on [t_{i-1}, t_i]) the update
f2_i = a_i f2_{i-1} + eta r_i (1 - a_i), a_i = exp(-dt_i k2 / eta), is exact; for a
constant-rate ramp eps = r t, F = k1 r t + eta r (1 - exp(-t / tau)). Used by the SLS fit
(:mod:`matid.fits.extension.fit`) and, arm by arm, by the Prony model (:mod:`matid.fits.extension.prony`).
"""

from __future__ import annotations

import math

import numpy as np

#: Blocked exponential sum: span of a block and a step that forgets the past (units of tau).
_BLOCK_SPAN = 300.0
_FORGET = 40.0


def sls_ramp(t: np.ndarray, rate: float, k1: float, k2: float, eta: float) -> np.ndarray:
    """Force of a constant-rate ramp from rest: ``F = k1 r t + eta r (1 - exp(-k2 t / eta))``."""
    t = np.asarray(t, dtype=float)
    return k1 * rate * t - eta * rate * np.expm1(-k2 * t / eta)


def sls_force(t: np.ndarray, eps: np.ndarray, k1: float, k2: float, eta: float) -> np.ndarray:
    """Force ``F = k1 eps + f2`` for a strain history linear between the samples ``(t, eps)``.

    ``f2_i = a_i f2_{i-1} + eta r_i (1 - a_i)`` with ``a_i = exp(-dt_i k2 / eta)``, f2_0 = 0.
    """
    return History(t, eps).force(k1, k2, eta)


class History:
    """A strain history linear between samples, checked and differenced once, for the many
    :func:`sls_force` evaluations of a fit (``sls_force`` is ``History(t, eps).force``)."""

    __slots__ = ("t", "eps", "dt", "deps", "elapsed")

    def __init__(self, t: np.ndarray, eps: np.ndarray) -> None:
        self.t = np.asarray(t, dtype=float)
        self.eps = np.asarray(eps, dtype=float)
        if self.t.ndim != 1 or self.t.shape != self.eps.shape:
            raise ValueError("t and eps must be 1-d arrays of the same length")
        self.dt = np.diff(self.t)
        if np.any(self.dt <= 0):
            raise ValueError("t must be strictly increasing")
        self.deps = np.diff(self.eps)
        self.elapsed = self.t[1:] - self.t[0]

    def force(self, k1: float, k2: float, eta: float) -> np.ndarray:
        """:func:`sls_force` of this history."""
        if not (k2 > 0 and eta > 0):
            raise ValueError(f"k2 and eta must be positive, got k2={k2}, eta={eta}")
        tau = eta / k2
        b = -eta * self.deps / self.dt * np.expm1(-self.dt / tau)  # eta r_i (1 - a_i)
        f2 = np.zeros_like(self.t)
        f2[1:] = _decaying_sum(self.elapsed / tau, b)
        return k1 * self.eps + f2


def _decaying_sum(s: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``g_i = sum_{j<=i} exp(-(s_i - s_j)) b_j`` for non-decreasing s, vectorised.

    The linear recurrence g_i = exp(-(s_i - s_{i-1})) g_{i-1} + b_i, solved as
    exp(-s_i) cumsum(exp(s_j) b_j) inside blocks of span at most _BLOCK_SPAN (no
    overflow, no cancellation between blocks), carrying the last value from block to
    block. After a step longer than _FORGET the past has decayed below round-off, so a
    lone sample there is simply g_i = b_i (this keeps tau << dt vectorised too).
    """
    g = np.empty_like(b)
    if s.size == 0:
        return g
    # np.concatenate rather than np.r_: this runs thousands of times per fit on short runs
    step = np.diff(s)
    if (
        s.size > 1
        and math.floor(s[0] / _BLOCK_SPAN) == math.floor(s[-1] / _BLOCK_SPAN)
        and step.max() <= _FORGET
    ):
        # one block (the usual case: tau within the run): the loop below, run once from i0 = 0
        ds = s - s[0]
        g[:] = np.exp(-ds) * (0.0 + np.cumsum(np.exp(ds) * b))
        return g
    forget = np.concatenate(([True], step > _FORGET))
    new_block = np.concatenate(([True], np.diff(np.floor(s / _BLOCK_SPAN)) > 0))
    starts = np.flatnonzero(forget | new_block)
    ends = np.append(starts[1:], s.size)
    lone = (ends - starts == 1) & forget[starts]
    g[starts[lone]] = b[starts[lone]]
    for i0, i1 in zip(starts[~lone].tolist(), ends[~lone].tolist(), strict=True):
        ds = s[i0:i1] - s[i0]
        head = 0.0 if i0 == 0 else math.exp(s[i0 - 1] - s[i0]) * g[i0 - 1]
        g[i0:i1] = np.exp(-ds) * (head + np.cumsum(np.exp(ds) * b[i0:i1]))
    return g
