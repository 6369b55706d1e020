"""Leave-out: which model and energy terms ran, and what the planar reduction saves.

For each scene the automatic choice (``model="auto"``) runs; for planar scenes
the same scene is also solved with the full (r, q) model, and the time saved
(best of 3 each) and the difference of the answers are reported. The bend runs
the planar half model with contact by construction (no full alternative); a
3D scene runs the full model (nothing to leave out).
"""

from __future__ import annotations

import numpy as np

from matid.bench import scenes as S
from matid.bench.common import best_of
from matid.rod.api import solve
from matid.rod.cantilever import solve_cantilever
from matid.rod.scenes import scene_from_dict

ELEMENTS = 16


def bend_scene():
    """The 10 mm three-point bend of the demo tube as a scene (deflections 0.5 and 1 mm)."""
    E_b, E_s, E_e = S.BEND_E
    g = S.bend_geometry()
    return scene_from_dict(
        {
            "scene": "three_point_bend",
            "rod": {
                "length": g.specimen_length,
                "E_b": E_b,
                "E_t": E_b,
                "E_s": E_s,
                "E_e": E_e,
                "outer_diameter": g.outer_diameter,
            },
            "three_point_bend": {
                "span": g.span,
                "support_radius": g.support_radius,
                "nose_radius": g.nose_radius,
                "deflection": [0.0005, 0.001],
            },
        }
    )


def run(quick: bool = False) -> dict:
    rows = [
        _cantilever("planar magnetic cantilever (q = 6.4, 120 deg)", S.magnetic(6.4, 120.0)),
        _cantilever("tip force (F L^2/E_b = 2)", S.tip_force(2.0)),
        _bend(),
        _cantilever("3D: precurved, tip magnet, tip force", S.spatial(stiff=1e6)),
    ]
    return {
        "rows": rows,
        "elements": ELEMENTS,
        "notes": [
            "Run times are the best of 3; 'time_saved_s' = full model minus the automatic choice "
            "on the same scene and mesh; 'answer_difference' = |tip_auto - tip_full| / L."
        ],
    }


def _cantilever(name: str, scene) -> dict:
    auto, t_auto, _ = best_of(lambda: solve_cantilever(scene, elements=ELEMENTS))
    row = {
        "scene": name,
        "model": auto.model,
        "terms": list(auto.terms),
        "contact": False,
        "elements": ELEMENTS,
        "runtime_s": t_auto,
        "newton_iterations": auto.newton_iterations,
        "load_steps": auto.load_steps,
    }
    if auto.model != "planar":
        return {
            **row,
            "full_runtime_s": None,
            "time_saved_s": 0.0,
            "speedup": None,
            "note": "no plane holds every load: the full model is the only choice",
        }
    full, t_full, _ = best_of(lambda: solve_cantilever(scene, elements=ELEMENTS, model="full"))
    diff = (
        float(np.linalg.norm(np.asarray(auto.position[-1]) - np.asarray(full.position[-1])))
        / scene.rod.length
    )
    return {
        **row,
        "full_terms": list(full.terms),
        "full_runtime_s": t_full,
        "time_saved_s": t_full - t_auto,
        "speedup": t_full / t_auto,
        "full_newton_iterations": full.newton_iterations,
        "full_load_steps": full.load_steps,
        "answer_difference": diff,
        "note": "planar model (x, z, theta): no twist, no quaternion, no unity penalty",
    }


def _bend() -> dict:
    scene = bend_scene()
    sol, runtime, _ = best_of(lambda: solve(scene))
    return {
        "scene": "three-point bend (span 10 mm, d = 1 mm)",
        "model": sol.model,
        "terms": list(sol.terms),
        "contact": "contact" in sol.terms,
        "elements": sol.elements,
        "runtime_s": runtime,
        "newton_iterations": sol.newton_iterations,
        "load_steps": sol.load_steps,
        "full_runtime_s": None,
        "time_saved_s": None,
        "speedup": None,
        "note": "planar half model with sliding contact by construction; no full-model alternative",
    }
