"""Three-point bend: frictionless sliding contact of the tube with three cylinders.

Half model by symmetry: s in [0, L/2] from mid-span (s = 0, where z = 0 and
theta = 0) to the free end. In the plane, x is vertical (up) and z runs along
the span. Contact is between the tube surface and a cylinder, i.e. between the
centreline and a circle of radius rho = R + R_o (physics.md section 4):

    support: centre (-rho_s, S/2),  nose: centre (rho_n - d, 0)

so that the straight tube at x = 0 touches all three at d = 0.

Which cross-section touches? The one whose plane holds the cylinder axis,

    h = (r - c) . d3 = 0,     gap g = |r - c| - rho = 0,

(the tube surface point r + R_o d1 of that section is the one on the cylinder).
For an unshearable rod d3 = r'/|r'| and this is the closest point. For a
shear-deformable rod it is the right condition and the closest point is not: a
point load puts a corner of angle nu1 = lam/E_s into the centreline, which P2
elements smooth over one element, so on fine meshes the discrete centreline
conforms to the circle and its closest point degenerates (measured: Newton
2-cycles at 24 elements). h is continuous with dh/ds = nu3 + ... > 0, so the
section is unique and moves smoothly; at mid-span symmetry puts it at s = 0,
the load point of the classic Timoshenko formula.

Each contact sits on a mesh vertex, where the corner belongs: the nose on
vertex 0, the support on a vertex whose position is a Newton unknown with the
equation h = 0 (:class:`matid.rod.terms.supports.Support`). This module gives, at a
vertex, the gap g with its gradient and Hessian in (x, z, theta) and the
section function h with its gradient; n = (r - c)/|r - c| is the contact normal
and the nose force of the whole tube is F = 2 lam_nose (-n_x).
"""

from __future__ import annotations

import math

import numpy as np


class Circle:
    """A rigid circle (cylinder axis out of the plane) the tube must stay outside of."""

    def __init__(self, centre: tuple[float, float], radius: float):
        self.centre = (float(centre[0]), float(centre[1]))
        self.radius = float(radius)

    def gap(self, x: float, z: float) -> tuple[float, float, float, float]:
        """(g, n_x, n_z, |r - c|) at a point r = (x, z), in plain floats (the Newton hot path)."""
        dx, dz = x - self.centre[0], z - self.centre[1]
        d = max(math.hypot(dx, dz), 1e-300)  # a wild iterate may hit the centre
        return d - self.radius, dx / d, dz / d, d

    def section(self, U: np.ndarray, vertex: int) -> tuple[float, np.ndarray]:
        """h = (r_v - c) . d3(theta_v) at a vertex and its gradient in (x_v, z_v, theta_v)."""
        x, z, th = (float(v) for v in U[vertex])
        dx, dz = x - self.centre[0], z - self.centre[1]
        s, c = math.sin(th), math.cos(th)
        return dx * s + dz * c, np.array([s, c, dx * c - dz * s])
