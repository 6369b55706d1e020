"""Is Newton's gauge projection (338edff, ``matid.rod.newton.PROJECT_ABOVE``) safe across 3D scenes?

    PYTHONPATH=<checkout> python benchmarks/gauge_projection.py [--quick] [--seed N] [--json OUT]

Each scene is solved twice in one process, each time from a fresh Scene built from its dictionary:
``matid.rod.solve(scene)`` as is, and with ``matid.rod.newton.PROJECT_ABOVE = inf`` (the solver
before the change: Newton never calls ``system.project``). Newton evaluations are counted by
wrapping ``RodSystem.evaluate`` (one call, one scene) and the stacks' ``evaluate`` (one call, its
rows). Per family the table gives: scenes, how many ran the full model, both solved, tips apart by
more than the larger error estimate (|tip - tip'| / L against ``discretization_error``, and the
largest ratio), new failures (ConvergenceError with the projection, solved without), new solves,
evaluations with / without, the scenes with more evaluations with the projection (and fewer).

Families (random draws of a seeded generator; a 30 mm rod with E_b = 9e-5 N m^2 as the bench's,
loads given scaled: alpha = |F| L^2/E_b, m = |M| L/E_b, q = mu |B| L^2/E_b, E_s L^2/E_b ...):

- ``precurved+force``: kappa_ref about d1, d2 or mixed (with twist), |kappa_ref| L in [0, 2 pi], a dead
  tip force in a random direction, alpha log-uniform in [0.1, 30];
- ``force+moment``: the same with a dead tip moment, m in [0.1, 2 pi] (3D: the non-symmetric tangent);
- ``distributed``: a dead distributed force f L^3/E_b in [0.1, 30], random direction, some with a
  tip force;
- ``magnetic``: magnetisation along d3 or directed, over the rod or its distal part, or lumped tip
  magnets (along d3 or directed); q in [0.3, 20] (buckling at 180 degrees is about 2.5), the field up
  to 180 degrees from the rod in a random azimuth; some precurved;
- ``segments``: 2-3 segments of E_b 0.3-3 times the rod's, E_t/E_b in [0.1, 3], E_s L^2/E_b and
  E_e L^2/E_b log-uniform in [1e2, 1e8], precurved, a tip force;
- ``aim``: examples/scenes/aim.toml's rod and magnet (some precurved, some directed) aimed at a random
  tip direction up to 100 degrees off the axis at |B| in [0.05, 1] T (its forward solves are full-model
  Newtons; its cold starts a FullStack); the answer is within the aim's tolerance, not the estimate;
- ``examples``: examples/scenes/*.toml that run the full model (and aim.toml);
- ``solve_many``: 12 scenes of each family above and 30 planar ones through ``matid.rod.solve_many``
  (it stacks the planar cantilevers: their ``Stack.project`` is the identity, so only the full
  scenes, which it solves one by one, can change);
- ``FullStack``: stackable full-model scenes of the families at 8 elements as one
  :class:`matid.rod.batch_full.FullStack` through :func:`matid.rod.batch.follow` (as [aim]'s cold
  starts: the only caller of the full stack), tips against each other.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import time
from pathlib import Path

import numpy as np

import matid.rod.newton as nw
from matid.errors import ConvergenceError, MatidError
from matid.physics import kinematics as kin
from matid.rod import batch, batch_full, solve, solve_many
from matid.rod import system as rod_system
from matid.rod.api import resolve_model
from matid.rod.cantilever import mesh, prepare_scene
from matid.rod.models import FULL
from matid.rod.scenes import load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parent.parent
L, E_B = 0.03, 9e-5
B_T = 0.04  # field strength of the magnetic scenes, T
SCALE = E_B / L**2  # force unit E_b/L^2


@contextlib.contextmanager
def counted():
    """Counts of RodSystem.evaluate calls and of stack rows evaluated, while inside."""
    count = {"system": 0, "stack": 0}
    originals = {
        (rod_system.RodSystem, "system"): rod_system.RodSystem.evaluate,
        (batch.Stack, "stack"): batch.Stack.evaluate,
        (batch_full.FullStack, "stack"): batch_full.FullStack.evaluate,
    }

    def wrap(original, key):
        def evaluate(self, X, *args, **kw):
            count[key] += 1 if key == "system" else int(np.shape(X)[0])
            return original(self, X, *args, **kw)

        return evaluate

    for (cls, key), original in originals.items():
        cls.evaluate = wrap(original, key)
    try:
        yield count
    finally:
        for (cls, _), original in originals.items():
            cls.evaluate = original


@contextlib.contextmanager
def projection(on: bool):
    """PROJECT_ABOVE as committed (on) or inf (off: the solver before the change)."""
    saved = nw.PROJECT_ABOVE
    if not on:
        nw.PROJECT_ABOVE = math.inf
    try:
        yield
    finally:
        nw.PROJECT_ABOVE = saved


# -- the families -----------------------------------------------------------------------------------


def _unit(rng) -> list[float]:
    v = rng.normal(size=3)
    return list(v / np.linalg.norm(v))


def _loguniform(rng, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _rod(rng, *, stiff: float | None = None, **extra) -> dict:
    stiff = stiff if stiff is not None else _loguniform(rng, 1e3, 1e6)
    E_t = rng.uniform(0.5, 1.5) * E_B
    return {"length": L, "E_b": E_B, "E_t": E_t, "E_s": stiff * SCALE, "E_e": stiff * SCALE, **extra}


def _precurvature(rng, kind: str | None = None, top: float = 2 * math.pi) -> list[float]:
    kind = kind or rng.choice(["d1", "d2", "mixed"])
    k = rng.uniform(0.0, top) / L
    if kind == "d1":
        return [k, 0.0, 0.0]
    if kind == "d2":
        return [0.0, k, 0.0]
    a = rng.uniform(0, 2 * math.pi)
    return [k * math.cos(a), k * math.sin(a), rng.uniform(-1.0, 1.0) / L]


def precurved_force(rng) -> dict:
    alpha = _loguniform(rng, 0.1, 30.0)
    rod = _rod(rng, precurvature=_precurvature(rng))
    return {"rod": rod, "tip": {"force": [alpha * SCALE * c for c in _unit(rng)]}}


def force_moment(rng) -> dict:
    raw = precurved_force(rng)
    m = rng.uniform(0.1, 2 * math.pi)
    raw["tip"]["moment"] = [m * E_B / L * c for c in _unit(rng)]
    return raw


def distributed(rng) -> dict:
    f = _loguniform(rng, 0.1, 30.0) * E_B / L**3
    raw = {
        "rod": _rod(rng, precurvature=_precurvature(rng, top=math.pi)),
        "load": {"distributed_force": [f * c for c in _unit(rng)]},
    }
    if rng.random() < 0.4:
        raw["tip"] = {"force": [_loguniform(rng, 0.1, 5.0) * SCALE * c for c in _unit(rng)]}
    return raw


def _field(rng, top_deg: float = 180.0) -> list[float]:
    psi, phi = math.radians(rng.uniform(0.0, top_deg)), rng.uniform(0, 2 * math.pi)
    return [B_T * math.sin(psi) * math.cos(phi), B_T * math.sin(psi) * math.sin(phi), B_T * math.cos(psi)]


def magnetic(rng) -> dict:
    q = _loguniform(rng, 0.3, 20.0)
    raw = {"rod": _rod(rng), "field": {"B": _field(rng)}}
    if rng.random() < 0.5:
        raw["rod"]["precurvature"] = _precurvature(rng, top=math.pi)
    kind = rng.choice(["along", "directed", "magnet", "magnet_directed"])
    if kind in ("along", "directed"):
        start = 0.0 if rng.random() < 0.5 else rng.uniform(0.3, 0.8) * L
        piece = {"from": start, "to": L, "per_length": q * E_B / (B_T * L**2)}
        if kind == "directed":
            piece["direction"] = _unit(rng)
        raw["magnetization"] = [piece]
    else:
        magnet = {"at": L, "moment": q * E_B / (B_T * L)}
        if kind == "magnet_directed":
            magnet["direction"] = _unit(rng)
        raw["magnet"] = [magnet]
        if rng.random() < 0.3:
            raw["magnet"].append({"at": 0.5 * L, "moment": 0.5 * q * E_B / (B_T * L)})
    return raw


def segments(rng) -> dict:
    E_s, E_e = _loguniform(rng, 1e2, 1e8), _loguniform(rng, 1e2, 1e8)
    rod = _rod(rng, precurvature=_precurvature(rng, top=math.pi))
    rod.update(E_t=rng.uniform(0.1, 3.0) * E_B, E_s=E_s * SCALE, E_e=E_e * SCALE)
    cuts = sorted(rng.uniform(0.2, 0.8, size=int(rng.integers(1, 3))))
    ends = [0.0, *[c * L for c in cuts], L]
    rod_segments = []
    for a, b in zip(ends[:-1], ends[1:], strict=True):
        seg = {"from": a, "to": b, "E_b": rng.uniform(0.3, 3.0) * E_B}
        if rng.random() < 0.5:
            seg["E_t"] = rng.uniform(0.1, 3.0) * seg["E_b"]
        if rng.random() < 0.3:
            seg["E_s"] = _loguniform(rng, 1e2, 1e8) * SCALE
        rod_segments.append(seg)
    alpha = _loguniform(rng, 0.1, 30.0)
    return {"rod": rod, "segment": rod_segments, "tip": {"force": [alpha * SCALE * c for c in _unit(rng)]}}


def aim(rng) -> dict:
    """examples/scenes/aim.toml's rod and tip magnet (sometimes precurved, directed) aimed at a random
    tip direction up to 100 degrees from the axis, |B| in [0.05, 1] T (q = m |B| L/E_b up to 5.8)."""
    rod = {"length": L, "E_b": 6.5e-5, "E_t": 4.4e-5, "E_s": 21.0, "E_e": 120.0}
    if rng.random() < 0.5:
        rod["precurvature"] = _precurvature(rng, top=math.pi / 2)
    magnet = {"at": L, "moment": 0.0125}
    if rng.random() < 0.3:
        magnet["direction"] = _unit(rng)
    theta, phi = math.radians(rng.uniform(5.0, 100.0)), rng.uniform(0, 2 * math.pi)
    target = [math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)]
    return {
        "rod": rod,
        "magnet": [magnet],
        "aim": {"tip_direction": target, "field_magnitude": rng.uniform(0.05, 1.0)},
    }


FAMILIES = {
    "precurved+force": precurved_force,
    "force+moment": force_moment,
    "distributed": distributed,
    "magnetic": magnetic,
    "segments": segments,
    "aim": aim,
}
#: scenes per family (full run, --quick)
COUNTS = {
    "precurved+force": (260, 12),
    "force+moment": (140, 6),
    "distributed": (140, 6),
    "magnetic": (260, 10),
    "segments": (160, 6),
    "aim": (40, 3),
}


# -- one scene, twice -------------------------------------------------------------------------------


def _once(make, on: bool) -> dict:
    with projection(on), counted() as count:
        t0 = time.process_time()
        try:
            sol = solve(make())
            out = {"tip": np.asarray(sol.position[-1]) / L, "error": sol.discretization_error}
        except ConvergenceError as exc:
            out = {"failure": f"ConvergenceError: {exc}"[:200]}
        except MatidError as exc:
            out = {"failure": f"{type(exc).__name__}: {exc}"[:200], "other": True}
        out["cpu"] = time.process_time() - t0
    out["evals"] = count["system"] + count["stack"]
    return out


def compare(make) -> dict:
    on, off = _once(make, True), _once(make, False)
    row = {"on": on, "off": off}
    if "tip" in on and "tip" in off:
        apart = float(np.max(np.abs(on["tip"] - off["tip"])))
        err = max(on["error"] or 0.0, off["error"] or 0.0)
        row["ratio"] = apart / err if err > 0 else (0.0 if apart == 0 else math.inf)
        row["apart"] = apart
    return row


def summary(name: str, rows: list[dict]) -> dict:
    both = [r for r in rows if "tip" in r["on"] and "tip" in r["off"]]
    new_fail = [r for r in rows if "failure" in r["on"] and "tip" in r["off"]]
    new_solve = [r for r in rows if "tip" in r["on"] and "failure" in r["off"]]
    more = [r for r in both if r["on"]["evals"] > r["off"]["evals"]]
    fewer = [r for r in both if r["on"]["evals"] < r["off"]["evals"]]
    return {
        "family": name,
        "scenes": len(rows),
        "full": sum(r.get("model") == FULL for r in rows),
        "both": len(both),
        "apart": sum(r.get("ratio", 0.0) > 1.0 for r in both),
        "max_ratio": max((r["ratio"] for r in both if "ratio" in r), default=None),
        "max_apart": max((r["apart"] for r in both), default=0.0),
        "new_fail": len(new_fail),
        "new_solve": len(new_solve),
        "evals_on": sum(r["on"]["evals"] for r in both),
        "evals_off": sum(r["off"]["evals"] for r in both),
        "more": len(more),
        "fewer": len(fewer),
        "cpu_on": sum(r["on"]["cpu"] for r in rows),
        "cpu_off": sum(r["off"]["cpu"] for r in rows),
    }


def _family(name: str, make_raw, n: int, rng) -> tuple[list[dict], list[dict]]:
    raws, rows = [], []
    for _ in range(n):
        raw = make_raw(rng)
        try:
            scene = scene_from_dict(raw)
            model = FULL if scene.aim is not None else resolve_model(scene)
        except MatidError as exc:  # a draw outside the schema's bounds: not a solver question
            print(f"  skipped ({name}): {exc}")
            continue
        row = compare(lambda raw=raw: scene_from_dict(raw))
        row.update(scene=raw, model=model)
        raws.append(raw)
        rows.append(row)
    return raws, rows


def examples() -> list[dict]:
    rows = []
    for path in sorted((ROOT / "examples" / "scenes").glob("*.toml")):
        scene = load_scene(path)
        if scene.kind != "cantilever" or (resolve_model(scene) != FULL and scene.aim is None):
            continue
        row = compare(lambda path=path: load_scene(path))
        row.update(scene=path.name, model=FULL)
        rows.append(row)
    return rows


def many(raws: list[dict]) -> dict:
    """solve_many with and without: tips, failures, evaluations (RodSystem calls + stack rows)."""
    runs = {}
    for on in (True, False):
        with projection(on), counted() as count:
            t0 = time.process_time()
            out = solve_many([scene_from_dict(r) for r in raws])
            runs[on] = (out, dict(count), time.process_time() - t0)
    rows = []
    for i, raw in enumerate(raws):
        row = {"scene": raw, "model": resolve_model(scene_from_dict(raw))}
        for on, key in ((True, "on"), (False, "off")):
            s = runs[on][0][i]
            ok = hasattr(s, "position")
            row[key] = (
                {"tip": np.asarray(s.position[-1]) / L, "error": s.discretization_error}
                if ok
                else {"failure": str(getattr(s, "reason", s))[:200]}
            )
            row[key].update(evals=0, cpu=0.0)
        if "tip" in row["on"] and "tip" in row["off"]:
            row["apart"] = apart = float(np.max(np.abs(row["on"]["tip"] - row["off"]["tip"])))
            err = max(row["on"]["error"] or 0.0, row["off"]["error"] or 0.0)
            row["ratio"] = apart / err if err > 0 else (0.0 if apart == 0 else math.inf)
        rows.append(row)
    s = summary("solve_many", rows)
    s.update(
        evals_on=sum(runs[True][1].values()),
        evals_off=sum(runs[False][1].values()),
        stack_rows_on=runs[True][1]["stack"],
        stack_rows_off=runs[False][1]["stack"],
        cpu_on=runs[True][2],
        cpu_off=runs[False][2],
        more=None,
        fewer=None,
    )
    return s, rows


def full_stack(raws: list[dict], elements: int = 8) -> tuple[dict, list[dict]]:
    """Stackable full-model scenes as one FullStack through batch.follow, with and without."""
    scenes = [scene_from_dict(r) for r in raws]
    keep = [i for i, s in enumerate(scenes) if batch_full.stackable(prepare_scene(s, FULL)[3])]
    disc = mesh(elements, (1.0,), 7, "P2", 2)
    tip = disc.vertex_dof(disc.vertices.size - 1)
    runs = {}
    for on in (True, False):
        parts = [prepare_scene(scene_from_dict(raws[i]), FULL)[2:4] for i in keep]
        stack = batch_full.FullStack(disc, parts)
        with projection(on), counted() as count:
            t0 = time.process_time()
            X, _, _, reasons = batch.follow(stack, stack.reference())
            runs[on] = (
                stack.expand(X).reshape(len(keep), disc.nscalar, 7),
                reasons,
                count["stack"],
                time.process_time() - t0,
            )
    rows = []
    for j, i in enumerate(keep):
        row = {"scene": raws[i], "model": FULL}
        for on, key in ((True, "on"), (False, "off")):
            U, reasons = runs[on][0], runs[on][1]
            row[key] = (
                {"tip": U[j, tip, :3], "d3": np.array(kin.d3(U[j, tip, 3:].tolist())), "error": None}
                if reasons[j] is None
                else {"failure": reasons[j]}
            )
            row[key].update(evals=0, cpu=0.0)
        if "tip" in row["on"] and "tip" in row["off"]:
            row["apart"] = float(np.max(np.abs(row["on"]["tip"] - row["off"]["tip"])))  # no estimate
        rows.append(row)
    s = summary("FullStack (8 el.)", rows)
    s.update(
        evals_on=runs[True][2],
        evals_off=runs[False][2],
        cpu_on=runs[True][3],
        cpu_off=runs[False][3],
        more=None,
        fewer=None,
    )
    return s, rows


# -- output ----------------------------------------------------------------------------------------


def table(sums: list[dict]) -> str:
    head = (
        "| family | scenes | full | both solved | tips apart | max ratio | new failures | new solves "
        "| max tip apart / L | evals with / without | more evals | fewer evals | CPU s with / without |"
    )
    lines = [head, "|" + " --- |" * 13]
    for s in sums:
        more = "-" if s["more"] is None else s["more"]
        fewer = "-" if s["fewer"] is None else s["fewer"]
        ratio = "-" if s["max_ratio"] is None else f"{s['max_ratio']:.3g}"
        lines.append(
            f"| {s['family']} | {s['scenes']} | {s['full']} | {s['both']} | {s['apart']} | {ratio} "
            f"| {s['new_fail']} | {s['new_solve']} | {s['max_apart']:.2g} "
            f"| {s['evals_on']} / {s['evals_off']} | {more} | {fewer} "
            f"| {s['cpu_on']:.1f} / {s['cpu_off']:.1f} |"
        )
    return "\n".join(lines)


def _jsonable(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return x


def notable(rows: list[dict]) -> list[dict]:
    """New failures, new solves, tips apart, more evaluations."""
    out = []
    for r in rows:
        on, off = r["on"], r["off"]
        why = []
        if "failure" in on and "tip" in off:
            why.append(f"new failure: {on['failure']}")
        if "tip" in on and "failure" in off:
            why.append(f"new solve (without: {off['failure']})")
        if r.get("ratio", 0.0) > 1.0:
            why.append(f"tips apart: ratio {r['ratio']:.3g}")
        if "tip" in on and "tip" in off and on["evals"] > off["evals"]:
            why.append(f"evals {on['evals']} > {off['evals']}")
        if why:
            out.append({"why": why, "scene": r["scene"], "model": r.get("model")})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="a few scenes per family (under a minute)")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--json", type=Path, help="write every scene's result here")
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    t0 = time.process_time()
    sums, every, pool, planar = [], {}, [], []
    for name, make_raw in FAMILIES.items():
        raws, rows = _family(name, make_raw, COUNTS[name][1 if args.quick else 0], rng)
        sums.append(summary(name, rows))
        every[name] = rows
        if name != "aim":  # [aim] runs alone
            pool += raws[: 3 if args.quick else 12]
            planar += [r["scene"] for r in rows if r["model"] != FULL]
        print(f"  {name}: {len(rows)} scenes, {time.process_time() - t0:.0f} s CPU so far", flush=True)
    rows = examples()
    sums.append(summary("examples (full)", rows))
    every["examples"] = rows
    s, rows = many(pool + planar[: 6 if args.quick else 30])
    sums.append(s)
    every["solve_many"] = rows
    stackable = [r for r in pool if resolve_model(scene_from_dict(r)) == FULL]
    s, rows = full_stack(stackable)
    sums.append(s)
    every["FullStack"] = rows
    print(table(sums))
    m, names = sums[-2], ", ".join(r["scene"] for r in every["examples"])
    rows_on, rows_off = m["stack_rows_on"], m["stack_rows_off"]
    print(
        f"\nsolve_many: stacked rows {rows_on} / {rows_off} (with / without; the planar stack's project is "
        f"the identity), RodSystem evaluations {m['evals_on'] - rows_on} / {m['evals_off'] - rows_off}; "
        f"examples run: {names}"
    )
    print(f"\n{time.process_time() - t0:.0f} s CPU in all")
    for name, rows in every.items():
        for item in notable(rows):
            why, scene = "; ".join(item["why"]), json.dumps(_jsonable(item["scene"]))
            print(f"- {name} ({item['model']}): {why}\n  {scene}")
    if args.json:
        args.json.write_text(json.dumps(_jsonable({"summary": sums, "rows": every}), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
