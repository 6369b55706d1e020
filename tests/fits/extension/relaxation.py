"""Long ramp-and-hold relaxation records matid did not make, for the tests and benchmarks.

The force comes from ``scipy.integrate.solve_ivp`` of the generalised Maxwell (Prony) ODE
``f_i' = k_i eps' - f_i / tau_i``, ``F = k0 eps + sum_i f_i`` (not from
:mod:`matid.physics.sls`), plus AR(1) noise, and is written as an Instron Bluehill raw-data
export (a quoted CSV: a "Name:","value" preamble, a blank line, the quoted column names, the
quoted units row in parentheses; see tests/corpus/bluehill_tension.csv).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from tests.fits.extension.test_sls_independent import ar1  # AR(1) noise written out, not matid's

#: Equilibrium stiffness and two arms (N, N, s): a fast and a slow relaxation.
K0 = 40.0
ARMS = ((25.0, 4.0), (15.0, 150.0))
GAUGE = 0.05  # m
STRAIN = 0.04  # ramp end
RATE = 0.01  # 1/s: a 4 s ramp
NOISE = 0.004  # N, marginal sd of the AR(1) noise
PHI = 0.8


def prony_record(n: int, dt: float, arms=ARMS, k0: float = K0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, strain, force) of a ramp to STRAIN at RATE, then a hold, n rows at step dt."""
    t = np.arange(n) * dt
    t_ramp = STRAIN / RATE
    ramp = t <= t_ramp
    ks = np.array([k for k, _ in arms])
    taus = np.array([tau for _, tau in arms])
    opts = dict(method="DOP853", rtol=1e-11, atol=1e-13)
    up = solve_ivp(
        lambda s, f: ks * RATE - f / taus, (0.0, t_ramp), np.zeros(len(arms)), dense_output=True, **opts
    )
    hold = solve_ivp(lambda s, f: -f / taus, (t_ramp, t[-1]), up.sol(t_ramp), t_eval=t[~ramp], **opts)
    arm_force = np.concatenate([up.sol(t[ramp]).sum(axis=0), hold.y.sum(axis=0)])
    eps = np.minimum(RATE * t, STRAIN)
    return t, eps, k0 * eps + arm_force


def write_bluehill(path: Path, t, extension_m, load_n, sample: str = "R1") -> None:
    """Instron Bluehill raw data: quoted preamble, blank line, quoted names and units (s, mm, N)."""
    head = [
        f'"Sample ID:","{sample}"',
        '"Method:","Relaxation catheter.im_tens"',
        "",
        '"Time","Extension","Load"',
    ]
    head.append('"(s)","(mm)","(N)"')
    rows = [f'"{a:.5f}","{b:.6f}","{c:.6f}"' for a, b, c in zip(t, extension_m * 1e3, load_n, strict=True)]
    path.write_text("\n".join(head + rows) + "\n", encoding="utf-8")


def make_study(folder: Path, *, n: int, dt: float, seed: int = 0, arms=ARMS) -> Path:
    """A study of one relaxation record of n rows (Bluehill CSV) for specimen R1."""
    folder.mkdir(parents=True, exist_ok=True)
    t, eps, force = prony_record(n, dt, arms)
    force = force + ar1(np.random.default_rng(seed), n, PHI, NOISE)
    write_bluehill(folder / "relax.csv", t, eps * GAUGE, force)
    toml = (
        '[study]\nname = "long relaxation"\n\n'
        '[[specimen]]\nid = "R1"\nouter_diameter = "2.4 mm"\ninner_diameter = "1.6 mm"\n\n'
        '[[test]]\nkind = "extension"\nspecimen = "R1"\nfile = "relax.csv"\ngauge_length = "50 mm"\n'
        'columns = { time = "Time", elongation = "Extension", force = "Load" }\n'
    )
    (folder / "study.toml").write_text(toml, encoding="utf-8")
    return folder / "study.toml"
