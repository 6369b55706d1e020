"""Discretisation error estimates and automatic meshing (error against cost).

For a reported quantity Q (tip position over L, bend forces) on meshes of n/2
and n elements, Richardson's estimate of the error of the finer answer is

    e(n) = |Q(n) - Q(n/2)| / (2^p - 1),

with p the observed order from three levels, p = log2(|Q(n/2) - Q(n/4)| / |Q(n) - Q(n/2)|),
capped at the element's asymptotic order (P2 at the mesh vertices: 4,
measured) so that a lucky cancellation never makes the estimate optimistic. The
mesh is doubled until e(n) <= tolerance. The estimate is relative: position
errors are divided by the rod length, forces by the largest force.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: Asymptotic order of P2 (2-point Gauss) at the vertices, measured on the closed forms.
P2_ORDER = 4.0
MAX_ELEMENTS = 4096
#: The first answer of the doubling (its first mesh has half as many elements).
START = 8
#: No estimate claims better than double precision on O(1) scaled quantities.
ROUNDOFF = 1e-14


@dataclass(frozen=True)
class Estimate:
    elements: int
    error: float  # estimated relative discretisation error of the answer at ``elements``
    order: float  # order used in the estimate
    history: tuple[tuple[int, float], ...]  # (elements, runtime_s) of every solve


def richardson(values: list[np.ndarray], cap: float = P2_ORDER) -> tuple[float, float]:
    """(error of the last value, order used) from values on meshes halving in size; the order is
    at most ``cap``."""
    d1 = float(np.abs(values[-1] - values[-2]).max())  # the method: no np.max dispatch (~2 us)
    order = cap
    if len(values) >= 3:
        d0 = float(np.abs(values[-2] - values[-3]).max())
        if d1 > 0 and d0 > d1:
            order = min(cap, float(np.log2(d0 / d1)))
        elif d1 > 0:
            order = 1.0  # not yet converging monotonically: assume the worst plausible order
    return max(d1 / (2.0**order - 1.0), ROUNDOFF), order


def refine(
    solve_at: Callable[[int], tuple[object, np.ndarray, float]],
    *,
    tolerance: float,
    fixed: int | None = None,
    enough: Callable[[object], bool] | None = None,
    cap: Callable[[object], float] | None = None,
    more: Callable[[object], bool] | None = None,
) -> tuple[object, Estimate]:
    """Solve on doubling meshes until the estimated relative error is below ``tolerance``.

    ``solve_at(n)`` returns (solution, relative quantity vector, runtime). With
    ``fixed`` elements, solve there and at half of it, only to report the error.
    ``enough(solution)``: stop the doubling early once it is true (from the second mesh on).
    ``cap(solution)``: the highest order the estimate may assume for the finest solution (default
    P2_ORDER). ``more(solution)``: go on doubling while it is true, below the tolerance too.
    """
    if fixed is not None:
        levels = [max(fixed // 2, 1), fixed] if fixed > 1 else [1, 2]
        results = [solve_at(n) for n in levels]
        error, order = richardson([r[1] for r in results], _cap(cap, results[-1][0]))
        keep = 1 if fixed > 1 else 0
        if keep == 0:  # a single element: the error of it, estimated against 2 elements
            error = float(np.max(np.abs(results[1][1] - results[0][1])))
    else:
        n, results, levels, keep = START // 2, [], [], -1
        while True:
            results.append(solve_at(n))
            levels.append(n)
            if len(results) >= 2:
                error, order = richardson([r[1] for r in results], _cap(cap, results[-1][0]))
                early = enough is not None and enough(results[-1][0])
                done = error <= tolerance and not (more is not None and more(results[-1][0]))
                if done or 2 * n > MAX_ELEMENTS or early:
                    break
            n *= 2
    history = tuple((n, r[2]) for n, r in zip(levels, results, strict=True))
    return results[keep][0], Estimate(levels[keep], error, order, history)


def _cap(cap: Callable[[object], float] | None, solution: object) -> float:
    return P2_ORDER if cap is None else min(P2_ORDER, cap(solution))
