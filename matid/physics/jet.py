"""Second-order forward-mode differentiation over arrays of points ("jets").

A :class:`Jet` carries, at every quadrature point at once, a value ``v`` of
shape ``P``, its gradient ``g`` of shape ``P + (n,)`` and Hessian ``h`` of shape
``P + (n, n)`` with respect to ``n`` local variables. The arithmetic rules are
the product and quotient rules,

    (ab)'  = a'b + ab'            (ab)''  = a''b + ab'' + a'b'^T + b'a'^T
    (1/b)' = -b'/b^2              (1/b)'' = -b''/b^2 + 2 b'b'^T/b^3

so that the energy densities of the rod models, written once as plain
arithmetic (see :mod:`matid.physics.kinematics`), give their exact gradient and
Hessian pointwise, which the assembly in :mod:`matid.rod.fem` turns into the
residual and the tangent. Plain numpy arrays pass through the same code.
"""

from __future__ import annotations

import numpy as np


class Jet:
    __slots__ = ("v", "g", "h")
    __array_priority__ = 100  # numpy scalars defer to Jet's reflected operators

    def __init__(self, v: np.ndarray, g: np.ndarray, h: np.ndarray) -> None:
        self.v, self.g, self.h = v, g, h

    @classmethod
    def variables(cls, values: np.ndarray, *, hessian: bool = True) -> list[Jet]:
        """Independent variables: ``values`` has shape ``(n,) + P``.

        With ``hessian=False`` only gradients are carried (h is None): a residual
        without its tangent, at a fraction of the cost.
        """
        n = values.shape[0]
        shape = values.shape[1:]
        eye = np.eye(n)
        zero_h = np.zeros(shape + (n, n)) if hessian else None
        return [cls(values[k], np.broadcast_to(eye[k], shape + (n,)), zero_h) for k in range(n)]

    # -- arithmetic -------------------------------------------------------
    def __add__(self, other: object) -> Jet:
        if isinstance(other, Jet):
            h = None if self.h is None else self.h + other.h
            return Jet(self.v + other.v, self.g + other.g, h)
        return Jet(self.v + other, self.g, self.h)

    __radd__ = __add__

    def __neg__(self) -> Jet:
        return Jet(-self.v, -self.g, None if self.h is None else -self.h)

    def __sub__(self, other: object) -> Jet:
        return self + (-other)

    def __rsub__(self, other: object) -> Jet:
        return (-self) + other

    def __mul__(self, other: object) -> Jet:
        if isinstance(other, Jet):
            a, b = self, other
            ga, gb = a.g, b.g
            h = None
            if a.h is not None:
                cross = ga[..., :, None] * gb[..., None, :]
                h = (
                    a.v[..., None, None] * b.h
                    + b.v[..., None, None] * a.h
                    + cross
                    + np.swapaxes(cross, -1, -2)
                )
            return Jet(a.v * b.v, a.v[..., None] * gb + b.v[..., None] * ga, h)
        c = np.asarray(other)
        h = None if self.h is None else self.h * c[..., None, None]
        return Jet(self.v * c, self.g * c[..., None], h)

    __rmul__ = __mul__

    def reciprocal(self) -> Jet:
        inv = 1.0 / self.v
        inv2 = inv * inv
        g = -self.g * inv2[..., None]
        h = None
        if self.h is not None:
            h = -self.h * inv2[..., None, None] + 2.0 * (inv2 * inv)[..., None, None] * (
                self.g[..., :, None] * self.g[..., None, :]
            )
        return Jet(inv, g, h)

    def __truediv__(self, other: object) -> Jet:
        if isinstance(other, Jet):
            return self * other.reciprocal()
        return self * (1.0 / np.asarray(other))

    def __rtruediv__(self, other: object) -> Jet:
        return self.reciprocal() * other


def apply(f_v: np.ndarray, f_d: np.ndarray, f_dd: np.ndarray, x: Jet) -> Jet:
    """Chain rule for a scalar function with value, first and second derivative at x.v."""
    g = f_d[..., None] * x.g
    if x.h is None:
        return Jet(f_v, g, None)
    h = f_d[..., None, None] * x.h + f_dd[..., None, None] * (x.g[..., :, None] * x.g[..., None, :])
    return Jet(f_v, g, h)


def sin(x: Jet | np.ndarray) -> Jet | np.ndarray:
    if isinstance(x, Jet):
        s, c = np.sin(x.v), np.cos(x.v)
        return apply(s, c, -s, x)
    return np.sin(x)


def cos(x: Jet | np.ndarray) -> Jet | np.ndarray:
    if isinstance(x, Jet):
        s, c = np.sin(x.v), np.cos(x.v)
        return apply(c, -s, -c, x)
    return np.cos(x)
