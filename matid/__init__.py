"""matid: stiffness identification of catheter tubes for special Cosserat rod models.

Pipeline: study -> measurements -> fits -> results -> report/export,
and scene -> solve -> solution for the embedded rod solver (:mod:`matid.rod`).

From Python (docs/contract.md section 8)::

    import matid
    result = matid.fit("data/example")   # -> matid.FitResult
    result.table()                       # pandas DataFrame
    result.write("reports/example")      # the files of `matid fit`

The API functions import the numerical stack on first use, so ``import matid``
itself is cheap.
"""

__version__ = "0.1.0"

__all__ = ["FitResult", "__version__", "fit", "load_study"]

#: The API, imported on first use: name -> its module.
_API = {"fit": "matid.app.api", "FitResult": "matid.app.api", "load_study": "matid.io.study"}


def __getattr__(name: str):
    if name in _API:
        import importlib

        return getattr(importlib.import_module(_API[name]), name)
    raise AttributeError(f"module 'matid' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API))
