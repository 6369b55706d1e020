"""Strain range of the linear law (contract section 9): a warning, never silence.

Eq. (6) is linear in the strains; it describes a tube only while they are small. At every
quadrature point of a converged state

    shear/extension  |nu - e3| = sqrt(nu1^2 + nu2^2 + (nu3 - 1)^2)
    bending/twist    |kappa - kappa_ref| R_o       (R_o the outer radius; SI: kappa / L)

and a value above LINEAR_RANGE is reported with where it peaks. Without an outer diameter
the curvature cannot be judged, and the warning says so when the curvature is large.
"""

from __future__ import annotations

import numpy as np

from matid.physics import kinematics as kin
from matid.rod.cantilever import equilibrium, prepare_scene
from matid.rod.models import PLANAR

#: Largest strain the linear law is taken to describe (contract section 9: 0.05).
LINEAR_RANGE = 0.05


def point_strains(eq, rod=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s / L, |nu - e3|, |kappa - kappa_ref| scaled by L) at the quadrature points of eq."""
    disc, model = eq.disc, eq.model
    rod = prepare_scene(eq.scene, model)[2] if rod is None else rod
    vals, ders = disc.interpolate(eq.U.ravel())
    at = rod.kappa_ref_at(disc.s_quad)  # per point (segments), or None: the rod's, uniform
    ref = [float(k) for k in rod.kappa_ref] if at is None else [at[..., i] for i in range(3)]
    if model == PLANAR:
        k2, nu1, nu3 = kin.planar_strains(ders[0], ders[1], vals[2], ders[2])
        shear = np.hypot(nu1, nu3 - 1.0)
        bend = np.abs(k2 - ref[1])
    else:
        kappa, nu = kin.strains(ders[:3], vals[3:], ders[3:], kin.NORMALISED)
        shear = np.sqrt(nu[0] ** 2 + nu[1] ** 2 + (nu[2] - 1.0) ** 2)
        bend = np.sqrt(sum((kappa[i] - ref[i]) ** 2 for i in range(3)))
    return disc.s_quad, shear, bend


def planar_point_strains(disc, U: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(|nu - e3|, |kappa - kappa_ref|) of :func:`point_strains` for N planar states U (N, nscalar 3)
    on one mesh at once; ``ref`` the precurvatures about the plane normal (N, ne, nq)."""
    Ue = U.reshape(U.shape[0], disc.nscalar, 3)[:, disc.edofs.T]  # (N, ne, nloc, 3)
    z = np.matmul(disc.point_table, Ue).reshape(U.shape[0], disc.ne, -1, 2, 3)
    k2, nu1, nu3 = kin.planar_strains(z[..., 1, 0], z[..., 1, 1], z[..., 0, 2], z[..., 1, 2])
    return np.hypot(nu1, nu3 - 1.0), np.abs(k2 - ref)


def strain_warnings(eq, rod=None, strains=None) -> list[str]:
    """Warnings for strains outside the linear law's range in a converged cantilever state;
    ``strains``: its (s, shear, bend) of :func:`point_strains` when already computed."""
    scene = eq.scene
    L, radius = scene.rod.length, 0.5 * _outer_diameter(scene, eq)
    s, shear, bend = point_strains(eq, rod) if strains is None else strains
    out = []
    i = int(np.argmax(shear))
    if shear.flat[i] > LINEAR_RANGE:
        out.append(
            f"strain outside the linear law's range: |nu - e3| = {shear.flat[i]:.3g} at s = "
            f"{s.flat[i] * L * 1e3:.4g} mm (above {LINEAR_RANGE}): shear/extension beyond eq. (6)"
        )
    curvature = bend / L * radius
    widest = float(radius.max())  # the method: no np.max dispatch (~2 us a call)
    j = int(np.argmax(curvature if widest > 0 else bend))
    if widest > 0 and np.ravel(curvature)[j] > LINEAR_RANGE:
        out.append(
            f"strain outside the linear law's range: |kappa - kappa_ref| R_o = {np.ravel(curvature)[j]:.3g} "
            f"at s = {s.flat[j] * L * 1e3:.4g} mm (above {LINEAR_RANGE}): bending/twist beyond eq. (6)"
        )
    elif widest == 0 and bend.flat[j] > 1.0:
        out.append("no rod.outer_diameter: the bending strain |kappa - kappa_ref| R_o could not be checked")
    return out


def _outer_diameter(scene, eq) -> np.ndarray | float:
    """The outer diameter at the quadrature points (segment overrides), or the rod's."""
    s = eq.disc.s_quad * scene.rod.length
    d = np.full(s.shape, scene.rod.outer_diameter)
    for seg in scene.rod.segments:
        if "outer_diameter" in seg.overrides:
            d[(s >= seg.start) & (s < seg.end)] = seg.overrides["outer_diameter"]
    return d


def penalty_error(eq) -> float:
    """The raw variant's penalty error of the tip (relative to L): its state minus the normalised
    variant's on the same mesh (where |q| = 1 exactly, the limit c_u -> infinity of the raw one)."""
    exact = equilibrium(eq.scene, elements=eq.disc.ne, model=eq.model, element=eq.disc.element, start=eq)
    return float(np.max(np.abs(eq.tip() - exact.tip())))
