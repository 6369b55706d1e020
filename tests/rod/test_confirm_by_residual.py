"""newton.confirm_by_residual: the deferred confirmation from a residual and the factor of the
iteration before (Equilibrium.confirmed), on a system whose root is known."""

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from matid.rod import newton as nw

ROOT = np.array([1.2, -0.7, 2.5])


class Cubic:
    """R = x^3 + x - lam c (root ROOT at lam = 1), tangent diag(3 x^2 + 1); ``off``: residuals off by
    this much; ``scale``: step_size = scale * max|dx| (a system that measures its own corrections);
    counts residual-only evaluations."""

    def __init__(self, off=0.0, scale=None):
        self.c, self.off, self.residuals = ROOT**3 + ROOT, off, 0
        if scale is not None:
            self.step_size = lambda dx: scale * float(np.abs(dx).max())

    def evaluate(self, x, lam, *, tangent=True):
        self.residuals += not tangent
        R = x**3 + x - lam * self.c + self.off
        return R, (sp.diags(3 * x**2 + 1, format="csc") if tangent else None)


def accepted(system, before=1e-9):
    """(x one quadratic step short of the root, NewtonInfo of a provisional Newton there): the factor
    at a point ``before`` from the root, ``last`` the correction it gave."""
    x_prev = ROOT + before
    lu = spla.splu(system.evaluate(x_prev, 1.0)[1])
    x = x_prev + lu.solve(-system.evaluate(x_prev, 1.0, tangent=False)[0])
    system.residuals = 0
    return x, nw.NewtonInfo(lu=lu, confirmed=False, last=before)


def test_a_converged_state_is_confirmed_by_one_residual():
    system = Cubic()
    x, info = accepted(system)
    done = nw.confirm_by_residual(system, x, 1.0, info)
    assert done is not None and system.residuals == 1
    np.testing.assert_allclose(done, ROOT, rtol=0, atol=1e-15)


def test_a_correction_above_xtol_is_no_confirmation():
    """Residuals off by 1e-7: the correction from them is ~1e-8 > XTOL: None (a full iteration follows)."""
    system = Cubic()
    x, info = accepted(system)
    system.off = 1e-7
    assert nw.confirm_by_residual(system, x, 1.0, info) is None


def test_the_correction_is_measured_by_the_systems_step_size():
    """A system's own step_size (BendSystem's): a correction of 1e-13 counted 1e4 times larger is
    above XTOL."""
    plain, scaled = Cubic(), Cubic(scale=1e4)
    for system, confirms in ((plain, True), (scaled, False)):
        x, info = accepted(system)
        system.off = 1e-12  # corrections ~1e-13
        assert (nw.confirm_by_residual(system, x, 1.0, info) is not None) is confirms


def test_no_confirmation_far_from_the_root_or_without_a_factor():
    system = Cubic()
    x, info = accepted(system)
    far = nw.NewtonInfo(lu=info.lu, confirmed=False, last=10 * nw.CHORD_LAST)
    for nfo in (far, nw.NewtonInfo(confirmed=False, last=1e-9)):
        assert nw.confirm_by_residual(system, x, 1.0, nfo) is None
    assert system.residuals == 0  # not even a residual


def test_a_non_finite_residual_or_correction_is_no_confirmation():
    system = Cubic()
    x, info = accepted(system)
    system.off = np.nan
    assert nw.confirm_by_residual(system, x, 1.0, info) is None
