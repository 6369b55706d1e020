"""Coverage of the 95 % intervals on long relaxation records fitted on bin means.

Run from the repository root: ``python benchmarks/extension_long_coverage.py [trials] [rows]``.
Each trial: one ramp (4 s) and hold of ``rows`` rows at 0.5 s (default 6000: above
:data:`matid.fits.extension.reduce.REDUCE_ABOVE`, so the fit runs on bin means), from
solve_ivp of a standard linear solid (k1 = 40 N, k2 = 25 N, tau = 10 s) and of a 2-arm
Prony solid (tests/fits/extension/relaxation.py), AR(1) noise phi = 0.8, sd 4 mN. Prints,
per parameter, the share of trials whose 95 % interval holds the true value.

Measured 2026-11-26 (branch lmfit, load ~13 on 2 cores), 40 trials of 6000 rows: SLS
sls_k1 38/40, sls_k2 39/40, sls_eta 37/40 (3.1 s per fit); 2-arm Prony prony_k0 37/40,
prony_k1 39/40, prony_tau1 38/40, prony_k2 37/40, prony_tau2 36/40 (1.5 s per fit).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from matid.fits.extension.fit import fit_extension  # noqa: E402
from matid.model import study  # noqa: E402
from matid.model.measurement import Measurement, Table  # noqa: E402
from tests.fits.extension.relaxation import ARMS, GAUGE, K0, NOISE, PHI, ar1, prony_record  # noqa: E402

CASES = {
    "SLS": (((25.0, 10.0),), {"sls_k1": K0, "sls_k2": 25.0, "sls_eta": 250.0}),
    "2-arm Prony": (
        ARMS,
        {"prony_k0": K0, "prony_k1": ARMS[0][0], "prony_tau1": ARMS[0][1]}
        | {"prony_k2": ARMS[1][0], "prony_tau2": ARMS[1][1]},
    ),
}


def measurement(t, eps, force) -> Measurement:
    test = study.Test("extension", "R1", Path("relax.csv"), {"gauge_length": GAUGE})
    return Measurement(test, Table(Path("relax.csv"), {"time": t, "strain": eps, "force": force}, {}, {}, ""))


def main(trials: int = 40, rows: int = 6000) -> None:
    for label, (arms, truth) in CASES.items():
        t, eps, clean = prony_record(rows, 0.5, arms)
        hits = dict.fromkeys(truth, 0)
        start = time.perf_counter()
        for seed in range(trials):
            force = clean + ar1(np.random.default_rng(seed), rows, PHI, NOISE)
            fit = fit_extension([measurement(t, eps, force)], specimen="R1")
            got = {e.parameter: e for e in fit.estimates}
            for name, value in truth.items():
                ci = got[name].ci95 if name in got else None
                hits[name] += ci is not None and ci[0] <= value <= ci[1]
        per_fit = (time.perf_counter() - start) / trials
        shares = ", ".join(f"{name} {n}/{trials}" for name, n in hits.items())
        print(f"{label} ({rows} rows, {per_fit:.2f} s per fit): {shares}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
