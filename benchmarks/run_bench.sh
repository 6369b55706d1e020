#!/bin/sh
# Run the full matid bench of this checkout from the repository root; results are not committed.
exec python -m matid bench --out benchmarks/results "$@"
