"""The 3D linear-elastic tube of the ``vs_3d`` section on scikit-fem: mesh, stiffness, loads, solves.

A structured (r, phi, z) hex mesh mapped onto the tube as ``MeshHex2`` (27-node geometry,
circles to O(h^3)); unknowns on ``ElementHex2`` (default), ``ElementHexS2`` (20-node) or
``ElementHex1`` (8-node, for the locking comparison). The stiffness is assembled as six scalar
forms d_a phi_i d_b phi_j on the scalar basis, because scikit-fem's ``asm`` of
``linear_elasticity`` on ``ElementVector`` loops over the 81 x 81 local pairs in Python: on the
level-2 cantilever (10k DOF) 10 s against 0.8 s, level 3 48 s against 3.4 s (scikit-fem
12.0.2, loaded 2-core machine; same matrix to 1e-15). 3 x 3 x 3 Gauss points
(``intorder=5``) instead of the 7 x 7 x 7 that ``ElementHex2`` asks for: 64 or 343 points move
the answer by < 1e-6 relative. Direct sparse LU (SuperLU, MMD(A^T + A), symmetric mode,
``DiagPivotThresh=0``: K is SPD; with threshold pivoting the serendipity matrix took 195 s
instead of 2 s at 33k DOF). The LU fill limits the sizes: level 6 (226k DOF) took 163 s once,
level 5 (133k DOF) 10-30 s, so the full run stops at level 5.

The cantilever mesh is graded towards the singular clamped edges (clamped-free wedges at r = R_i
and R_o): spacing 1 - (1 - t)^2 through the wall towards both surfaces and z = L s^2 along the
tube. With uniform z slices (1 x 8 sectors, 10/20/40 slices) the tip deflection was 3.4 %,
1.4 %, 0.6 % off (order ~1.2); graded, the family converges at order ~2 in h. The bend has no
singularity (smooth C^1 patches on element boundaries).

"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import (
    Basis,
    BilinearForm,
    ElementHex1,
    ElementHex2,
    ElementHexS2,
    FacetBasis,
    Functional,
    LinearForm,
    MeshHex,
    MeshHex2,
    asm,
    condense,
    solve,
)
from skfem.models.elasticity import lame_parameters

from matid.bench.extrapolation import Run
from matid.bench.tube_section import (
    CANTILEVER_LENGTH,
    PATCH_HALF_ANGLE,
    PATCH_HALF_LENGTH,
    R_I,
    R_O,
    SPAN,
    SPECIMEN_LENGTH,
    TUBE,
    Section,
)

ELEMENTS_3D = {"hex27": ElementHex2, "hex20": ElementHexS2, "hex8": ElementHex1}
#: 3 x 3 x 3 Gauss points (module docstring: 64 or 343 move the answer by < 1e-6).
DEFAULT_INTORDER = 5

# -- 3D model ------------------------------------------------------------------


@dataclass(frozen=True)
class TubeGrid:
    """Node coordinates of the structured (r, phi, z) grid; phi in [0, pi] (half tube, y >= 0)."""

    r: np.ndarray
    phi: np.ndarray
    z: np.ndarray

    @property
    def label(self) -> str:
        return f"{self.r.size - 1}x{self.phi.size - 1}x{self.z.size - 1}"


def tube_mesh(grid: TubeGrid) -> tuple[MeshHex, MeshHex2]:
    """(parameter mesh, curved tube): the same topology and facet numbering, nodes mapped
    (r, phi, z) -> (r cos phi, r sin phi, z) including the edge, face and centre nodes."""
    param = MeshHex.init_tensor(grid.r, grid.phi, grid.z)
    curved = MeshHex2.from_mesh(param)
    r, phi, z = curved.doflocs
    curved = dataclasses.replace(curved, doflocs=np.array([r * np.cos(phi), r * np.sin(phi), z]))
    return param, curved


def stiffness_matrix(basis: Basis, lam: float, mu: float) -> sp.csr_matrix:
    """Isotropic linear elasticity, unknown 3 k + a = component a of scalar dof k:

    K_(i a)(j b) = lam D^ab_ij + mu (D^ba_ij + delta_ab sum_c D^cc_ij),  D^ab_ij = int d_a phi_i d_b phi_j,

    the six distinct D^ab assembled by scikit-fem on the scalar basis (module docstring: why not
    ``linear_elasticity`` on ``ElementVector``).
    """
    D = {
        (a, b): asm(BilinearForm(lambda u, v, w, a=a, b=b: v.grad[a] * u.grad[b]), basis)
        for a in range(3)
        for b in range(a, 3)
    }
    D.update({(b, a): D[a, b].T for a, b in list(D) if a != b})
    trace = D[0, 0] + D[1, 1] + D[2, 2]
    K = sp.bmat(
        [[lam * D[a, b] + mu * (D[b, a] + (trace if a == b else 0)) for b in range(3)] for a in range(3)]
    )
    order = (np.arange(3) * basis.N + np.arange(basis.N)[:, None]).ravel()  # (component, dof) -> 3 k + a
    return K.tocsr()[order][:, order]


def scaled_load(basis: Basis | FacetBasis, weight: Callable, total: float) -> np.ndarray:
    """Scalar load vector of the density weight(x) on the basis's domain (a traction on facets or a
    body force), scaled to the given total."""
    size = Functional(lambda w: weight(w.x)).assemble(basis)
    return LinearForm(lambda v, w: total / size * weight(w.x) * v).assemble(basis)


def solve_fixed(K: sp.csr_matrix, loads: list[np.ndarray], fixed: np.ndarray) -> list[np.ndarray]:
    """u with u[fixed] = 0 and K u = f on the rest, for each f (one factorisation)."""
    A, _, u0, free = condense(K, loads[0], D=fixed)
    lu = spla.splu(
        A.tocsc(), permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True, "DiagPivotThresh": 0}
    )
    out = [solve(A, f[free], u0, free, solver=lambda _, b: lu.solve(b)) for f in loads]
    if not np.all(np.isfinite(out)):
        raise FloatingPointError("3D solve returned non-finite displacements")
    return out


def cantilever_grid(level: int) -> TubeGrid:
    """Level n: n layers through the wall, 4n sectors on the half circle, 10n slices, h ~ 1/n,
    graded towards the singular clamped edges (module docstring)."""
    t = np.linspace(-1.0, 1.0, level + 1)
    wall = 0.5 * (1 + np.sign(t) * (1 - (1 - np.abs(t)) ** 2))
    return TubeGrid(
        r=R_I + (R_O - R_I) * wall,
        phi=np.linspace(0.0, math.pi, 4 * level + 1),
        z=CANTILEVER_LENGTH * np.linspace(0.0, 1.0, 10 * level + 1) ** 2,
    )


def cantilever_3d(
    grid: TubeGrid, *, element: str = "hex27", intorder: int = DEFAULT_INTORDER, sec: Section = TUBE
) -> Run:
    """3D clamped tube, parabolic end traction: tip deflection per unit force [m/N] (half model)."""
    t0 = time.perf_counter()
    param, mesh, elem, basis, K = _tube(grid, element, intorder, sec)
    t1 = time.perf_counter()
    tip = param.facets_satisfying(lambda x: np.isclose(x[2], grid.z[-1]))
    f = np.zeros(K.shape[0])
    tip_basis = FacetBasis(mesh, elem, facets=tip, intorder=intorder)
    f[0::3] = scaled_load(tip_basis, lambda x: _wall_parabola(x, sec), 0.5)  # half of P = 1
    clamp = basis.get_dofs(param.facets_satisfying(lambda x: np.isclose(x[2], 0.0))).all()
    sym = basis.get_dofs(param.facets_satisfying(lambda x: np.isclose(x[1], 0.0) | np.isclose(x[1], math.pi)))
    fixed = np.unique(np.concatenate([(3 * clamp[:, None] + np.arange(3)).ravel(), 3 * sym.all() + 1]))
    (u,) = solve_fixed(K, [f], fixed)
    return _run_3d("cantilever", grid, element, intorder, K.shape[0] - fixed.size, t0, t1, float(f @ u / 0.5))


def _tube(grid: TubeGrid, element: str, intorder: int, sec: Section):
    """(parameter mesh, curved mesh, element, basis, stiffness matrix) of the tube on ``grid``."""
    param, mesh = tube_mesh(grid)
    elem = ELEMENTS_3D[element]()
    basis = Basis(mesh, elem, intorder=intorder)
    return param, mesh, elem, basis, stiffness_matrix(basis, *lame_parameters(sec.E, sec.nu))


def _run_3d(case: str, grid: TubeGrid, element: str, intorder: int, dofs: int, t0, t1, value, **extra) -> Run:
    """The Run of a 3D solve started at t0, assembled at t1 and solved now."""
    t2 = time.perf_counter()
    extra = {"assembly_s": t1 - t0, "solve_s": t2 - t1, "element": element, "intorder": intorder, **extra}
    return Run("3d", case, f"{element} {grid.label}", dofs, t2 - t0, value, extra)


def _wall_parabola(x: np.ndarray, sec: Section) -> np.ndarray:
    r = np.sqrt(x[0] ** 2 + x[1] ** 2)
    return np.clip((r - sec.R_i) * (sec.R_o - r), 0.0, None)


def bend_grid(level: int) -> TubeGrid:
    """Quarter specimen, level n, h ~ 1/n: n layers, 4n sectors (patch edges at 45 and 135 deg on
    nodes), z slices n on the nose patch, 3n to the support patch, 2n on it, 3n on the overhang
    (graded away from the support: it carries no moment)."""
    b = PATCH_HALF_LENGTH
    breaks = [0.0, b, SPAN / 2 - b, SPAN / 2 + b, SPECIMEN_LENGTH / 2]
    steps = [np.linspace(0.0, 1.0, n + 1)[1:] for n in (level, 3 * level, 2 * level, 3 * level)]
    steps[-1] = steps[-1] ** 2
    segments = zip(itertools.pairwise(breaks), steps, strict=True)
    z = np.concatenate([[0.0], *(z0 + (z1 - z0) * t for (z0, z1), t in segments)])
    return TubeGrid(r=np.linspace(R_I, R_O, level + 1), phi=np.linspace(0.0, math.pi, 4 * level + 1), z=z)


def _band(x: np.ndarray, z0: float, b: float) -> np.ndarray:
    """cos^2 bump in z (half-width b) around z0."""
    dz = x[2] - z0
    return np.where(np.abs(dz) < b, np.cos(0.5 * math.pi * dz / b) ** 2, 0.0)


def _patch(x: np.ndarray, z0: float, phi0: float, b: float, alpha: float) -> np.ndarray:
    """The band times a cos^2 bump in phi (half-width alpha) around phi0."""
    dphi = np.abs(np.arctan2(x[1], x[0]) - phi0)
    return _band(x, z0, b) * np.where(dphi < alpha, np.cos(0.5 * math.pi * dphi / alpha) ** 2, 0.0)


def bend_3d(
    grid: TubeGrid, *, element: str = "hex27", intorder: int = DEFAULT_INTORDER, sec: Section = TUBE
) -> Run:
    """3D quarter tube in three-point bend: stiffness F/d [N/m] under surface patches (value)
    and under the same axial profiles smeared over the section as body forces (extra)."""
    t0 = time.perf_counter()
    param, mesh, elem, basis, K = _tube(grid, element, intorder, sec)
    t1 = time.perf_counter()
    outer = param.facets_satisfying(lambda x: np.isclose(x[0], sec.R_o))
    quarter = 0.25  # of F = 1: half the nose load on the quarter, one support's half
    f_surface, f_body = np.zeros(K.shape[0]), np.zeros(K.shape[0])
    surface = FacetBasis(mesh, elem, facets=outer, intorder=intorder)
    b, alpha = PATCH_HALF_LENGTH, PATCH_HALF_ANGLE
    for z0, phi0, total in ((0.0, 0.0, -quarter), (SPAN / 2, math.pi, quarter)):  # nose, support
        f_surface[0::3] += scaled_load(
            surface, lambda x, z0=z0, phi0=phi0: _patch(x, z0, phi0, b, alpha), total
        )
        f_body[0::3] += scaled_load(basis, lambda x, z0=z0: _band(x, z0, b), total)
    sym_y = basis.get_dofs(param.facets_satisfying(lambda x: np.isclose(x[1], 0) | np.isclose(x[1], math.pi)))
    sym_z = basis.get_dofs(param.facets_satisfying(lambda x: np.isclose(x[2], 0.0)))
    end = basis.get_dofs(param.facets_satisfying(lambda x: np.isclose(x[2], grid.z[-1]))).all()
    pin = end[np.argmax(basis.doflocs[1, end])]  # a node on top of the y-axis at the free end
    fixed = np.unique(np.concatenate([3 * sym_y.all() + 1, 3 * sym_z.all() + 2, [3 * pin]]))
    u_surface, u_body = solve_fixed(K, [f_surface, f_body], fixed)
    stiffness = [float(quarter**2 / (f @ u) * 4) for f, u in ((f_surface, u_surface), (f_body, u_body))]
    dofs = K.shape[0] - fixed.size
    return _run_3d("bend", grid, element, intorder, dofs, t0, t1, stiffness[0], body_force_value=stiffness[1])
