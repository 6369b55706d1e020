"""The floor of one scene (issue 32.3): how fast matid's solve could be with a perfect start.

    PYTHONPATH=<checkout> python benchmarks/single_floor.py [--repeats N] [--json OUT]

For the peers of ``matid bench --sections peers`` (matid/bench/peers.py: P1 magnetic cantilever,
P2 Bisshopp-Drucker alpha = 5, P3 45-degree 3D bend), in one process, process CPU, best of N,
with every call on a fresh scene (loads times 1 + 1e-9 i, as the bench) and the three solvers
interleaved call by call (P1 bvp, P1 matid, P1 oracle, P2 bvp, ...):

- ``bvp``: scipy's solve_bvp as the bench calls it (its tolerance calibrated to a 1e-6 tip error);
- ``matid``: ``matid.rod.solve(scene)``, the tip read as the bench reads it;
- ``oracle``: the same meshes and the same Richardson estimate (``refine``), the same Solution
  (``Equilibrium.solution`` with ``strain_warnings``), but each mesh's Newton started from its own
  converged state (``equilibrium(scene, elements=n, start=<that mesh's Equilibrium>)``, computed
  beforehand on another Scene object with the same values, so no per-scene cache is warm). It
  costs the least any start or step strategy can: one Newton evaluation per mesh to confirm
  convergence, its factorisation, and everything outside Newton (scaling, meshes, interpolation,
  the estimate, the Solution). It skips ``contact_rounds``' bookkeeping (no contact in the peers),
  so it is, if anything, optimistic. In the full model (P3) the warm start renormalises each
  nodal q (the gauge leaves |q| != 1 at convergence: first corrections 6e-6 / 8e-7 / 9e-8 at 4 / 8
  / 16 elements), so its Newton takes 2 evaluations per mesh: ``oracle1`` subtracts the second
  at its measured cost (the floor of 1 per mesh).

Evaluations per mesh are counted by wrapping ``RodSystem.evaluate`` in a separate, untimed pass;
the same pass keeps each mesh's system and converged state, on which one Newton iteration
(``mixed_begin``, ``evaluate`` with tangent, ``factor``, ``solve``) and one residual-only
evaluation are timed (best of N). ``outside`` = matid's time minus its evaluations at those
costs; ``need`` = the per-evaluation cost (as a fraction of today's) that would reach each target
with today's evaluation counts and today's outside time; ``need@oracle`` the same with the
oracle's counts (negative: out of reach whatever an evaluation costs); ``us/eval`` = (matid -
oracle) / (its evaluations - the oracle's): what one evaluation costs in the solve with all it
brings along (Newton's bookkeeping, the mixed stress update, predictor, probes); ``allowed`` = the
oracle's evaluations plus (the time the target allows - the oracle's) / us/eval: the evaluations
(tangent and residual-only) a solve may take to reach the target (``evals``: today's count).
"""

from __future__ import annotations

import argparse
import json
import time
from contextlib import contextmanager

import numpy as np

from matid.bench import peers
from matid.rod import system as rod_system
from matid.rod.accuracy import refine
from matid.rod.api import solve
from matid.rod.cantilever import equilibrium
from matid.rod.checks import strain_warnings

TARGETS = {"magnetic": 1.5, "tip_force": 2.0, "precurved_3d": 2.5}


def states(scene, meshes) -> dict:
    """Each mesh's converged Equilibrium, each finer one warm from the last (as solve does)."""
    out, last = {}, None
    for n in meshes:
        out[n] = last = equilibrium(scene, elements=n, start=last)
    return out


def oracle(scene, converged: dict) -> np.ndarray:
    """The tip / L of solve's answer, each mesh's Newton started at its own converged state."""

    def at(n):
        eq = equilibrium(scene, elements=n, start=converged[n])
        return eq, eq.quantities(), eq.runtime_s

    result, est = refine(at, tolerance=scene.tolerance)
    if est.history[-1][0] != max(converged):
        raise RuntimeError("the oracle's estimate stopped on another mesh than solve's")
    estimate = {"method": "richardson", "order": est.order, "meshes": [n for n, _ in est.history]}
    extra = {"error_estimate": estimate, "warnings": strain_warnings(result)}
    sol = result.solution(discretization_error=est.error, extra=extra)
    return np.asarray(sol.position[-1]) / scene.rod.length


def matid_tip(scene) -> np.ndarray:
    return np.asarray(solve(scene).position[-1]) / scene.rod.length


@contextmanager
def counted():
    """Every RodSystem.evaluate: (system, x, tangent) appended to the list yielded."""
    calls, original = [], rod_system.RodSystem.evaluate

    def evaluate(self, X, lam, *, tangent=True, **kw):
        calls.append((self, X, tangent))
        return original(self, X, lam, tangent=tangent, **kw)

    rod_system.RodSystem.evaluate = evaluate
    try:
        yield calls
    finally:
        rod_system.RodSystem.evaluate = original


def per_mesh(calls) -> dict:
    """{elements: [tangent evaluations, residual-only evaluations, its system, last x]}."""
    out: dict = {}
    for system, X, tangent in calls:
        row = out.setdefault(system.disc.ne, [0, 0, None, None])
        row[0 if tangent else 1] += 1
        row[2], row[3] = system, X
    return out


def best(fn, repeats: int) -> float:
    t = np.inf
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        t = min(t, time.process_time() - t0)
    return t


def eval_costs(system, X, repeats: int) -> tuple[float, float]:
    """(one Newton iteration at X: evaluate + factor + solve, one residual-only evaluation), s."""

    def iteration():
        system.mixed_begin()
        R, K = system.evaluate(X, 1.0)
        K.factor().solve(-R)

    return best(iteration, repeats), best(lambda: system.evaluate(X, 1.0, tangent=False), repeats)


def run(repeats: int) -> list[dict]:
    base = peers.problems()
    rows, tols, refs = [], [], []
    for p in base:  # the bench's calibration: the loosest solve_bvp tolerance within 1e-6
        refs.append(p["baseline"].tip(tol=1e-9, nodes=200))
        tols.append(peers.calibrate(p["baseline"], refs[-1]))
    meshes = [solve(p["scene"]).extra["error_estimate"]["meshes"] for p in base]
    times = [dict.fromkeys(("bvp", "matid", "oracle"), np.inf) for _ in base]
    tips = [{} for _ in base]
    for i in range(1, repeats + 1):
        fresh, twin = peers.problems(1.0 + 1e-9 * i), peers.problems(1.0 + 1e-9 * i)
        for k, p in enumerate(fresh):
            converged = states(twin[k]["scene"], meshes[k])
            jobs = {
                "bvp": lambda p=p, k=k: p["baseline"].tip(tol=tols[k]),
                "matid": lambda p=p: matid_tip(p["scene"]),
                "oracle": lambda p=p, c=converged: oracle(p["scene"], c),
            }
            order = list(jobs)[i % 3 :] + list(jobs)[: i % 3]  # each goes first in turn
            for who in order:
                t0 = time.process_time()
                tips[k][who] = jobs[who]()
                times[k][who] = min(times[k][who], time.process_time() - t0)
    for k, p in enumerate(base):
        twin = peers.problems()[k]["scene"]
        with counted() as calls:
            matid_tip(peers.problems()[k]["scene"])
        live = per_mesh(calls)
        converged = states(twin, meshes[k])
        with counted() as calls:
            oracle(peers.problems()[k]["scene"], converged)
        floor = per_mesh(calls)
        cost = {n: eval_costs(row[2], row[3], repeats) for n, row in live.items()}
        rows.append(summary(p["name"], times[k], tips[k], refs[k], live, floor, cost))
    return rows


def summary(name, t, tips, ref, live, floor, cost) -> dict:
    """The row of one problem: ratios, counts, per-evaluation costs and what the target needs."""
    newton = sum(row[0] * cost[n][0] + row[1] * cost[n][1] for n, row in live.items())
    newton_floor = sum(row[0] * cost[n][0] + row[1] * cost[n][1] for n, row in floor.items())
    outside, outside_floor = t["matid"] - newton, t["oracle"] - newton_floor
    spare = sum((row[0] - 1) * cost[n][0] for n, row in floor.items())  # beyond 1 per mesh
    goal = t["bvp"] / TARGETS[name]  # the matid time the target allows
    count, count_floor = (sum(row[0] + row[1] for row in rows.values()) for rows in (live, floor))
    per_eval = (t["matid"] - t["oracle"]) / (count - count_floor)  # in the solve, all it brings along
    return {
        "problem": name,
        "target": TARGETS[name],
        "bvp_ms": 1e3 * t["bvp"],
        "matid_ms": 1e3 * t["matid"],
        "oracle_ms": 1e3 * t["oracle"],
        "bvp/matid": t["bvp"] / t["matid"],
        "bvp/oracle": t["bvp"] / t["oracle"],
        "bvp/oracle1": t["bvp"] / (t["oracle"] - spare),
        "evaluations": {n: row[:2] for n, row in sorted(live.items())},
        "oracle_evaluations": {n: row[:2] for n, row in sorted(floor.items())},
        "iteration_us": {n: 1e6 * c[0] for n, c in sorted(cost.items())},
        "residual_us": {n: 1e6 * c[1] for n, c in sorted(cost.items())},
        "newton_ms": 1e3 * newton,
        "outside_ms": 1e3 * outside,
        "oracle_outside_ms": 1e3 * outside_floor,
        "goal_ms": 1e3 * goal,
        "need": (goal - outside) / newton,
        "evaluation_in_solve_us": 1e6 * per_eval,
        "evaluations_now": count,
        "evaluations_allowed": count_floor + (goal - t["oracle"]) / per_eval,
        "need@oracle": (goal - outside_floor) / newton_floor,
        "tip_error": {who: float(np.max(np.abs(tips[who] - ref))) for who in tips},
    }


def table(rows: list[dict]) -> str:
    lines = [
        "problem       target bvp/matid bvp/oracle oracle1  bvp ms matid ms oracle ms  goal ms  "
        "newton ms outside ms oracle-out ms  need need@oracle evals allowed us/eval"
    ]
    for r in rows:
        lines.append(
            f"{r['problem']:13s} {r['target']:6.1f} {r['bvp/matid']:9.2f} {r['bvp/oracle']:10.2f} "
            f"{r['bvp/oracle1']:7.2f} "
            f"{r['bvp_ms']:7.3f} {r['matid_ms']:8.3f} {r['oracle_ms']:9.3f} {r['goal_ms']:8.3f} "
            f"{r['newton_ms']:10.3f} {r['outside_ms']:10.3f} {r['oracle_outside_ms']:13.3f} "
            f"{r['need']:5.2f} {r['need@oracle']:11.2f} {r['evaluations_now']:5d} "
            f"{r['evaluations_allowed']:7.1f} {r['evaluation_in_solve_us']:6.0f}"
        )
    lines.append("")
    for r in rows:
        lines.append(
            f"{r['problem']:13s} evaluations (tangent, residual) per mesh {r['evaluations']}, oracle "
            f"{r['oracle_evaluations']}; one iteration us {_us(r['iteration_us'])}, residual only us "
            f"{_us(r['residual_us'])}; tip errors "
            + ", ".join(f"{k} {v:.1e}" for k, v in r["tip_error"].items())
        )
    return "\n".join(lines)


def _us(d: dict) -> str:
    return "{" + ", ".join(f"{n}: {v:.0f}" for n, v in d.items()) + "}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30)
    parser.add_argument("--json", help="write the rows here")
    args = parser.parse_args()
    rows = run(args.repeats)
    print(table(rows))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1, default=str)


if __name__ == "__main__":
    main()
