"""Hypothesis profiles: "ci" (the default: short fuzz runs, no deadline) and "long" for fuzzing.

Select one with ``pytest --hypothesis-profile=long``. The fuzz tests
(tests/test_fuzz.py) run whole pipeline stages per example, so hypothesis'
per-example deadline is off; each case has its own wall-clock limit instead
(tests/fuzzkit.py) and a case past it counts as a hang.
"""

import os

from hypothesis import HealthCheck, settings

_SLOW_OK = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.large_base_example]

#: CI: about 200 examples across the fuzz tests, derandomised so a run is reproducible.
settings.register_profile(
    "ci", deadline=None, suppress_health_check=_SLOW_OK, derandomize=True, print_blob=True, max_examples=100
)
#: Long: tens of thousands of examples (benchmarks/fuzz.py sets how many per test).
settings.register_profile(
    "long",
    deadline=None,
    suppress_health_check=_SLOW_OK,
    print_blob=True,
    max_examples=int(os.environ.get("MATID_FUZZ_EXAMPLES", "5000")),
)
settings.load_profile("ci")
