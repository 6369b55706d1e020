"""Newton and the load continuation (matid.rod.newton) on small systems with known roots."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from matid.errors import ConvergenceError
from matid.rod import newton as nw


class Noisy:
    """R(x; lam) = x - lam * target plus an error of fixed size ``noise`` whose pattern changes at
    every evaluation, as round-off does; tangent the identity. ``roundoff``: the floor it reports."""

    def __init__(self, target: np.ndarray, noise: float = 0.0, roundoff: float = 0.0) -> None:
        self.target, self.noise, self.roundoff, self.calls = target, noise, roundoff, 0

    def evaluate(self, x, lam, *, tangent=True):
        self.calls += 1
        wobble = (1.0 + 0.5 * np.sin(7.3 * self.calls)) * np.cos(np.arange(x.size) + self.calls)
        return x - lam * self.target + self.noise * wobble, sp.identity(x.size, format="csc")


def test_newton_reaches_the_root_with_corrections_capped_at_max_step():
    """From 0 to a root 2 away: capped steps of MAX_STEP (0.5) until the full step fits, then exact."""
    target = np.array([2.0, -1.0, 0.5])
    x, its, _ = nw.newton(Noisy(target), np.zeros(3), 1.0)
    np.testing.assert_allclose(x, target, rtol=0, atol=1e-14)
    # corrections 2, 1.5, 1, 0.5 are capped (x moves 0.5 each), the fourth is taken whole, the
    # fifth is 0: converged at iteration 5
    assert its == 5


def test_roundoff_stagnation_is_a_convergence_error_naming_the_last_load_factor():
    """An error of 1e-8 in every residual (above XTOL and the system's floor): Newton's corrections
    stop shrinking at ~1e-8; the continuation stops with a ConvergenceError (not a halved step, not
    another exception) that says so and names the last converged load factor, 0."""
    system = Noisy(np.array([2.0, -1.0, 0.5]), noise=1e-8)
    with pytest.raises(nw.RoundoffStagnation, match="stagnated at corrections of 1"):
        nw.newton(system, np.zeros(3), 1.0)
    with pytest.raises(ConvergenceError, match="stagnated") as caught:
        nw.follow(Noisy(np.array([2.0, -1.0, 0.5]), noise=1e-8), np.zeros(3), [1.0])
    assert caught.value.load_factor == 0.0
    assert "last converged load factor 0" in str(caught.value)


def test_corrections_at_the_systems_roundoff_floor_are_converged():
    """The same 1e-8 error under a floor of 1e-7 (the system says it cannot do better): converged,
    to within the error."""
    target = np.array([2.0, -1.0, 0.5])
    x, info = nw.follow(Noisy(target, noise=1e-8, roundoff=1e-7), np.zeros(3), [1.0])
    np.testing.assert_allclose(x, target, rtol=0, atol=1e-7)
    assert info.steps >= 1


def test_the_continuation_counts_its_load_steps_and_iterations():
    """A linear system from a first step of 0.25: steps 0.25, 0.5 (doubled after an easy step), then
    the rest, 0.25: 3 load steps (solution.json's load_steps), none rejected. Iterations: 2 on the
    first step (one lands, one sees a zero correction), 1 on each later one (the tangent predictor
    of a linear system lands exactly): 4."""
    target = np.array([0.2, -0.1])
    x, info = nw.follow(Noisy(target), np.zeros(2), [1.0], first_step=0.25)
    np.testing.assert_allclose(x, target, rtol=0, atol=1e-15)
    assert (info.steps, info.iterations, info.rejected) == (3, 4, 0)


class Factor:
    def __init__(self, d: np.ndarray) -> None:
        self.d, self.positive_definite = d, bool(np.all(d > 0))

    def solve(self, b: np.ndarray) -> np.ndarray:
        return b / self.d


class Diagonal:
    """A tangent with a ``factor`` method, as rod.band's banded matrices have."""

    def __init__(self, d: np.ndarray) -> None:
        self.d = d

    def factor(self) -> Factor:
        return Factor(self.d)


class Softening:
    """R = (1 - lam) x - lam * 0.1: a spring that softens with the load, stable (positive definite
    tangent 1 - lam) only below lam = 1. Counts its evaluations."""

    def __init__(self) -> None:
        self.calls = 0

    def evaluate(self, x, lam, *, tangent=True):
        self.calls += 1
        return (1.0 - lam) * x - lam * 0.1, Diagonal(np.full(x.size, 1.0 - lam))


def test_the_first_step_is_halved_towards_the_target_while_the_tangent_is_indefinite():
    """Loading from 0 towards 1.6 by 1.2: 1.2 is beyond the limit 1, 0.6 is not. Unloading from
    0.8 towards 0 by 0.5 heads down to 0.3 (stable): the step stays 0.5."""
    x = np.zeros(2)
    assert nw.definite_step(Softening(), x, 0.0, 1.6, 1.2, 1e-6) == 0.6
    assert nw.definite_step(Softening(), x, 0.8, 0.0, 0.5, 1e-6) == 0.5


def test_the_first_newton_iteration_reuses_the_definite_start_probe():
    """With definite_start the probe's residual and factorised tangent are Newton's first
    iteration: the probe costs no evaluation more than a start without it, and the answer is the
    same (x = 0.1 lam / (1 - lam))."""
    runs = {}
    for definite_start in (False, True):
        system = Softening()
        x, info = nw.follow(system, np.zeros(2), [0.5], definite_start=definite_start)
        np.testing.assert_allclose(x, 0.1, rtol=1e-12)
        runs[definite_start] = system.calls
    assert runs[True] == runs[False] == 2


class Reach:
    """R = x - scale lam (a linear system) that rejects any load step longer than ``reach``."""

    def __init__(self, reach: float = np.inf, scale: float = 20.0) -> None:
        self.reach, self.scale, self.last = reach, scale, 0.0

    def evaluate(self, x, lam, *, tangent=True):
        return x - self.scale * lam, sp.identity(x.size, format="csc")

    def reject(self, x, lam, factor):
        if abs(lam - self.last) > self.reach:
            return "too far"
        self.last = lam
        return None


def test_a_failed_step_is_halved_and_the_next_one_doubled():
    """Steps beyond 0.6 fail: the first, the whole load 1.0, fails once; 0.5 converges, and the
    doubled step reaches 1.0: 2 load steps, 1 rejected."""
    x, info = nw.follow(Reach(0.6, scale=1.0), np.zeros(1), [1.0])
    np.testing.assert_allclose(x, 1.0)
    assert (info.steps, info.rejected) == (2, 1)


def test_a_moderately_hard_step_grows_by_half():
    """From a first step of 0.1 (x moves by 2: four capped corrections of 0.5 and a zero one, 5
    iterations, more than FAST): the next step is 1.5 x 0.1, lam 0.25; easy from there (the
    predictor lands): doubled to 0.3, which reaches the target 0.3: 3 load steps."""
    x, info = nw.follow(Reach(), np.zeros(1), [0.3], first_step=0.1)
    np.testing.assert_allclose(x, 6.0)
    assert info.steps == 3 and info.iterations == 5 + 1 + 1


class ScriptedFactor:
    def __init__(self, size: float) -> None:
        self.size = size

    def solve(self, b):
        out = np.zeros(b.size)
        out[-1] = self.size
        return out


class ScriptedTangent:
    def __init__(self, size: float) -> None:
        self.size = size

    def factor(self):
        return ScriptedFactor(self.size)


class Corrections:
    """Newton corrections of the given sizes, one per iteration (the residual is irrelevant)."""

    def __init__(self, sizes) -> None:
        self.sizes = iter(sizes)

    def evaluate(self, x, lam, *, tangent=True):
        return np.zeros(x.size), ScriptedTangent(next(self.sizes))


STALL = [1e-2, 5e-3, 4e-3, 2e-8, 1e-8, 1e-8, 1e-8, 1.2e-8]


def test_stagnation_is_judged_on_the_last_three_corrections():
    """Corrections shrink, then wobble at 1e-8 and grow (1.2e-8 above the last three, all within
    a factor 10): round-off stagnation. An earlier, smaller dip (1e-9 among older corrections)
    leaves the verdict as it is: the last three decide."""
    for sizes in (STALL, STALL[:3] + [1e-9] + STALL[4:]):
        with pytest.raises(nw.RoundoffStagnation):
            nw.newton(Corrections(sizes), np.zeros(2), 1.0)
    with pytest.raises(nw.NewtonFailure, match="diverging: correction 0.02 at iteration 4"):
        nw.newton(Corrections([1e-2, 5e-3, 4e-3, 2e-2]), np.zeros(2), 1.0)


def test_a_non_finite_correction_is_a_newton_failure_that_says_so():
    with pytest.raises(nw.NewtonFailure, match="Newton correction is not finite"):
        nw.newton(Corrections([np.nan]), np.zeros(2), 1.0)


class Lopsided:
    """R = x - lam (0.2, 50) with a step measure that reads only the first unknown (as the bend
    system's reads the displacements and not the multipliers)."""

    def evaluate(self, x, lam, *, tangent=True):
        return x - lam * np.array([0.2, 50.0]), sp.identity(2, format="csc")

    def step_size(self, dx):
        return float(abs(dx[0]))


def test_newton_measures_its_corrections_with_the_systems_step_size():
    """Measured by step_size, the first correction is 0.2 (below MAX_STEP): taken whole, converged
    at the second iteration. (Measured by the largest entry, 50, it would crawl in steps of 0.5.)"""
    x, its, _ = nw.newton(Lopsided(), np.zeros(2), 1.0)
    np.testing.assert_allclose(x, [0.2, 50.0])
    assert its == 2
