"""Same answers as another tree? Every scene of a seeded list solved by two matid trees, compared.

    python benchmarks/warm_chord_safety.py [--quick] [--seed N] [--json OUT] [--before /work/wt/final]
                                           [--unprojected] [--audit] [--paths]

(issue 32: the quartic warm starts, the chord confirmation, the gauge projection and the skipped
contact rounds, against main.) The script writes the scenes to a file and runs itself twice as a
worker (``--worker TREE``), once with PYTHONPATH=--before ("main") and once with this tree
("branch"), both at the same time; each worker solves every scene with ``matid.rod.solve`` under a
per-scene CPU limit and records the outcome (solved, ConvergenceError and its message, any other
exception), the tip / L, the discretisation error, the meshes of the error estimate, the warnings,
RodSystem.evaluate calls (tangent / residual-only), the confirmations that failed and solved the
mesh again (``redo``: cantilever.equilibrium called through Equilibrium.confirmed) and the process
CPU. The table compares them per scene family; every scene whose outcome differs, or whose tips are
further apart than the larger of the two discretisation errors, is listed with its scene.

Families: planar magnetic cantilevers (q = mu B L^2/E_b 0.1..500, field 0..180 deg, E_s, E_e
1e2..1e8 E_b/L^2), planar tip forces (alpha 0.1..50, 0..180 deg, many near buckling at 180), planar
compositions (partial magnetisation, magnets, point loads, distributed forces, segments of other
stiffness, rigid or precurved, precurved rods, tip moments), 3D ones, walls and lumens, [advance] and
[aim] (from examples/scenes), every example scene, scenes of the others with fixed elements, and
(a second stage) near_fold: each scene main's continuation stopped on, loaded to just short of the
load factor it reached (FOLD_SHORT), where the stability test's tangent is nearly singular.

``--unprojected`` adds a third run, this tree with newton.PROJECT_ABOVE = inf (338edff's gauge
projection off), to tell its effects from the others'. ``--audit`` takes every stability verdict of
check_admissible (cantilever's: confirmations and warm starts; newton.follow's: each load step)
twice, with Newton's factor (one correction before the state) and afresh with the consistent tangent
at the state, and counts disagreements. ``--paths`` solves each scene whose trees disagree (outcome,
or tips PATH_APART apart) again along the quasi-static path, and says whose answer is on it.

Measured (issue 32, main 22fbcf1 against da72bb7, seeds 32-47, 26211 scenes, 2026-11-29): without
the projection, main's outcome in all but 5 scenes and tips within 6.3e-12 L (5.1e-10 with fixed
coarse meshes) on the same meshes (the 5:
round-off of the regrouped planar.derivatives at a bifurcation, where the continuation accepts an
unstable state: tests/rod/test_continuation_stability.py); with it, 8 more new failures and 59 more
new solves, all full-model, 50 of the 63 new solves where load steps of 0.02 fail as well (--paths),
and 3 answers on another branch (main's the one off the small-step path in 2). The confirmations'
verdicts (--audit) differ from the fresh ones in the same scenes as main's.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
L, E_B, B = 0.03, 9e-5, 0.04  # the bench's rod (matid/bench/scenes.py)
SCALE = E_B / L**2  # N: the force scale E_b/L^2
R_O = 0.0005  # the contact scenes' tube radius
#: tips this close (/ L) are the same to round-off, whatever the estimate says (a 1-element rod's 1e-16)
ROUNDOFF = 1e-13
TIMEOUT_S = 60.0
#: set in a worker's environment: newton.PROJECT_ABOVE = inf there (338edff off: --unprojected)
UNPROJECTED = "WARM_CHORD_UNPROJECTED"
#: set in a worker's environment: every stability verdict also taken afresh (--audit)
AUDIT = "WARM_CHORD_AUDIT"
#: set in a worker's environment: no cold start, every load step at most PATH_STEP (--paths)
PATH = "WARM_CHORD_PATH"
PATH_STEP = 0.02
#: --paths: scenes whose outcomes differ or whose tips are this far apart (/ L) are solved again along
#: the quasi-static path, and a tree is "on it" when its tip is this close to that one's
PATH_APART = 1e-3
#: scenes per family in the full run (--quick: about a tenth)
COUNTS = {"magnetic": 380, "tip_force": 220, "planar_mix": 330, "spatial": 170, "contact": 90,
          "advance_aim": 12, "fixed_elements": 280}  # fmt: skip
ANGLES = (0, 15, 30, 45, 60, 90, 120, 150, 160, 170, 172, 175, 177, 178, 179, 179.5, 179.9, 180)


# -- scenes --------------------------------------------------------------------------------------


def _rod(r: random.Random, *, stiff: float | None = None, **extra) -> dict:
    E_s = stiff or 10 ** r.uniform(2, 8)
    E_e = stiff or 10 ** r.uniform(2, 8)
    return {"length": L, "E_b": E_B, "E_t": E_B * r.choice((1.0, 0.7)), "E_s": E_s * SCALE,
            "E_e": E_e * SCALE, **extra}  # fmt: skip


def _angle(r: random.Random) -> float:
    return r.choice(ANGLES) if r.random() < 0.6 else r.uniform(0.0, 180.0)


def _in_plane(size: float, deg: float) -> list[float]:
    a = math.radians(deg)
    return [size * math.sin(a), 0.0, size * math.cos(a)]


def magnetic(r: random.Random) -> dict:
    q = 10 ** r.uniform(-1, math.log10(500))
    stiff = r.choice((1e2, 1e3, 1e4, 1e6, 1e8))
    return {"rod": _rod(r, stiff=stiff), "field": {"B": _in_plane(B, _angle(r))},
            "magnetization": [{"from": 0.0, "to": L, "per_length": q * E_B / (B * L**2)}]}  # fmt: skip


def tip_force(r: random.Random) -> dict:
    if r.random() < 0.35:  # near the Euler load (pi/2)^2 of the compressed straight rod
        alpha, deg = (math.pi / 2) ** 2 * r.uniform(0.9, 1.1), r.choice((180, 180, 179.9, 179.5, 179, 175))
    else:
        alpha, deg = 10 ** r.uniform(-1, math.log10(50)), _angle(r)
    return {"rod": _rod(r, stiff=r.choice((None, 1e8))), "tip": {"force": _in_plane(alpha * SCALE, deg)}}


def _pieces(r: random.Random, k: int) -> list[tuple[float, float]]:
    cuts = sorted(r.choice((r.uniform(0, L), L * r.randint(1, 9) / 10)) for _ in range(2 * k))
    return [(a, b) for a, b in zip(cuts[::2], cuts[1::2], strict=True) if b - a > 1e-4 * L]


def planar_mix(r: random.Random) -> dict:
    raw = {"rod": _rod(r, stiff=r.choice((None, 1e4, 1e8)))}
    if r.random() < 0.3:
        raw["rod"]["precurvature"] = [0.0, r.uniform(-3, 3) * math.pi / L, 0.0]
    if r.random() < 0.6:
        raw["field"] = {"B": _in_plane(B, _angle(r))}
        q = lambda: r.choice((-1, 1)) * 10 ** r.uniform(-1, 1.5)  # noqa: E731
        raw["magnetization"] = [{"from": a, "to": b, "per_length": q() * E_B / (B * L**2)}
                                for a, b in _pieces(r, r.randint(0, 2))]  # fmt: skip
        raw["magnet"] = [{"at": r.choice((L, r.uniform(0.1, 1) * L)), "moment": q() * E_B / (B * L)}
                         for _ in range(r.randint(0, 3))]  # fmt: skip
    if r.random() < 0.4:
        force = lambda: _in_plane(r.uniform(0.1, 5) * SCALE, _angle(r))  # noqa: E731
        raw["point_load"] = [{"at": r.uniform(0.05, 1) * L, "force": force()} for _ in range(r.randint(1, 2))]
    if r.random() < 0.3:
        raw["load"] = {"distributed_force": _in_plane(r.uniform(0.1, 10) * SCALE / L, _angle(r))}
    if r.random() < 0.3:
        raw["tip"] = {"moment": [0.0, r.uniform(-2, 2) * math.pi * E_B / L, 0.0]}
    segments = []
    for a, b in _pieces(r, r.randint(0, 2)):
        kind = r.choice(("stiff", "rigid", "curved"))
        seg = {"from": a, "to": b}
        if kind == "stiff":
            seg["E_b"] = E_B * 10 ** r.uniform(-1, 2)
        elif kind == "rigid":
            seg["rigid"] = True
        else:
            seg["precurvature"] = [0.0, r.uniform(-3, 3) * math.pi / L, 0.0]
        segments.append(seg)
    if segments:
        raw["segment"] = segments
    if len(raw) == 1:
        raw["tip"] = {"force": _in_plane(r.uniform(0.1, 10) * SCALE, _angle(r))}
    return {k: v for k, v in raw.items() if v != []}


def _unit(r: random.Random) -> list[float]:
    v = [r.gauss(0, 1) for _ in range(3)]
    n = math.sqrt(sum(x * x for x in v)) or 1.0
    return [x / n for x in v]


def spatial(r: random.Random) -> dict:
    curv = [r.uniform(-1, 1) * math.pi / L for _ in range(2)] + [r.uniform(-0.5, 0.5) / L]
    raw = {"rod": _rod(r, stiff=r.choice((1e3, 1e4, 1e6)), precurvature=curv)}
    pick = r.sample(("force", "magnetisation", "magnet", "moment", "point"), r.randint(1, 3))
    if "force" in pick:
        raw["tip"] = {"force": [x * r.uniform(0.1, 3) * SCALE for x in _unit(r)]}
    if "moment" in pick:
        raw.setdefault("tip", {})["moment"] = [x * r.uniform(0.1, 1.5) * E_B / L for x in _unit(r)]
    if "magnetisation" in pick or "magnet" in pick:
        raw["field"] = {"B": [B * x for x in _unit(r)]}
    if "magnetisation" in pick:
        a = r.choice((0.0, r.uniform(0, 0.8) * L))
        raw["magnetization"] = [{"from": a, "to": L, "per_length": r.uniform(0.3, 8) * E_B / (B * L**2),
                                 "direction": r.choice(([0, 0, 1], _unit(r)))}]  # fmt: skip
    if "magnet" in pick:
        raw["magnet"] = [{"at": L, "moment": r.uniform(0.3, 5) * E_B / (B * L), "direction": _unit(r)}]
    if "point" in pick:
        force, moment = r.uniform(0.1, 2) * SCALE, r.uniform(0, 1) * E_B / L
        raw["point_load"] = [{"at": r.uniform(0.2, 0.9) * L, "force": [x * force for x in _unit(r)],
                              "moment": [x * moment for x in _unit(r)]}]  # fmt: skip
    if r.random() < 0.25:
        raw["segment"] = [{"from": 0.9 * L, "to": L, "rigid": True}]
    return raw


def contact(r: random.Random) -> dict:
    q, deg = r.uniform(1, 10), r.choice((60, 90, 120, 150))
    rod = _rod(r, stiff=r.choice((1e4, 1e8)), outer_diameter=2 * R_O)
    raw = {"rod": rod, "field": {"B": _in_plane(B, deg)}}
    if r.random() < 0.5:
        raw["magnetization"] = [{"from": 0.0, "to": L, "per_length": q * E_B / (B * L**2)}]
    else:
        raw["magnet"] = [{"at": L, "moment": q / 3 * E_B / (B * L)}]
        if r.random() < 0.4:
            raw["segment"] = [{"from": 0.9 * L, "to": L, "rigid": True}]
    kind = r.choice(("wall", "wall", "clamp", "lumen"))
    if kind == "wall":  # a wall at x = w the tip is pushed towards
        raw["wall"] = [{"point": [r.uniform(0.15, 0.8) * L, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}]
    elif kind == "clamp":  # touching the tube at the clamp, at an angle
        a = math.radians(r.uniform(10, 80))
        n = (-math.cos(a), math.sin(a))
        raw["wall"] = [{"point": [-R_O * n[0], 0.0, -R_O * n[1]], "normal": [n[0], 0.0, n[1]]}]
    else:
        raw["lumen"] = {"centreline": [[0, 0, -L], [0, 0, 2 * L]], "radius": R_O * r.uniform(1.01, 4)}
    return raw


def _example(name: str) -> Path:
    return ROOT / "examples" / "scenes" / name


def advance_aim(r: random.Random, i: int) -> dict:
    """Variants of the example scenes with [advance] and [aim] (TOML read, then one value changed)."""
    import tomllib

    name = ("advance_channel.toml", "advance_lumen.toml", "aim.toml")[i % 3]
    raw = tomllib.loads(_example(name).read_text())
    if name == "aim.toml":
        t = math.radians(r.uniform(5, 60))
        raw["aim"]["tip_direction"] = [math.sin(t), 0.0, math.cos(t)]
    else:  # the field's direction in the x-z plane (30 mT)
        a = math.radians(r.uniform(-90, 90) if "channel" in name else r.uniform(60, 120))
        raw["field"]["B"] = [f"{30 * math.sin(a)} mT", "0 mT", f"{30 * math.cos(a)} mT"]
    return raw


def scenes(quick: bool, seed: int = 32) -> list[dict]:
    r, out = random.Random(seed), []
    makers = {"magnetic": magnetic, "tip_force": tip_force, "planar_mix": planar_mix, "spatial": spatial,
              "contact": contact}  # fmt: skip
    for family, count in COUNTS.items():
        n = max(2, count // 10) if quick else count
        for i in range(n):
            if family == "advance_aim":
                out.append({"family": family, "raw": advance_aim(r, i)})
            elif family == "fixed_elements":
                base = makers[r.choice(("magnetic", "tip_force", "planar_mix", "planar_mix", "spatial"))](r)
                out.append({"family": family, "raw": {**base, "elements": r.choice((1, 2, 3, 5, 7, 12))}})
            else:
                out.append({"family": family, "raw": makers[family](r)})
    for path in sorted((ROOT / "examples" / "scenes").glob("*.toml")):
        out.append({"family": "examples", "path": str(path.relative_to(ROOT))})
    for i, s in enumerate(out):
        s["id"] = i
    return out


#: near_fold: a scene main fails on, every load times the last load factor its continuation
#: reached times (1 - d) for each of these d (its state at lam = 1 is then that close to the fold or
#: branch point that stopped it: the stability test's tangent is nearly singular there)
FOLD_SHORT = (0.0, 1e-8, 1e-6, 1e-4, 1e-2)
#: ... and between that and the load factor it failed at (Y + t (Z - Y) for these t: past the fold, or
#: a hair short of it)
FOLD_BETWEEN = (0.5, 0.9)
LAST_FACTOR = re.compile(r"failed at load factor ([0-9.eE+-]+) .*last converged load factor ([0-9.eE+-]+)")


def scaled_loads(raw: dict, f: float) -> dict:
    """The scene dictionary ``raw`` with every load (field, tip, point loads, distributed force) times f."""
    out = json.loads(json.dumps(raw))
    times = lambda v: [f * x for x in v]  # noqa: E731
    if "field" in out:
        out["field"]["B"] = times(out["field"]["B"])
    for key in ("force", "moment"):
        if key in out.get("tip", {}):
            out["tip"][key] = times(out["tip"][key])
        for p in out.get("point_load", []):
            if key in p:
                p[key] = times(p[key])
    if "load" in out:
        out["load"]["distributed_force"] = times(out["load"]["distributed_force"])
    return out


def near_folds(scene_list: list[dict], main: dict) -> list[dict]:
    """The near_fold scenes (FOLD_SHORT) of every scene without walls, [advance] or [aim] that main's
    continuation stopped on, numbered after ``scene_list``."""
    out = []
    for s in scene_list:
        rec, raw = main.get(s["id"], {}), s.get("raw", {})
        found = LAST_FACTOR.search(rec.get("message") or "")
        if not found or float(found.group(2)) <= 0 or {"wall", "lumen", "advance", "aim"} & set(raw):
            continue
        failed, last = float(found.group(1)), float(found.group(2))
        factors = [last * (1.0 - d) for d in FOLD_SHORT] + [last + t * (failed - last) for t in FOLD_BETWEEN]
        for f in factors:
            out.append({"family": "near_fold", "raw": scaled_loads(raw, f), "from": s["id"], "factor": f})
    for i, s in enumerate(out, start=len(scene_list)):
        s["id"] = i
    return out


# -- the worker ----------------------------------------------------------------------------------


class Timeout(Exception):
    pass


def _on_alarm(signum, frame):
    raise Timeout(f"over {TIMEOUT_S:.0f} s of CPU")


def _audited(check, counts: dict, audits: list):
    """cantilever's check_admissible, each call also judged afresh at the state with the consistent
    tangent (reject without Newton's factor; its evaluations and CPU not counted): audits gets
    (admissible with Newton's factor, admissible afresh, CPU of the fresh one) per call, e.g. the
    chord confirmation's verdict (a factor one correction before) against the one it stands for."""
    from matid.rod.newton import NewtonFailure

    def audited(system, X, lam, factor=None):
        t0, saved = time.process_time(), dict(counts)
        # the fresh tangent is the consistent one, and the state's stresses are left as they were
        kept = (system._stress, system._strain)  # noqa: SLF001 - the solver's own state, probed
        system.mixed_reset()
        try:
            check(system, X, lam, None)
            fresh = True
        except NewtonFailure:
            fresh = False
        system._stress, system._strain = kept  # noqa: SLF001
        counts.update(saved)
        spent = time.process_time() - t0
        try:
            check(system, X, lam, factor)
        except NewtonFailure:
            audits.append((False, fresh, spent))
            raise
        audits.append((True, fresh, spent))

    return audited


def worker(scene_file: Path, out_file: Path) -> None:
    """Solve every scene of ``scene_file`` with the matid on sys.path; one JSON line per scene."""
    import numpy as np

    import matid
    import matid.rod.api as api
    import matid.rod.cantilever as cantilever
    from matid.errors import ConvergenceError
    from matid.rod.scenes import load_scene, scene_from_dict
    from matid.rod.system import RodSystem

    counts = {"tangent": 0, "residual": 0, "redo": 0}
    evaluate, equilibrium = RodSystem.evaluate, cantilever.equilibrium

    def counted(self, X, lam, *args, tangent=True, **kw):
        counts["tangent" if tangent else "residual"] += 1
        return evaluate(self, X, lam, *args, tangent=tangent, **kw)

    def redo(*args, **kw):  # api holds its own name: only Equilibrium.confirmed's redo comes here
        counts["redo"] += 1
        return equilibrium(*args, **kw)

    RodSystem.evaluate, cantilever.equilibrium = counted, redo
    audits = []  # (verdict from Newton's factor, verdict from the consistent tangent at the state)
    if os.environ.get(AUDIT):  # the confirmations' and warm starts' verdicts, and the continuation's
        import matid.rod.newton as nw

        cantilever.check_admissible = _audited(cantilever.check_admissible, counts, audits)
        nw.check_admissible = _audited(nw.check_admissible, counts, audits)
    if os.environ.get(UNPROJECTED):  # the branch without 338edff's gauge projection (attribution)
        import matid.rod.newton as nw

        nw.PROJECT_ABOVE = math.inf
    if os.environ.get(PATH):  # the quasi-static path: small load steps from the unloaded rod only
        import functools

        import matid.rod.newton as nw

        nw.MAX_LOAD_STEP = PATH_STEP
        cantilever.cold_start = lambda system: None
        cantilever.follow = functools.partial(nw.follow, first_step=PATH_STEP)
    signal.signal(signal.SIGPROF, _on_alarm)
    with open(out_file, "w") as out:
        out.write(json.dumps({"matid": matid.__file__}) + "\n")
        for s in json.loads(scene_file.read_text()):
            for k in counts:
                counts[k] = 0
            rec, t0 = {"id": s["id"]}, time.process_time()
            signal.setitimer(signal.ITIMER_PROF, TIMEOUT_S)
            try:
                scene = load_scene(ROOT / s["path"]) if "path" in s else scene_from_dict(s["raw"])
                sol = api.solve(scene)
                signal.setitimer(signal.ITIMER_PROF, 0)
                Ls = sol.scene.rod.length
                est = sol.extra.get("error_estimate", {})
                rec.update(outcome="solved", tip=(np.asarray(sol.position[-1]) / Ls).tolist(),
                           error=sol.discretization_error, meshes=est.get("meshes"), elements=sol.elements,
                           warnings=sol.extra.get("warnings", []), model=sol.model)  # fmt: skip
            except Timeout as exc:
                rec.update(outcome="timeout", message=str(exc))
            except ConvergenceError as exc:
                rec.update(outcome="ConvergenceError", message=str(exc))
            except Exception as exc:  # noqa: BLE001 - recorded, compared between the trees
                rec.update(outcome=type(exc).__name__, message=str(exc)[:300])
            finally:
                signal.setitimer(signal.ITIMER_PROF, 0)
            rec.update(cpu=time.process_time() - t0 - sum(a[2] for a in audits), **counts)
            if os.environ.get(AUDIT):
                rec["audit"] = [a[:2] for a in audits]
                rec["audit_differs"] = sum(a[0] != a[1] for a in audits)
            audits.clear()
            out.write(json.dumps(rec) + "\n")
            out.flush()


# -- the comparison ------------------------------------------------------------------------------


def _read(path: Path) -> dict:
    lines = path.read_text().splitlines()
    return {r["id"]: r for r in map(json.loads, lines[1:])}


#: what a finding shows of each tree's record
KEEP = ("outcome", "message", "tip", "error", "meshes", "warnings", "tangent", "residual", "redo", "cpu")


def compare(scene_list: list[dict], main: dict, branch: dict) -> tuple[list[dict], list[dict]]:
    """(rows per family, findings: every scene with a different outcome or tips apart)."""
    fams: dict[str, dict] = {}
    findings = []
    for s in scene_list:
        a, b = main.get(s["id"]), branch.get(s["id"])
        f = fams.setdefault(s["family"], {"family": s["family"], "scenes": 0, "same_outcome": 0, "apart": 0,
                                          "new_failures": 0, "new_solves": 0, "other_differences": 0,
                                          "solved_both": 0, "max_ratio": 0.0, "max_apart": 0.0,
                                          "meshes_differ": 0, "warnings_differ": 0, "redo_main": 0,
                                          "redo_branch": 0, "tangent_main": 0, "tangent_branch": 0,
                                          "residual_main": 0, "residual_branch": 0, "cpu_main": 0.0,
                                          "cpu_branch": 0.0})  # fmt: skip
        f["scenes"] += 1
        if a is None or b is None:
            findings.append({"id": s["id"], "family": s["family"], "what": "missing record", "scene": s})
            continue
        for who, r in (("main", a), ("branch", b)):
            for k in ("tangent", "residual", "redo"):
                f[f"{k}_{who}"] += r[k]
            f[f"cpu_{who}"] += r["cpu"]
        finding = None
        if a["outcome"] == b["outcome"]:
            f["same_outcome"] += 1
            if a["outcome"] == "solved":
                f["solved_both"] += 1
                apart = math.dist(a["tip"], b["tip"])
                big = max(a["error"] or 0.0, b["error"] or 0.0)  # round-off apart: ratio 0
                ratio = apart / big if apart > ROUNDOFF else 0.0
                f["max_apart"], f["max_ratio"] = max(f["max_apart"], apart), max(f["max_ratio"], ratio)
                f["meshes_differ"] += a["meshes"] != b["meshes"]
                f["warnings_differ"] += a["warnings"] != b["warnings"]
                if ratio > 1.0:
                    f["apart"] += 1
                    finding = f"tips {apart:.3g} L apart, {ratio:.3g} x the larger estimate"
                elif a["meshes"] != b["meshes"] or a["warnings"] != b["warnings"]:
                    finding = "meshes or warnings differ"
            elif a.get("message") != b.get("message"):
                f["other_differences"] += 1
                finding = "same outcome, another message"
        elif a["outcome"] == "solved":
            f["new_failures"] += 1
            finding = f"main solves, branch: {b['outcome']}"
        elif b["outcome"] == "solved":
            f["new_solves"] += 1
            finding = f"branch solves, main: {a['outcome']}"
        else:
            f["other_differences"] += 1
            finding = f"main {a['outcome']}, branch {b['outcome']}"
        if finding:
            keep = KEEP
            findings.append({"id": s["id"], "family": s["family"], "what": finding,
                             "main": {k: a.get(k) for k in keep}, "branch": {k: b.get(k) for k in keep},
                             "scene": s.get("raw") or s.get("path")})  # fmt: skip
    return list(fams.values()), findings


def table(rows: list[dict]) -> str:
    head = ("| family | scenes | same outcome | tips apart > estimate (max ratio) | new failures "
            "| new solves | other | meshes differ | warnings differ | tangent evals main -> branch "
            "| residual-only | redo | CPU s main / branch (ratio) |")  # fmt: skip
    lines = [head, "|" + " --- |" * 13]
    total = {k: sum(r[k] for r in rows) for k in rows[0] if k not in ("family", "max_ratio", "max_apart")}
    total.update(family="all", max_ratio=max(r["max_ratio"] for r in rows))
    for r in [*rows, total]:
        ratio = r["cpu_main"] / r["cpu_branch"] if r["cpu_branch"] else float("nan")
        lines.append(
            f"| {r['family']} | {r['scenes']} | {r['same_outcome']} | {r['apart']} ({r['max_ratio']:.2g}) "
            f"| {r['new_failures']} | {r['new_solves']} | {r['other_differences']} | {r['meshes_differ']} "
            f"| {r['warnings_differ']} | {r['tangent_main']} -> {r['tangent_branch']} "
            f"| {r['residual_main']} -> {r['residual_branch']} | {r['redo_main']} -> {r['redo_branch']} "
            f"| {r['cpu_main']:.1f} / {r['cpu_branch']:.1f} ({ratio:.3f}) |"
        )
    return "\n".join(lines)


def _run(scene_list: list[dict], runs: dict[str, tuple[Path, dict]]) -> tuple[dict, dict]:
    """Every run (name: (tree, extra environment)) as a worker at once: (records, matid paths) by name."""
    with tempfile.TemporaryDirectory(prefix="warm_chord_") as tmp:
        scene_file = Path(tmp) / "scenes.json"
        scene_file.write_text(json.dumps(scene_list))
        procs, outs = [], {}
        for who, (tree, extra) in runs.items():
            outs[who] = Path(tmp) / f"{who}.jsonl"
            env = {**os.environ, **extra, "PYTHONPATH": str(tree.resolve())}
            cmd = [sys.executable, __file__, "--worker", str(tree), "--scenes", str(scene_file),
                   "--out", str(outs[who])]  # fmt: skip
            procs.append(subprocess.Popen(cmd, env=env, cwd=tmp))
        if any(proc.wait() for proc in procs):
            raise RuntimeError("a worker failed")
        records = {who: _read(path) for who, path in outs.items()}
        trees = {who: json.loads(path.read_text().splitlines()[0])["matid"] for who, path in outs.items()}
    return records, trees


def on_path(scene_list: list[dict], findings: list[dict], tree: Path) -> None:
    """Each finding whose outcomes differ or whose tips are PATH_APART apart (no walls, [advance] or
    [aim]) gets "path": the outcome and tip of ``tree`` solving it along the quasi-static path (the
    worker's PATH), and for each side whether its answer is on it (tip within PATH_APART)."""
    by_id = {s["id"]: s for s in scene_list}

    def wanted(f):
        a, b, raw = f["main"], f["branch"], by_id[f["id"]].get("raw", {})
        if {"wall", "lumen", "advance", "aim"} & set(raw) or "tip" not in a:
            return False
        apart = a["tip"] and b["tip"] and math.dist(a["tip"], b["tip"]) > PATH_APART
        return a["outcome"] != b["outcome"] or apart

    chosen = [f for f in findings if wanted(f)]
    if not chosen:
        return
    records, _ = _run([by_id[f["id"]] for f in chosen], {"path": (tree, {PATH: "1"})})
    for f in chosen:
        r = records["path"][f["id"]]
        near = {w: r["outcome"] == "solved" and f[w]["outcome"] == "solved"
                and math.dist(r["tip"], f[w]["tip"]) < PATH_APART for w in ("main", "branch")}  # fmt: skip
        f["path"] = {"outcome": r["outcome"], "tip": r.get("tip"), "main_on_it": near["main"],
                     "branch_on_it": near["branch"]}  # fmt: skip


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="about a tenth of the scenes (< 2 min)")
    p.add_argument("--json", type=Path, help="write rows, findings and both trees' records here")
    p.add_argument("--seed", type=int, default=32, help="of the scene list")
    p.add_argument("--before", type=Path, default=Path("/work/wt/final"), help="the tree called main")
    p.add_argument("--after", type=Path, default=ROOT, help="the tree called branch (this one)")
    p.add_argument("--unprojected", action="store_true",
                   help="a third run: the branch with newton.PROJECT_ABOVE = inf (338edff off)")  # fmt: skip
    p.add_argument("--audit", action="store_true",
                   help="every stability verdict of cantilever's check_admissible also taken with the "
                   "consistent tangent at the state (both trees; the disagreements listed)")  # fmt: skip
    p.add_argument("--paths", action="store_true",
                   help="solve each scene whose outcomes differ or whose tips are far apart again "
                   "along the quasi-static path (load steps <= PATH_STEP from the unloaded rod)")  # fmt: skip
    p.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    p.add_argument("--scenes", type=Path, help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.worker:
        worker(args.scenes, args.out)
        return 0
    scene_list, t0 = scenes(args.quick, args.seed), time.perf_counter()
    audit = {AUDIT: "1"} if args.audit else {}
    runs = {"main": (args.before, audit), "branch": (args.after, audit)}
    if args.unprojected:
        runs["unprojected"] = (args.after, {UNPROJECTED: "1", **audit})
    records, trees = _run(scene_list, runs)
    folds = near_folds(scene_list, records["main"])
    if folds:  # second stage: main's failed continuations, loaded up to just short of where they stopped
        more, _ = _run(folds, runs)
        scene_list += folds
        for who in records:
            records[who].update(more[who])
    print(f"{len(scene_list)} scenes (seed {args.seed}), main = {trees['main']}, branch = {trees['branch']}, "
          f"{time.perf_counter() - t0:.0f} s wall\n")  # fmt: skip
    out = {"trees": trees, "scenes": scene_list, "records": records}
    for name in [n for n in runs if n != "main"]:
        rows, findings = compare(scene_list, records["main"], records[name])
        if args.paths:
            on_path(scene_list, findings, args.before)
        print(f"## main -> {name}\n\n{table(rows)}\n\n{len(findings)} scenes differ:")
        for f in findings:
            print(json.dumps(f))
        print()
        out[name] = {"rows": rows, "findings": findings}
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
