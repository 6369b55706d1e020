"""transfer.interpolate_warm: the warm start's quartic through an element's nodes and its nearer
neighbour's, never across a break (matid.rod.cantilever._warm)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from matid.rod.transfer import interpolate_p2, interpolate_warm


def nodes(v):
    out = np.empty(2 * v.size - 1)
    out[::2], out[1::2] = v, 0.5 * (v[1:] + v[:-1])
    return out


def bisected(v):
    """The nodes of the mesh with every element of v halved (the next mesh of the error estimate)."""
    return nodes(np.sort(np.concatenate([v, 0.5 * (v[1:] + v[:-1])])))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=5, max_size=5), st.integers(2, 9))
def test_a_quartic_inside_one_piece_is_reproduced(coefficients, ne):
    """Inside one piece of at least two elements every quartic is reproduced at the bisected mesh's
    nodes (to round-off); the P2 interpolant is off by up to its cubic and quartic terms there."""
    v = np.linspace(0.0, 1.0, ne + 1)
    poly = np.polynomial.Polynomial(coefficients)
    values = poly(nodes(v))[:, None]
    s = bisected(v)
    got = interpolate_warm(v, values, s, np.array([], float).tobytes())[:, 0]
    np.testing.assert_allclose(got, poly(s), rtol=0, atol=1e-11 * (1 + np.abs(coefficients).sum()))


def test_p2_misses_a_quartic_that_the_warm_start_reproduces():
    v = np.linspace(0.0, 1.0, 5)
    values = (nodes(v) ** 4)[:, None]
    s = bisected(v)
    assert np.abs(interpolate_p2(v, values, s)[:, 0] - s**4).max() > 1e-4
    assert np.abs(interpolate_warm(v, values, s, b"")[:, 0] - s**4).max() < 1e-13


def test_no_stencil_crosses_a_break():
    """A field that kinks at a break (another quartic on each side, continuous) is reproduced on both sides:
    no point reads a node across the break; a piece of one element falls back to P2 (exact on
    quadratics)."""
    v = np.array([0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0])
    P = np.polynomial.Polynomial
    left = P([0.1, -2, 3, 1, -4])
    right = left + P([-0.5, 1]) * P([1, 2, -1, 3])  # continuous at 0.5, every derivative jumps
    x = nodes(v)
    values = np.where(x <= 0.5, left(x), right(x))[:, None]
    s = bisected(v)
    got = interpolate_warm(v, values, s, np.array([0.5]).tobytes())[:, 0]
    want = np.where(s <= 0.5, left(s), right(s))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # a one-element piece [0.875, 1]: P2 there, exact on a quadratic only
    quad = left(0.875) + P([-0.875, 1]) * P([-1.0, 2.0])  # a quadratic, continuous at 0.875
    values = np.where(x <= 0.875, left(x), quad(x))[:, None]
    got = interpolate_warm(v, values, s, np.array([0.875]).tobytes())[:, 0]
    np.testing.assert_allclose(got, np.where(s <= 0.875, left(s), quad(s)), rtol=0, atol=1e-12)


def test_without_breaks_it_is_the_p2_interpolant():
    """breaks None (a state with contact: its forces kink the fields anywhere): P2, bit for bit."""
    rng = np.random.default_rng(3)
    v = np.sort(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, 5)]))
    values = rng.normal(size=(2 * v.size - 1, 3))
    s = bisected(v)
    assert np.array_equal(interpolate_warm(v, values, s, None), interpolate_p2(v, values, s))


def test_each_point_reads_its_element_and_the_nearer_neighbour():
    """The stencil of a point is its element's 3 nodes and the 2 of the neighbour on its side (the
    other side at the rod's ends): checked against numpy's quartic through those 5 nodes, on a field
    no quartic reproduces."""
    v = np.linspace(0.0, 1.0, 6)
    x = nodes(v)
    f = np.exp(3.0 * x) * np.sin(5.0 * x)
    for s in (0.03, 0.17, 0.23, 0.37, 0.5, 0.61, 0.79, 0.97):
        e = min(int(s / 0.2), 4)
        near_left = s - v[e] < v[e + 1] - s
        first = 2 * e - 2 if (near_left and e > 0) or e == 4 else 2 * e
        xs = x[first : first + 5]
        want = np.polynomial.Polynomial.fit(xs, f[first : first + 5], 4)(s)
        got = interpolate_warm(v, f[:, None], np.array([s]), b"")[0, 0]
        assert abs(got - want) <= 1e-12, s
