"""Inputs and outputs: studies, ingest of test-machine records, results, exports and publishing."""
