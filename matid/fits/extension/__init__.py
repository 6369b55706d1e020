"""The extension (viscoelastic) fits: SLS and Prony, runs, statistics."""
