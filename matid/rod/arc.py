"""Newton's start for a precurved rod: its unloaded shape, the arc (issue 32 item 3).

A rod of uniform precurvature k (scaled, in the director frame) is unstrained when it turns about
the fixed axis k / |k| by |k| s: q(s) = (cos(|k| s / 2), sin(|k| s / 2) k / |k|) has
kappa = 2 G(q) q' = k (:mod:`matid.physics.kinematics`), and r' = d3 (nu = e3). Newton at the
full load starts there (:func:`matid.rod.cantilever.equilibrium`) instead of continuing the load
(and the precurvature with it) from the straight rod: the 45-degree 3D bend of the peers bench
took 7 iterations on its coarse mesh instead of 9.
"""

from __future__ import annotations

import numpy as np

from matid.rod.models import PLANAR


def arc(system) -> np.ndarray | None:
    """The unloaded rod of uniform precurvature k (scaled), unstrained, at every dof (nscalar, nf):
    the circular arc (a planar theta = k2 s) about the clamp's axis k / |k| rotated by |k| s;
    None when the rod is straight or its precurvature varies along it (segments)."""
    k = np.asarray(system.rod.kappa_ref, float)
    if system.kappa is not None or not k.any():
        return None
    s = system.disc.s_dof
    if system.model == PLANAR:
        k2 = float(k[1])  # the plane's normal component (the scene's plane is e_a, e3)
        if k2 == 0.0:
            return None
        th = k2 * s
        return np.stack([(1.0 - np.cos(th)) / k2, np.sin(th) / k2, th], axis=1)
    size = float(np.sqrt(k @ k))
    axis, phi = k / size, size * s
    c, sn = np.cos(phi), np.sin(phi)
    # d3 = c e3 + (1 - c)(a.e3) a + sin (a x e3), integrated from the clamp (a x e3 = (a2, -a1, 0))
    U = np.empty((s.size, 7))
    U[:, :3] = ((s - sn / size) * axis[2])[:, None] * axis
    U[:, 0] += ((1.0 - c) / size) * axis[1]
    U[:, 1] += ((1.0 - c) / size) * -axis[0]
    U[:, 2] += sn / size
    U[:, 3] = np.cos(0.5 * phi)  # kappa = 2 G(q) q' = k
    U[:, 4:] = np.sin(0.5 * phi)[:, None] * axis
    return U
