#!/bin/sh
# Run the full matid bench from the repository root; results are not committed.
exec matid bench --out benchmarks/results "$@"
