"""The demo's bend generator (matid.example.bend_shooting, strong form by shooting) against the
model the fit uses (matid.rod.bend.BendModel, P2 finite elements): two models of the same
physics that share no code must agree to the finite-element model's discretisation error,
which falls at its order (four) as the mesh is refined."""

from __future__ import annotations

import numpy as np
import pytest

from matid.example.bend_shooting import bend_path
from matid.fits.shear.centreline import centreline_deflection
from matid.rod.bend import BendGeometry, BendModel

RIG = dict(span=0.010, specimen_length=0.030, support_radius=0.002, nose_radius=0.002)
CASES = {  # name: (stiffnesses, outer diameter, deepest nose deflection)
    "T1 demo, d/S 10 %": (dict(E_b=6.5e-5, E_s=26.31, E_e=120.0), 2.4e-3, 1.0e-3),
    "T2 demo, d/S 10 %": (dict(E_b=9.0e-5, E_s=47.9, E_e=190.0), 2.2e-3, 1.0e-3),
    "soft shear, d/S 15 %": (dict(E_b=6.5e-5, E_s=2.0, E_e=40.0), 2.4e-3, 1.5e-3),
}


@pytest.mark.parametrize("case", list(CASES))
def test_shooting_and_bend_model_agree_to_the_discretisation_error(case):
    stiff, outer, d_max = CASES[case]
    geometry = dict(RIG, outer_diameter=outer)
    d = np.linspace(0.0, d_max, 16)
    force, centre, support_s = bend_path(d, **stiff, **geometry)
    assert np.all(np.diff(force) > 0) and force[0] == 0.0
    errors = []
    for n in (12, 24, 48):
        model = BendModel(BendGeometry(**geometry), elements=n)
        path = model.solve(stiff["E_b"], stiff["E_s"], stiff["E_e"], d)
        c = centreline_deflection(model, path)
        errors.append([
            np.max(np.abs(path.force[1:] / force[1:] - 1.0)),
            np.max(np.abs(c[1:] / centre[1:] - 1.0)),
            np.max(np.abs(path.support_s - support_s)) / RIG["span"],
        ])  # fmt: skip
    errors = np.array(errors)
    # measured (T1): force 4.0e-6, 2.5e-7, 1.6e-8; centreline 6.5e-7, 4.1e-8, 2.6e-9
    assert np.all(errors[-1] < 1e-6), errors
    orders = np.log2(errors[:-1] / errors[1:])
    assert np.all(orders > 3.5), orders


def test_shooting_tends_to_the_timoshenko_closed_form():
    stiff, geometry = dict(E_b=6.5e-5, E_s=21.0, E_e=120.0), dict(RIG, outer_diameter=2.4e-3)
    d = np.array([0.0, 1e-8])
    force = bend_path(d, **stiff, **geometry)[0][-1]
    S = RIG["span"]
    timoshenko = force * S**3 / (48 * stiff["E_b"]) + force * S / (4 * stiff["E_s"])
    assert d[-1] == pytest.approx(timoshenko, rel=1e-6)


def test_shooting_refuses_what_it_cannot_solve():
    geometry = dict(RIG, outer_diameter=2.4e-3)
    with pytest.raises(ValueError, match="increasing"):
        bend_path(np.array([1e-3, 0.0]), E_b=6.5e-5, E_s=21.0, E_e=120.0, **geometry)
    with pytest.raises(ValueError, match="E_s"):
        bend_path(np.array([0.0, 1e-3]), E_b=6.5e-5, E_s=0.0, E_e=120.0, **geometry)
