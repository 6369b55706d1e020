#!/bin/sh
# matid's whole solve() against the solve_bvp baseline on the three problems of issue 13
# (interleaved, best of 5, tip errors against a tight reference); prints the ratio table.
exec python -m matid bench --sections peers --out benchmarks/results/peers "$@"
