"""The bend's derivatives that make the E_s fit cheap, each against its oracle (issue 13).

- dR/dlam (closed form) against central differences of the residual;
- dF/dd on the path against differences of solved forces;
- warm and predicted starts change the work, never the answer;
- the centreline deflection's gradient against central differences along state directions,
  and the centreline fit's Jacobian (at fixed centreline deflection) against differences of
  the whole problem;
- the least squares ends at the minimum in a few solves (counted, not timed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.example.forward import bend_centreline, bend_force
from matid.fits.shear import centreline as bc
from matid.fits.shear import fit as shear
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.rod.bend import BendGeometry, BendModel

E_B, E_S, E_E = 6.5e-5, 21.0, 120.0
RIG = {"span": 0.01, "specimen_length": 0.03, "support_radius": 2e-3, "nose_radius": 2e-3}
GEOMETRY = BendGeometry(0.01, 0.03, 2e-3, 2e-3, 2.4e-3)
SPECIMEN = study.Specimen("T1", 2.4e-3, 1.6e-3)
ALL = ("E_s", "E_b", "E_e")


@pytest.fixture(scope="module")
def path():
    return BendModel(GEOMETRY, elements=8).solve(E_B, E_S, E_E, np.linspace(0.0, 1e-3, 6), sensitivities=ALL)


def test_lam_derivative_matches_central_differences(path):
    model = BendModel(GEOMETRY, elements=8)
    system = model.system(E_B, E_S, E_E, 1e-3)
    X, lam, h = path.states[-1], 1.0, 1e-6
    exact = system.lam_derivative(X, lam)
    fd = (system.evaluate(X, lam + h, tangent=False)[0] - system.evaluate(X, lam - h, tangent=False)[0]) / (
        2 * h
    )
    assert np.max(np.abs(exact - fd)) < 1e-8 * np.max(np.abs(fd))
    X_off = X.copy()
    X_off[system.dofs[1][0]] += 1e-3  # a state off the axis normal: the general formula, not +-1
    system2 = BendModel(BendGeometry(0.01, 0.03, 2e-3, 2e-3, 2.4e-3), elements=8).system(E_B, E_S, E_E, 1e-3)
    exact = system2.lam_derivative(X_off, 0.7)
    fd = (
        system2.evaluate(X_off, 0.7 + h, tangent=False)[0]
        - system2.evaluate(X_off, 0.7 - h, tangent=False)[0]
    ) / (2 * h)
    assert np.max(np.abs(exact - fd)) < 1e-8 * np.max(np.abs(fd))


def test_force_slope_matches_differences_of_solved_forces(path):
    model = BendModel(GEOMETRY, elements=8)
    d, h = path.deflection[3], 1e-9
    up, down = (model.solve(E_B, E_S, E_E, [d + s]).force[0] for s in (h, -h))
    assert path.dforce_dd[3] == pytest.approx((up - down) / (2 * h), rel=1e-6)


def test_warm_and_predicted_starts_give_the_cold_answer():
    """A warm start at other stiffnesses and other deflections (the centreline fit's case), and a
    cold path whose points start from the tangent predictor, agree with point-by-point solves."""
    model = BendModel(GEOMETRY, elements=12)
    d = np.linspace(0.0, 1e-3, 12)
    first = model.solve(E_B, 1.2 * E_S, E_E, d, sensitivities=ALL)
    moved = d * 1.01
    warm = model.solve(E_B, E_S, 0.9 * E_E, moved, sensitivities=ALL, start=first)
    cold = model.solve(E_B, E_S, 0.9 * E_E, moved, sensitivities=ALL)
    single = [model.solve(E_B, E_S, 0.9 * E_E, [x]).force[0] for x in moved[[1, 6, 11]]]
    assert np.allclose(warm.force, cold.force, rtol=1e-9, atol=0)
    assert np.allclose(cold.force[[1, 6, 11]], single, rtol=1e-9, atol=0)
    for p in ALL:
        assert np.allclose(
            warm.dforce[p], cold.dforce[p], rtol=1e-7, atol=1e-12 * np.abs(cold.dforce[p]).max()
        )
    assert cold.newton_iterations <= 3 * d.size  # the tangent predictor (4 per point without)
    assert warm.newton_iterations <= 3 * d.size


def test_centreline_gradient_matches_central_differences(path):
    model = BendModel(GEOMETRY, elements=8)
    centre = bc.Centreline(model)
    c, slope, grads = bc.centreline_path(centre, path)
    assert np.allclose(c, bc.centreline_deflection(model, path), rtol=0, atol=1e-15)
    for X, t, grad in zip(path.states[1:], path.tangents[1:], grads[1:], strict=True):
        for v in (t["d"], t["E_s"], t["E_e"]):
            fd = bc.rate(model, X, v)
            assert grad @ v == pytest.approx(fd, rel=1e-6, abs=1e-9 * abs(fd) + 1e-15)


def _centreline_problem(fit_E_b: bool) -> shear.Problem:
    data = []
    for span in (0.008, 0.010):
        rig = {**RIG, "span": span}
        c, F = bend_centreline(
            np.linspace(0.0, 0.03 * span, 10), E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=2.4e-3, **rig
        )
        F = F * (1.0 + 0.02 * np.sin(np.arange(F.size)))  # non-zero residuals
        test = study.Test("three_point_bend", "T1", Path(f"c{span}.csv"), rig, deflection_at="centreline")
        m = Measurement(test, Table(Path(f"c{span}.csv"), {"deflection": c, "force": F}, {}, {}, ""))
        data.append(shear.bend_data(m, SPECIMEN, E_B))
    return shear.Problem(data, E_B, E_E, fit_E_b=fit_E_b, elements=16)


@pytest.mark.parametrize("fit_E_b", [False, True])
def test_centreline_jacobian_is_the_total_derivative(fit_E_b):
    """At fixed centreline deflection the nose travel moves with the stiffnesses; the Jacobian
    holds that term (without it the error was 5 %, and Gauss-Newton stalled beside the minimum)."""
    problem = _centreline_problem(fit_E_b)
    x = np.log([23.0, 6.0e-5][: 1 + fit_E_b])
    _, J = problem.evaluate(x)
    held = problem.sensitivity("E_e")
    h = 1e-4
    for k in range(x.size):
        step = np.zeros_like(x)
        step[k] = h
        fd = (problem.evaluate(x + step)[0] - problem.evaluate(x - step)[0]) / (2 * h)
        assert np.max(np.abs(fd - J[:, k])) < 1e-5 * np.max(np.abs(J[:, k]))
    other = shear.Problem(problem.data, E_B, E_E * (1 + h), fit_E_b=fit_E_b, elements=16)
    lower = shear.Problem(problem.data, E_B, E_E * (1 - h), fit_E_b=fit_E_b, elements=16)
    fd = (other.evaluate(x)[0] - lower.evaluate(x)[0]) / (2 * h * E_E)
    assert np.max(np.abs(fd - held)) < 1e-5 * np.max(np.abs(held))


def test_fit_ends_at_the_minimum_in_few_solves():
    d = np.linspace(0.0, 1e-3, 30)
    F = bend_force(d, E_b=E_B, E_s=E_S, E_e=E_E, outer_diameter=2.4e-3, **RIG)
    F = F + np.random.default_rng(1).normal(0.0, 0.002 * F.max(), F.size)
    m = Measurement(
        study.Test("three_point_bend", "T1", Path("3pb.csv"), RIG),
        Table(Path("3pb.csv"), {"deflection": d, "force": F}, {}, {}, ""),
    )
    data = [shear.bend_data(m, SPECIMEN, E_B)]
    out = shear._fit_adaptive(data, E_B, E_E, fit_E_b=False, elements=None, progress=None)
    gradient = float(out.J[:, 0] @ out.r)
    assert abs(gradient) / float(out.J[:, 0] @ out.J[:, 0]) < 1e-4 * np.sqrt(out.cov_log[0, 0])
    assert out.problem.solves <= 5  # cold start, Gauss-Newton steps, no confirming solve
    assert out.problem.newton_iterations <= 300
