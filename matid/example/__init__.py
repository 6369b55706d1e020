"""The embedded synthetic demo study (SYNTHETIC data, not a measurement).

This folder ships as the package ``matid.example``. It holds a small demo
study (``study.toml`` plus CSV files and ``ground_truth.json``) and the
generator that wrote it, :mod:`matid.example.generate`; regenerate with
``python -m matid.example.generate``. See ``README.md`` here for the ground
truth, the noise model and which file exercises which CSV feature.
"""
