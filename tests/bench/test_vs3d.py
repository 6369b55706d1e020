"""The ``vs_3d`` bench section (vs3d, tube_fe, tube_section, extrapolation): 3D scikit-fem tube against
the 1D rod on the same small-deflection cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import Basis, ElementHex2, ElementVector, asm
from skfem.models.elasticity import lame_parameters, linear_elasticity

from matid.bench import extrapolation, tube_fe, tube_section, vs3d


@pytest.fixture(scope="module")
def quick():
    return vs3d.run(quick=True)


def test_cowper_coefficient_limits():
    """Cowper's hollow-circle k: 6(1+nu)/(7+6nu) for a solid section, 2(1+nu)/(4+3nu) for a thin wall."""
    nu = 0.3
    assert tube_section.Section(nu=nu, R_i=0.0).k == pytest.approx(6 * (1 + nu) / (7 + 6 * nu), rel=1e-14)
    thin = tube_section.Section(nu=nu, R_i=1.2e-3 * (1 - 1e-9))
    assert thin.k == pytest.approx(2 * (1 + nu) / (4 + 3 * nu), rel=1e-8)


def test_patch_beam_reduces_to_point_loads():
    sec = tube_section.Section()
    assert tube_section.bend_stiffness_patch(sec, half_length=1e-9) == pytest.approx(
        tube_section.bend_stiffness_point(sec), rel=1e-5
    )
    assert tube_section.bend_stiffness_patch(sec) > tube_section.bend_stiffness_point(
        sec
    )  # spread loads: smaller moments


def test_vectorised_stiffness_equals_scikit_fem_assembly():
    """Same operator as skfem's linear_elasticity (dof numbering differs: compare spectra)."""
    lame = lame_parameters(tube_section.E, tube_section.NU)
    grid = tube_fe.TubeGrid(
        np.array([tube_section.R_I, tube_section.R_O]), np.linspace(0, math.pi, 3), np.array([0.0, 1e-3])
    )
    _, mesh = tube_fe.tube_mesh(grid)
    mine = tube_fe.stiffness_matrix(Basis(mesh, ElementHex2(), intorder=5), *lame).toarray()
    ref = asm(linear_elasticity(*lame), Basis(mesh, ElementVector(ElementHex2()), intorder=5)).toarray()
    np.testing.assert_allclose(
        np.linalg.eigvalsh(mine), np.linalg.eigvalsh(ref), rtol=1e-9, atol=1e-9 * np.abs(ref).max()
    )


def test_richardson_recovers_limit_and_order():
    h = 1.0 / np.array([2.0, 3.0, 4.0, 5.0])
    fit = extrapolation.richardson(h, 1.0 + 0.3 * h**2.5)
    assert fit["limit"] == pytest.approx(1.0, abs=1e-12)
    assert fit["order"] == pytest.approx(2.5, rel=1e-8)
    assert (
        extrapolation.richardson(h, np.full(4, 2.0))["order"] is None
    )  # round-off: finest value is the limit


def test_cost_at_interpolates_and_extrapolates():
    runs = [
        extrapolation.Run("3d", "c", str(n), dofs=n, runtime_s=n / 1e3, value=0.0) for n in (1e3, 8e3, 64e3)
    ]
    inside = extrapolation.cost_at(runs, np.array([1e-2, 1e-3, 1e-5]), 1e-4)
    assert inside["status"] == "interpolated" and 8e3 < inside["dofs"] < 64e3
    beyond = extrapolation.cost_at(runs, np.array([1e-2, 1e-3, 4e-4]), 1e-4, order=2.0, dim=3)
    assert beyond["status"].startswith("extrapolated")
    assert beyond["dofs"] == pytest.approx(64e3 * 4**1.5)  # err ~ DOF^(-2/3)


def test_3d_cantilever_agrees_with_timoshenko():
    """Level 2 (~10k DOF): within 2 % of P L^3/(3EI) + P L/(kGA).

    Tolerance: the converged 3D tube is ~0.9 % stiffer than Timoshenko beam theory
    (the clamp stops the Poisson contraction and the warping of the root section,
    a Saint-Venant end effect), plus ~6e-4 discretisation error on this mesh.
    """
    sec = tube_section.Section()
    delta = tube_fe.cantilever_3d(tube_fe.cantilever_grid(2), sec=sec).value
    assert delta == pytest.approx(tube_section.cantilever_compliance(sec), rel=0.02)


def test_quick_run_structure(quick):
    assert set(quick) >= {"rows", "converged", "ratios", "notes"}
    for row in quick["rows"]:
        assert set(row) >= {"model", "case", "mesh", "dofs", "runtime_s", "value", "discretization_error"}
        assert row["model"] in ("3d", "1d") and row["case"] in ("cantilever", "bend")
        assert row["dofs"] > 0 and row["runtime_s"] > 0 and row["discretization_error"] >= 0
    for case in ("cantilever", "bend"):
        assert set(quick["converged"][case]) >= {"3d", "1d", "gap_rel"}
        assert set(quick["ratios"][case]) >= {"dof_ratio_at_1e-4", "time_ratio_at_1e-4"}
        assert quick["ratios"][case]["dof_ratio_at_1e-4"] > 40
    assert quick["notes"] and all(isinstance(n, str) for n in quick["notes"])


def test_3d_error_decreases_with_level(quick):
    for case in ("cantilever", "bend"):
        rows = [r for r in quick["rows"] if r["case"] == case and r["model"] == "3d"]
        errors = [r["discretization_error"] for r in rows]
        assert all(a > b for a, b in zip(errors, errors[1:], strict=False))


def test_1d_matches_closed_forms_and_gap_is_reported(quick):
    sec = tube_section.Section()
    c, b = quick["converged"]["cantilever"], quick["converged"]["bend"]
    assert c["1d"] == pytest.approx(tube_section.cantilever_compliance(sec), rel=1e-6)
    assert b["1d"] == pytest.approx(tube_section.bend_stiffness_point(sec), rel=1e-6)
    # 1D modelling error: the 1D cantilever is ~1 % softer than the clamped 3D tube ...
    assert 0.0 < c["gap_rel"] < 0.02
    # ... and the 3D bend without indentation (loads smeared over the section) is within 3 % of the beam.
    assert b["3d_body_force"] == pytest.approx(tube_section.bend_stiffness_patch(sec), rel=0.03)
    assert math.isfinite(b["gap_rel"])
