"""Coverage of the 95 % interval of E_e (extension fit), i.i.d. and AR(1)-correlated noise.

Run from the repository root: ``python benchmarks/extension_coverage.py [trials]``.
Each trial: three constant-rate ramps (10 tau, tau, tau/10) of a standard linear solid
(k1 = 50 N, k2 = 30 N, eta = 300 N s), 400 rows each, noise 0.3 % of each run's peak force,
either i.i.d. or AR(1) with coefficient 0.95 (stationary, same marginal sd). Prints the
share of trials whose 95 % interval of E_e holds k1, and how often a warning was given.
Target (issue 10): 90-98 % i.i.d., >= 85 % AR(1).

Measured 2026-11-23 (commit after f3fe803, 100 trials each): i.i.d. 98/100 covered, no
warning; AR(1) 0.95 93/100 covered, every trial warned (lack of fit / wandering noise);
the SLS was kept (E_e not from a Prony model) in all 200.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from matid.fits.extension.fit import fit_extension
from matid.fits.stats import ar1_noise
from matid.model import study
from matid.model.measurement import Measurement, Table
from matid.physics.sls import sls_ramp

K1, K2, ETA = 50.0, 30.0, 300.0
TAU = ETA / K2


def runs(seed: int, phi: float) -> list[Measurement]:
    rng = np.random.default_rng(seed)
    out = []
    for i, duration in enumerate([10 * TAU, TAU, 0.1 * TAU]):
        t = np.linspace(0.0, duration, 400)
        eps = 0.05 * t / duration
        force = sls_ramp(t, 0.05 / duration, K1, K2, ETA)
        noise = ar1_noise(rng, t.size, phi) if phi else rng.normal(size=t.size)
        force = force + 0.003 * force.max() * noise
        test = study.Test("extension", "T1", Path(f"r{i}.csv"), {"gauge_length": 0.05})
        out.append(
            Measurement(
                test, Table(Path(f"r{i}.csv"), {"time": t, "strain": eps, "force": force}, {}, {}, "")
            )
        )
    return out


def main(trials: int = 100) -> None:
    for phi in (0.0, 0.95):
        hits = warned = prony = 0
        start = time.perf_counter()
        for seed in range(trials):
            fit = fit_extension(runs(seed, phi), specimen="T1")
            est = fit.estimate("E_e")
            hits += est.ci95[0] < K1 < est.ci95[1]
            warned += bool(est.warnings)
            prony += est.method == "prony"
        elapsed = time.perf_counter() - start
        print(
            f"noise {'AR(1) 0.95' if phi else 'i.i.d.'}: E_e interval covers k1 in {hits}/{trials}; "
            f"warned {warned}/{trials}; E_e from a Prony model {prony}/{trials}; "
            f"{elapsed / trials:.2f} s/fit",
            flush=True,
        )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)
