"""A shearable tube lying flat on its lumen's wall over a stretch shorter than the node spacing
(issue 31; fuzz of issue 30: 'interior contact points still moved after round 6 of meshing at
them'). The contact rounds of matid.rod.contact_mesh put a mesh vertex at each end of it.

Before, the vertex of its 'point contact' hopped between the stretch's two ends: the examples
precurved_3d (a 1.5 mm lumen) and tip_twist_stability (a 3 mm lumen) exited 1 at 12 and 16
elements, and automatic meshing took 2560 and 4096 elements (the stretch left its wall inside an
element: order 1). The reference for the planar case is independent of matid's code:
tests/rod/contact_reference.shear_stretch_in_lumen, a planar Reissner rod shot with the stretch's
ends as unknowns (matid's model: extensible, shearable), rotated about the lumen's axis.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from matid.physics import kinematics as kin
from matid.rod import cantilever
from matid.rod.api import _solve_forward
from matid.rod.contact_rounds import carry, check
from matid.rod.scenes import load_scene, scene_from_dict
from matid.rod.system import RodSystem
from matid.rod.terms.contact import contact_of

from . import contact_reference as cr

ROOT = Path(__file__).resolve().parents[2]
L, EB, ES, EE, RHO, MAG = 0.03, 6.5e-5, 21.0, 120.0, 3e-3, 0.0125
BX, BZ = 105.0859484050812e-3, -999.8260121435706e-3  # examples/scenes/tip_twist_stability.toml
AZIMUTH = math.radians(35.0)
FS = EB / L**2
#: The reference's own error (shooting at rtol 1e-12, residual 1e-10): below it no error is matid's.
FLOOR = 1e-8


def solved_and_checked(scene, elements, model="auto"):
    """solve's Solution of a scene, its returned state rebuilt on its mesh with its settled
    multipliers and passed through matid.rod.contact_rounds.check (walls met within
    contact_tolerance, no pulling reaction, stable with its contacts)."""
    sol, eq = _solve_forward(scene, elements=elements, model=model, variant=kin.NORMALISED, element="P2")
    _, _, rod, loads, _ = cantilever.prepare_scene(scene, model)
    penalty = cantilever.default_penalty(rod, kin.NORMALISED)
    system = RodSystem(eq.disc, rod, loads, model=eq.model, c_u=penalty, banded=True, mixed=True)
    carry(system, eq)
    contact_of(system)[1]["state"].k = eq.contact[3][2]
    check(system, system.reduce(eq.U.ravel()))
    assert sol.converged and np.isfinite(sol.discretization_error)
    return sol


@pytest.fixture(scope="module")
def reference():
    """The planar answer: the tip on x = +rho, the side flat on x = -rho over [a, b]; started from
    the unshearable point contact of the same scene."""
    walls = [((RHO, 0.0), (-1.0, 0.0)), ((-RHO, 0.0), (1.0, 0.0))]
    contacts = [("interior", 1, 0.62 * L), ("tip", 0)]
    point = cr.solve_planar_contact(L, EB, 0.0, walls, B=(BX, BZ), m=MAG, contacts=contacts,
                                    guess=[0.0, 10.0 * FS, 0.62 * L, 15.0 * FS])  # fmt: skip
    assert point["converged"] and point["admissible"]
    side, tip = point["contacts"]
    guess = [point["m0"], side["force"] - tip["force"], side["s"] - 0.005 * L, side["s"] + 0.005 * L]
    ref = cr.shear_stretch_in_lumen(L, EB, ES, EE, RHO, (BX, BZ), MAG, guess)
    assert ref["admissible"] and ref["residual"] < 1e-10
    assert 0.01 * L < ref["b"] - ref["a"] < 0.05 * L  # shorter than 16 elements' node spacing
    return ref


def _rotated_scene():
    B = [BX * math.cos(AZIMUTH), BX * math.sin(AZIMUTH), BZ]
    raw = {"rod": {"length": L, "E_b": EB, "E_t": 4.4e-5, "E_s": ES, "E_e": EE},
           "magnet": [{"at": L, "moment": MAG}], "field": {"B": B},
           "lumen": {"centreline": [[0, 0, -10e-3], [0, 0, 40e-3]], "radius": RHO}}  # fmt: skip
    return scene_from_dict(raw)


@pytest.mark.parametrize("elements", [12, 16, None])
def test_a_short_stretch_in_a_lumen_is_the_planar_reissner_answer_rotated(reference, elements):
    """The tip-twist example's tube and field without its twist, in a 3 mm lumen, with the field's
    plane turned 35 deg about the lumen's axis, solved by the full model."""
    sol = solved_and_checked(_rotated_scene(), elements, model="full")
    side, tip = sol.extra["contacts"]
    rot = lambda v: cr.rotate_about_axis(v, AZIMUTH)  # noqa: E731
    e_tip = float(np.abs(np.asarray(sol.tip["position"]) - rot(reference["tip"])).max()) / L
    forces = ((side, rot((reference["stretch_force"], 0.0))), (tip, rot((-reference["tip_force"], 0.0))))
    e_force = max(float(np.linalg.norm(np.asarray(c["force"]) - f) / np.linalg.norm(f)) for c, f in forces)
    e_s = max(abs(side["s"][0] - reference["a"]), abs(side["s"][1] - reference["b"])) / L
    est = sol.discretization_error
    row = f"{elements} -> {sol.elements} | {e_tip:.1e} | {e_force:.1e} | {e_s:.1e} | {est:.1e}"
    print(f"| short stretch | {row} |")
    assert tip["s"][0] == pytest.approx(L, abs=1e-12)
    assert est >= (max(e_tip, e_force) - FLOOR) / 3
    assert sol.extra["error_estimate"]["order"] > 2  # the stretch leaves its wall on a vertex
    if elements is None:  # the scene's tolerance (1e-6): issue 31's targets
        assert e_tip < 1e-6 and e_force < 1e-4 and e_s < 1e-4
        assert sol.elements <= 256


@pytest.mark.parametrize("elements", [12, 16, None])
@pytest.mark.parametrize(("name", "radius"), [("precurved_3d", "1.5 mm"), ("tip_twist_stability", "3 mm")])
def test_the_examples_in_a_straight_lumen_solve_with_a_short_stretch(name, radius, elements, tmp_path):
    """The two 3D examples placed in a straight lumen (no independent answer: their loads are in no
    plane). Each solves on few elements, its side contact a stretch with both ends inside the rod."""
    text = (ROOT / "examples" / "scenes" / f"{name}.toml").read_text().replace("elements = 24", "")
    axis = '[["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "200 mm"]]'
    lumen = f'\n[lumen]\ncentreline = {axis}\nradius = "{radius}"\n'
    (tmp_path / "scene.toml").write_text(text + lumen)
    sol = solved_and_checked(load_scene(tmp_path / "scene.toml"), elements)
    side = [c for c in sol.extra["contacts"] if c["s"][1] < 0.9 * L]
    assert len(side) == 1 and 0.5 * L < side[0]["s"][0] < side[0]["s"][1] < 0.7 * L
    assert sol.elements <= 256 and sol.extra["error_estimate"]["order"] > 2


def test_no_contact_round_refines_past_the_mesh_its_answer_needs(monkeypatch):
    """examples/scenes/magnet_direction.toml at 400 mT between two walls, tolerance 1e-7: a stretch
    on each wall. A round whose stretch end is known off its vertex stops doubling (its meshes
    cannot settle it): no round goes past the finest mesh of the last one (before, the sixth round
    went to 2048 elements for an answer on 1024, 3x the CPU). Same tip as every round's answer,
    within the scene's estimate of the exact one."""
    import matid.rod.api as api

    largest, refine = [], api.refine

    def recorded(*args, **kwargs):
        result = refine(*args, **kwargs)
        largest.append(max(n for n, _ in result[1].history))
        return result

    monkeypatch.setattr(api, "refine", recorded)
    raw = tomllib.loads((Path(__file__).parents[2] / "examples/scenes/magnet_direction.toml").read_text())
    raw["tolerance"], raw["field"]["B"] = 1e-7, ["0 mT", "400 mT", "200 mT"]
    raw["wall"] = [
        {"point": ["-2 mm", "0 mm", "0 mm"], "normal": [1, 0, 0]},
        {"point": ["1.41421356 mm", "0 mm", "1.41421356 mm"], "normal": [-1, 0, -1]},
    ]
    sol = api.solve(scene_from_dict(raw))
    assert sol.converged and len(sol.extra["contacts"]) == 3 and len(largest) > 2
    assert max(largest) == largest[-1]
