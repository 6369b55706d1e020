"""Every ``parametrize`` of the suite takes a collection, never an iterator.

A generator is used up by the first collection: a second collection in the same process (mutmut
collects and runs the tests several times in one process: benchmarks/mutation.sh) finds none of
its cases, and pytest stops with a usage error.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator

from tests import ROOT

MODULES = sorted(
    ".".join(path.relative_to(ROOT).with_suffix("").parts) for path in (ROOT / "tests").rglob("test_*.py")
)


def _parametrized(module):
    for name, obj in vars(module).items():
        items = [(name, obj)]
        if isinstance(obj, type):  # a test class: its methods
            items += [(f"{name}.{n}", o) for n, o in vars(obj).items()]
        for label, item in items:
            for mark in getattr(item, "pytestmark", ()):
                if mark.name == "parametrize":
                    yield label, mark.args[1] if len(mark.args) > 1 else mark.kwargs["argvalues"]


def test_every_parametrize_takes_a_collection():
    assert len(MODULES) > 50
    iterators = [
        f"{module}.{label}"
        for module in MODULES
        for label, values in _parametrized(importlib.import_module(module))
        if isinstance(values, Iterator)
    ]
    assert not iterators, iterators
