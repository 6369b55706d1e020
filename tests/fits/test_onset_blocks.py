"""The onset test's noise series on long records is built a block of rows at a time (memory of
the 7.4e6-row torsion record: benchmarks/README.md, issue 32.4): the same fit as in one piece."""

from __future__ import annotations

import numpy as np

from matid.fits import onset


def _record(n: int = 5003):
    rng = np.random.default_rng(7)
    u = np.sort(rng.uniform(-1.0, 1.0, n))
    noise = np.empty(n)
    noise[0] = rng.normal()
    for i in range(1, n):  # AR(1), rho 0.6: a variance factor well away from 1
        noise[i] = 0.6 * noise[i - 1] + rng.normal()
    y = np.sin(2.0 * u) + 0.3 * u**2 + 1e-3 * noise
    return u, y, np.arange(n)  # recorded in increasing u: the noise's correlation is along it


def test_blocks_give_the_one_piece_noise_factor(monkeypatch):
    u, y, order = _record()
    whole = onset._noise_factor(u, y, order)
    assert u.size * (onset.NOISE_DEGREE + 1) <= onset.SCAN_BLOCK  # one block at the default
    monkeypatch.setattr(onset, "SCAN_BLOCK", 700 * (onset.NOISE_DEGREE + 1))  # 8 blocks, the last short
    blocks = onset._noise_factor(u, y, order)
    assert whole[0] > 1.5  # the correlated noise is seen
    np.testing.assert_allclose(blocks, whole, rtol=1e-9)


def test_blocks_give_the_one_piece_residuals(monkeypatch):
    u, y, _ = _record()
    resid, rank = onset._legendre_fit(u, y, 12)
    monkeypatch.setattr(onset, "SCAN_BLOCK", 1000 * 13)
    blocked, blocked_rank = onset._legendre_fit(u, y, 12)
    assert blocked_rank == rank == 13
    assert np.max(np.abs(blocked - resid)) <= 1e-9 * np.max(np.abs(resid))
