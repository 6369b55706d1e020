"""The application layer: the CLI, the pipeline of a study, batches, comparison and the Python API."""
