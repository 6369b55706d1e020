"""Kinematics and energy densities of the special Cosserat rod (paper eqs. 2-10).

Directors from a quaternion q = (q0, qv), eq. (2):

    R(q) = [d1 d2 d3] = (q0^2 - qv.qv) I + 2 qv qv^T + 2 q0 [qv]x

Strains, eqs. (3)-(4): kappa_i = 1/2 eps_ijk d_j'.d_k and nu_i = r'.d_i. With
directors from the raw q (the paper's choice) R(q) = |q|^2 R(q/|q|), so

    kappa = 2 |q|^2 G(q) q',   nu = R(q)^T r',   G(q) q' = q0 qv' - q0' qv - qv x qv'

and with directors from q/|q| (the normalised variant)

    kappa = 2 G(q) q' / |q|^2,   nu = R(q)^T r' / |q|^2,

which do not depend on |q| at all: the unity penalty c_u/2 (|q|^2 - 1)^2 of
eq. (5) then only removes the null direction instead of fighting the strain
energy. Strain energy per length, eq. (6), magnetic energy eq. (9):

    W   = 1/2 [E_b (k1^2 + k2^2) + E_t k3^2 + E_s (nu1^2 + nu2^2) + E_e (nu3 - 1)^2]
    U_m = -mu d3 . B

with kappa - kappa_ref for a precurved rod. The planar reduction (rod in the
plane spanned by e3 and e1, rotated by theta about e2) has

    d1 = (cos t, 0, -sin t), d3 = (sin t, 0, cos t), kappa2 = theta',
    nu1 = x' cos t - z' sin t,  nu3 = x' sin t + z' cos t.

Every function is plain arithmetic, so it runs on numpy arrays (values) and on
:class:`matid.physics.jet.Jet` (values with exact gradient and Hessian) alike.
"""

from __future__ import annotations

from collections.abc import Sequence

from matid.physics import jet

#: Quaternion treatments of physics.md section 3.
RAW, NORMALISED = "raw", "normalised"


def directors(q: Sequence) -> list[list]:
    """R(q) of eq. (2) as nested lists, ``R[i][j]`` = component i of d_j (not normalised)."""
    q0, q1, q2, q3 = q
    a = q0 * q0 - (q1 * q1 + q2 * q2 + q3 * q3)
    return [
        [a + 2 * q1 * q1, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
        [2 * (q2 * q1 + q0 * q3), a + 2 * q2 * q2, 2 * (q2 * q3 - q0 * q1)],
        [2 * (q3 * q1 - q0 * q2), 2 * (q3 * q2 + q0 * q1), a + 2 * q3 * q3],
    ]


def norm2(q: Sequence):
    q0, q1, q2, q3 = q
    return q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3


def curvature_numerator(q: Sequence, dq: Sequence) -> list:
    """2 G(q) q' = 2 (q0 qv' - q0' qv - qv x qv'): the body-frame curvature for unit q."""
    q0, q1, q2, q3 = q
    p0, p1, p2, p3 = dq
    return [
        2 * (q0 * p1 - p0 * q1 - (q2 * p3 - q3 * p2)),
        2 * (q0 * p2 - p0 * q2 - (q3 * p1 - q1 * p3)),
        2 * (q0 * p3 - p0 * q3 - (q1 * p2 - q2 * p1)),
    ]


def strains(dr: Sequence, q: Sequence, dq: Sequence, variant: str = NORMALISED) -> tuple[list, list]:
    """(kappa, nu) of eqs. (3)-(4) in the director frame, for either quaternion treatment."""
    n2 = norm2(q)
    kn = curvature_numerator(q, dq)
    R = directors(q)
    nu = [R[0][i] * dr[0] + R[1][i] * dr[1] + R[2][i] * dr[2] for i in range(3)]
    if variant == RAW:
        return [n2 * k for k in kn], nu
    inv = 1.0 / n2
    return [k * inv for k in kn], [v * inv for v in nu]


def d3(q: Sequence, variant: str = NORMALISED) -> list:
    """The third director (tangent of an unsheared rod), raw or from q/|q|."""
    return director(q, 2, variant)


def director(q: Sequence, j: int, variant: str = NORMALISED) -> list:
    """The director d_(j+1) (j = 0, 1, 2), raw or from q/|q|."""
    R = directors(q)
    col = [R[0][j], R[1][j], R[2][j]]
    if variant == RAW:
        return col
    inv = 1.0 / norm2(q)
    return [c * inv for c in col]


def strain_energy(kappa: Sequence, nu: Sequence, E_b, E_t, E_s, E_e, kappa_ref=(0.0, 0.0, 0.0)):
    """W of eq. (6), with kappa - kappa_ref for a precurved rod."""
    k1, k2, k3 = (kappa[i] - kappa_ref[i] for i in range(3))
    nu3 = nu[2] - 1.0
    return 0.5 * (
        E_b * (k1 * k1 + k2 * k2)
        + E_t * (k3 * k3)
        + E_s * (nu[0] * nu[0] + nu[1] * nu[1])
        + E_e * (nu3 * nu3)
    )


def magnetic_energy(mu, d3_vec: Sequence, B: Sequence):
    """U_m = -mu d3 . B, eq. (9)."""
    return -mu * (d3_vec[0] * B[0] + d3_vec[1] * B[1] + d3_vec[2] * B[2])


def unity_penalty(q: Sequence, c_u):
    """c_u P with P = 1/2 (|q|^2 - 1)^2, eq. (5)."""
    e = norm2(q) - 1.0
    return 0.5 * c_u * (e * e)


def planar_strains(dx, dz, theta, dtheta) -> tuple:
    """(kappa2, nu1, nu3) of the planar reduction."""
    c, s = jet.cos(theta), jet.sin(theta)
    return dtheta, dx * c - dz * s, dx * s + dz * c


def planar_strain_energy(kappa2, nu1, nu3, E_b, E_s, E_e, kappa_ref=0.0):
    """W of eq. (6) restricted to the plane: 1/2 [E_b (theta' - k_ref)^2 + E_s nu1^2 + E_e (nu3 - 1)^2]."""
    k = kappa2 - kappa_ref
    e = nu3 - 1.0
    return 0.5 * (E_b * (k * k) + E_s * (nu1 * nu1) + E_e * (e * e))
