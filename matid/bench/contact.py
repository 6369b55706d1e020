"""Contact in the bench (issue 31): walls and a lumen, their independent reference, the convergence
rows with contact and the stability catalogue's contact cases.

The reference is the planar elastica of :mod:`matid.bench.references` (shooting, DOP853 at 1e-13)
with the boundary's reaction at the tip: m(0) and P along the wall's normal solved together (hybr)
so that the end moment is met and the tip's gap closes, followed as the loads rise from zero with
the walls in place. Its state is admissible when P >= 0 and the gap along the whole rod (2001
points, and a rigid tip body's end) is >= -GAP_TOL; a scene whose state needs an interior contact
raises (not modelled here). A straight lumen is, in the plane of the loads, the wall x = radius.
Nothing here calls the matid solver.

Every error is the larger of the tip error / L (L of the step under [advance]) and the relative
error of the boundary's reaction (the resultant of matid's contacts on that boundary).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from functools import cache

import numpy as np
from scipy.optimize import root

from matid.bench import scenes as S
from matid.bench.case import Case, refused
from matid.bench.references import Elastica, end_state, shooting
from matid.errors import ConvergenceError
from matid.rod.api import contacts_of, solve
from matid.rod.cantilever import equilibrium
from matid.rod.scenes import scene_from_dict

GAP_TOL = 1e-8  # scaled by the rod's length
PSI = math.radians(120.0)
R = S.R_O / S.L  # the tube's outer radius, scaled
#: The wall of the convergence case: the magnetic cantilever (q = 6.4, 120 deg, free tip x = 0.834 L)
#: stopped at x = 0.75 L (a wall nearer, at 0.6 L, needs P ~ 6 E_b/L^2: near the fold where the
#: pushed tip snaps to -x).
WALL_X = 0.75
#: "contacts switching": a tip magnet (m B L/E_b = 1.5 at L = 30 mm) in a field at 90 deg pushed into a
#: channel 3 mm wide tilted 6 deg towards -x, free lengths (units of L).
CHANNEL_TILT, CHANNEL_HALF, CHANNEL_MAGNET = math.radians(-6.0), 0.05, 1.5
CHANNEL_STEPS = (0.2, 0.4, 0.6, 0.8, 1.0)


def channel_walls() -> list[tuple[np.ndarray, np.ndarray]]:
    """The channel's two walls [(point, normal)] in units of L (x, z): wall 1 at -x, wall 2 at +x."""
    axis = np.array([math.sin(CHANNEL_TILT), math.cos(CHANNEL_TILT)])
    across = np.array([axis[1], -axis[0]])  # +x side of the axis
    return [(-CHANNEL_HALF * across, across), (CHANNEL_HALF * across, -across)]


# -- the reference ---------------------------------------------------------------------------------


def _state(y: np.ndarray, rod: Elastica) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 2) of the centreline incl. a rigid arm's end, tip (x, z, theta)) of y = (theta, m,
    x, z) sampled along the rod."""
    theta = y[0, -1]
    end = y[2:, -1] + rod.arm * np.array([math.sin(theta), math.cos(theta)])
    return np.vstack([y[2:].T, end]), np.array([*end, theta])


def _gaps(points: np.ndarray, walls, R_o: float) -> np.ndarray:
    return np.array([(points - np.asarray(p)) @ np.asarray(n) - R_o for p, n in walls])


def tip_contact(rod: Elastica, walls, R_o: float, steps: int = 16) -> dict:
    """{"tip" (x, z, theta), "force" (Fx, Fz), "wall" (index or None)} of ``rod`` (scaled, loads
    and walls [(point, normal)] in x-z, units of its length) held by the walls, followed as its loads
    rise from zero with the walls in place (the path decides between states): free while the rod
    crosses no wall; once its tip crosses one, on that wall with P >= 0 along its normal
    (:func:`_on_wall`). A load step is halved when a shot fails or the
    free rod would cross a wall by more than ENTRY (the search then starts close to it).
    RuntimeError when the state is not admissible."""
    state, f, df = (0.0, 0.0, None, None), 0.0, 1.0 / steps
    while f < 1.0:
        f1 = min(1.0, f + df)
        part = replace(rod, force=(f1 * rod.force[0], f1 * rod.force[1]), moment=f1 * rod.moment,
                       q=f1 * rod.q, tip_magnet=f1 * rod.tip_magnet)  # fmt: skip
        try:
            new = _load_step(part, walls, R_o, *state[:3])
        except RuntimeError:
            new = None
        if new is None:
            df /= 2.0
            if df < 1e-9:
                raise RuntimeError(f"contact reference: lost at load factor {f:.6g}")
            continue
        state, f, df = new, f1, min(2.0 * df, 1.0 / steps)
    _, P, w, y = state
    points, tip = _state(y, rod)
    g = _gaps(points, walls, R_o)
    if g.min() < -GAP_TOL:
        raise RuntimeError(f"contact reference: the rod crosses a wall (gap {g.min():.3g} L) away from its "
                           "tip: an interior contact, not modelled here")  # fmt: skip
    force = np.zeros(2) if w is None else P * np.asarray(walls[w][1], float)
    return {"tip": tip, "force": force, "wall": w}


ENTRY = 1e-3  # the deepest crossing (scaled) a load step may enter a contact from


def _load_step(rod: Elastica, walls, R_o: float, m0: float, P: float, w: int | None):
    """(m(0), P, wall, y) at ``rod``'s loads from the last state, or None when the step must be halved."""
    if w is None:
        m0, y = shooting(rod, m0)
        g = _gaps(_state(y, rod)[0], walls, R_o)
        if g.min() >= -GAP_TOL:
            return m0, 0.0, None, y
        if g.min() < -ENTRY:
            return None
        w = int(np.argmin(g[:, -1]))
    m0, P, y = _on_wall(rod, walls[w], R_o, m0, P)
    if P < 0:  # the tip leaves the wall again: free, unless the free rod crosses a wall
        m0, y = shooting(rod, m0)
        return (m0, 0.0, None, y) if _gaps(_state(y, rod)[0], walls, R_o).min() >= -GAP_TOL else None
    return m0, P, w, y


def _on_wall(rod: Elastica, wall, R_o: float, m0: float, P0: float) -> tuple[float, float, np.ndarray]:
    """(m(0), P, y) of ``rod`` with its tip on ``wall``: m(0) and the reaction P along the normal
    that meet the end moment and close the tip's gap (hybr from the last state)."""
    normal = np.asarray(wall[1], float)

    def pushed(P: float) -> Elastica:
        return replace(rod, force=tuple(float(v) for v in np.asarray(rod.force) + P * normal))

    def residual(x):
        r = pushed(x[1])
        y = end_state(r, x[0])
        tip = _state(y[:, None], r)[0][-1:]
        return [y[1] - r.end_moment(y[0]), float(_gaps(tip, [wall], R_o)[0, 0])]

    out = root(residual, [m0, P0], method="hybr", options={"xtol": 1e-14})
    if np.abs(out.fun).max() > 1e-12:  # ("xtol too small" at round-off is no failure)
        raise RuntimeError(f"contact reference: the tip on the wall did not converge ({out.message})")
    m0, y = shooting(pushed(out.x[1]), out.x[0])
    return m0, float(out.x[1]), y


@cache
def wall_reference(wall_x: float = WALL_X) -> dict:
    """The magnetic cantilever (q = 6.4, 120 deg) with a wall at x = wall_x L + R_O."""
    return tip_contact(
        Elastica(q=6.4, field_angle=PSI, E_s=S.STIFF, E_e=S.STIFF), [((wall_x + R, 0.0), (-1.0, 0.0))], R
    )


def _boundary_force(sol, name: str) -> np.ndarray:
    """(Fx, Fz) of every contact of ``sol`` on boundary ``name``, scaled by E_b/L^2."""
    F = sum(
        (np.asarray(c["force"]) for c in sol.extra.get("contacts", []) if c["boundary"] == name), np.zeros(3)
    )
    L = sol.scene.rod.length
    return F[[0, 2]] / (sol.scene.rod.E_b / L**2)


def contact_error(ref: dict, name: str) -> Callable[[object], float]:
    """max(|tip - ref| / L, |F - F_ref| / |F_ref|) of a Solution against a :func:`tip_contact` state."""

    def error(sol) -> float:
        L = sol.scene.rod.length
        tip = np.asarray(sol.position[-1])[[0, 2]] / L
        e = float(np.linalg.norm(tip - ref["tip"][:2]))
        F_ref = np.asarray(ref["force"])
        F = _boundary_force(sol, name)
        if np.linalg.norm(F_ref) > 0:
            return max(e, float(np.linalg.norm(F - F_ref) / np.linalg.norm(F_ref)))
        return max(e, float(np.linalg.norm(F)))  # free: no reaction either

    return error


def solve_with_contacts(scene, elements: int = 16, **options):
    """One mesh (as the catalogue's cantilevers), with the contacts in SI in its extra."""
    eq = equilibrium(scene, elements=elements, **options)
    return eq.solution(extra=contacts_of(eq))


def wall_scene(wall_x: float = WALL_X):
    return S.with_contact(S.magnetic_raw(), walls=(S.wall((wall_x + R, 0.0), (-1.0, 0.0)),))


# -- convergence with contact ----------------------------------------------------------------------

CONVERGENCE_SCENE = "tip on a wall"


def convergence_rows(levels: tuple[int, ...], best_of) -> tuple[list[dict], dict]:
    """Rows of the convergence section for the magnetic cantilever held by a wall at x = 0.75 L (P2,
    2-point Gauss: error against elements and run time), and the reference's description."""
    ref = wall_reference()
    scene, error = wall_scene(), contact_error(ref, "wall 1")
    rows = []
    for n in levels:
        row = {
            **dict(scene=CONVERGENCE_SCENE, model="planar", element="P2", quadrature="2-point Gauss"),
            **dict(intorder=2, elements=n, reference=REFERENCE),
        }
        try:
            sol, runtime, _ = best_of(lambda n=n: solve_with_contacts(scene, n))
        except ConvergenceError as exc:
            rows.append(
                {**row, "runtime_s": None, "error": None, "status": f"raised ConvergenceError: {exc}"}
            )
            continue
        solved = dict(model=sol.model, runtime_s=runtime, error=error(sol), status="ok")
        rows.append(
            {**row, **solved, "newton_iterations": sol.newton_iterations, "load_steps": sol.load_steps}
        )
    check = {"method": REFERENCE, "tip_xz": ref["tip"][:2], "reaction_scaled": ref["force"]}
    return rows, check


REFERENCE = (
    "elastica shooting (same E_s, E_e) with the wall's reaction at the tip solved for with m(0) (the tip's "
    "gap closed), loads raised with the wall in place; error = max(tip error / L, relative reaction error)"
)


# -- the stability catalogue's contact cases -------------------------------------------------------

FAMILY = "contact"
MAGNETIC = Elastica(q=6.4, field_angle=PSI, E_s=S.STIFF, E_e=S.STIFF)  # S.magnetic's rod, scaled
LUMEN_GAP = 1.01  # "just wider": the lumen's radius in tube radii
PRESS = 2.0  # F L^2/E_b of the tip force pressing the rod on the wall it lies along
#: The channel of tests/rod/test_contact_reference.py (2 x 4 mm tilted 10 deg, tip magnet 0.01 A m^2
#: in 39 mT at -60 deg, E_b = 6.5e-5 N m^2, tube 2.4 mm), advanced to 100 mm: free, the tip on wall 1,
#: the rod resting on wall 1 behind its tip, then also the tip on wall 2 (that reference's sequence).
SIDES = {"E_b": 6.5e-5, "R_o": 1.2e-3, "half": 4e-3, "tilt": math.radians(10.0), "psi": math.radians(-60.0),
         "B": 0.039, "m": 0.01, "L": 0.1, "free": (0.02, 0.03, 0.05, 0.08, 0.095, 0.1)}  # fmt: skip
SIDE_SETS = ((), ("wall 1",), ("wall 1",), ("wall 1",), ("wall 1", "wall 2"), ("wall 1", "wall 2"))


def _scaled(w: dict) -> tuple:
    return ((w["point"][0] / S.L, w["point"][2] / S.L), (w["normal"][0], w["normal"][2]))


@cache
def _reference(name: str) -> dict:
    """The :func:`tip_contact` state of the catalogue case ``name`` (scaled by L = 30 mm)."""
    if name == "clamp":
        return tip_contact(MAGNETIC, [_scaled(S.touching(45.0))], R)
    if name == "lumen":
        return tip_contact(MAGNETIC, [((LUMEN_GAP * R, 0.0), (-1.0, 0.0))], R)
    if name == "away":
        return tip_contact(MAGNETIC, [((-R, 0.0), (1.0, 0.0))], R)
    # "rigid": the flexible 0.9 L, scaled by itself, the rigid 0.1 L its arm
    a = 0.9
    w = _scaled(S.wall((RIGID_WALL + R, 0.0), (-1.0, 0.0)))
    rod = Elastica(tip_magnet=2.0 * a, field_angle=PSI, E_s=S.STIFF * a * a, E_e=S.STIFF * a * a, arm=0.1 / a)
    out = tip_contact(rod, [(np.asarray(w[0]) / a, w[1])], R / a)
    return {"tip": out["tip"] * [a, a, 1.0], "force": out["force"] / a**2, "wall": out["wall"]}


RIGID_WALL = 0.42  # x / L of the wall the rigid tip body meets (its free tip reaches 0.601 L)


def _case(name: str, parameters: dict, scene: Callable, error, reference: str, **options) -> Case:
    return Case(FAMILY, name, {**parameters, "elements": 16}, lambda: solve_with_contacts(scene()), error,
                reference, **options)  # fmt: skip


def _lazy(key: str, boundary: str) -> Callable[[object], float]:
    return lambda sol: contact_error(_reference(key), boundary)(sol)


def _exact(tip, force, boundary: str) -> Callable[[object], float]:
    return contact_error({"tip": np.asarray(tip, float), "force": np.asarray(force, float)}, boundary)


def _sides_scene():
    p = SIDES
    t = np.array([math.cos(p["tilt"]), math.sin(p["tilt"])])
    walls = [  # wall 1 on the side the tip meets first
        {"point": [q * p["half"] * t[0], 0.0, q * p["half"] * t[1]], "normal": [-q * t[0], 0.0, -q * t[1]]}
        for q in (1.0, -1.0)
    ]
    ES = 1e8 * p["E_b"] / p["L"] ** 2
    rod = dict(length=p["L"], E_b=p["E_b"], E_t=p["E_b"], E_s=ES, E_e=ES, outer_diameter=2 * p["R_o"])
    B = [p["B"] * math.sin(p["psi"]), 0.0, p["B"] * math.cos(p["psi"])]
    return scene_from_dict(
        {
            "rod": rod,
            "field": {"B": B},
            "magnet": [{"at": p["L"], "moment": p["m"]}],
            "wall": walls,
            "advance": {"free_lengths": list(p["free"])},
        }
    )


def _sides_error(sol) -> float:
    """The contact sets of every step as SIDE_SETS (else inf), and the largest tip difference / free
    length from the same advance on 64 elements per step (self-convergence: the independent check of
    this sequence is tests/rod/test_contact_reference.py's channel)."""
    steps = sol.extra["steps"]
    if tuple(tuple(sorted({c["boundary"] for c in s["contacts"]})) for s in steps) != SIDE_SETS:
        return math.inf
    fine = solve(_sides_scene(), elements=64).extra["steps"]
    return max(float(np.abs(np.subtract(a["tip"]["position"], b["tip"]["position"])).max()) / a["free_length"]
               for a, b in zip(steps, fine, strict=True))  # fmt: skip


MAGNETIC_SCENE = {"scene": "magnetic cantilever q = 6.4, 120 deg, tube 1 mm"}
STRAIGHT = {"centreline": [[0, 0, -S.L], [0, 0, 2 * S.L]]}  # a straight lumen along the clamp's axis
REFUSED_BY_READER = "refused by the scene reader (exit 2) before any solve"


def cases() -> list[Case]:
    """The contact cases, each with its expected outcome (what is right physically)."""
    return [*_held_cases(), _sides_case(), *_refused_cases()]


def _held_cases() -> list[Case]:
    """A wall at the clamp, a lumen just wider than the tube, a rigid body on a wall, and a wall the
    unloaded rod lies along (pressed on it, and bent away from it)."""
    rigid_wall = (S.wall((RIGID_WALL + R, 0.0), (-1.0, 0.0)),)
    along, away = S.wall((R, 0.0), (-1.0, 0.0)), S.wall((-R, 0.0), (1.0, 0.0))
    return [
        _case(
            "a wall at the clamp (45 deg, touching the tube there)",
            {**MAGNETIC_SCENE, "wall": "45 deg, gap 0 at s = 0"},
            lambda: S.with_contact(S.magnetic_raw(), walls=(S.touching(45.0),)),
            _lazy("clamp", "wall 1"),
            REFERENCE,
            quick=True,
        ),
        _case(
            "a lumen 1 % wider than the tube",
            {**MAGNETIC_SCENE, "lumen radius / tube radius": LUMEN_GAP},
            lambda: S.with_contact(S.magnetic_raw(), lumen={**STRAIGHT, "radius": LUMEN_GAP * S.R_O}),
            _lazy("lumen", "lumen"),
            REFERENCE + " (the lumen is the wall x = its radius in the plane of the loads)",
        ),
        _case(
            "a rigid tip body against a wall",
            {"scene": "tip magnet m B L/E_b = 2, 120 deg, rigid last 10 %", "wall x / L": RIGID_WALL},
            lambda: S.with_contact(S.tip_magnet_raw(2.0, 120.0, rigid=0.1), walls=rigid_wall),
            _lazy("rigid", "wall 1"),
            REFERENCE + "; the rigid body as an arm carrying the reaction",
            quick=True,
            basis="10 x the rigid body's own compliance (RIGID_FACTOR = 1e6: ~1e-6)",
        ),
        _case(
            "a wall the unloaded rod lies along, pressed on it",
            {"tip force F L^2/E_b": PRESS, "wall": "x = R_o"},
            lambda: S.with_contact(S.tip_force_raw(PRESS), walls=(along,)),
            _exact((0.0, 1.0), (-PRESS, 0.0), "wall 1"),
            "exact: the straight rod, the wall's reaction -F (at the tip: no moment anywhere)",
        ),
        _case(
            "a wall the unloaded rod lies along, bent away from it",
            {**MAGNETIC_SCENE, "wall": "x = -R_o"},
            lambda: S.with_contact(S.magnetic_raw(), walls=(away,)),
            _lazy("away", "wall 1"),
            "the free elastica (shooting): the wall is left behind",
            quick=True,
        ),
    ]


def _sides_case() -> Case:
    return Case(
        FAMILY,
        "an advance whose contact changes sides (channel 8 mm, tilted 10 deg)",
        {"free lengths (mm)": [1e3 * v for v in SIDES["free"]], "elements": 16},
        lambda: solve(_sides_scene(), elements=16),
        _sides_error,
        "contact sets free, wall 1 x3, wall 1 + wall 2 x2 (tests/rod/contact_reference.advance); "
        "tips against 64 elements per step",
    )


def _refused_cases() -> list[Case]:
    cutting = (S.wall((0.5 * R, 0.0), (-1.0, 0.0)),)
    options = {"tolerance": None, "basis": "must be refused", "quick": True}
    lumens = [("a lumen narrower than the tube", 0.9, "narrower than the tube"),
              ("a lumen as wide as the tube", 1.0, "leaves the tube no room")]  # fmt: skip
    return [
        _case("a wall cutting the clamp", {"wall": "x = R_o / 2"},
              lambda: S.with_contact(S.magnetic_raw(), walls=cutting), None, REFUSED_BY_READER,
              expect=refused(says="cuts the clamp"), **options),
        *(_case(name, {"lumen radius / tube radius": k},
                lambda k=k: S.with_contact(S.magnetic_raw(), lumen={**STRAIGHT, "radius": k * S.R_O}),
                None, REFUSED_BY_READER, expect=refused(says=says), **options)
          for name, k, says in lumens),
    ]  # fmt: skip
