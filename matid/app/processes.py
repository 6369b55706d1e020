"""Process-level helpers of the CLI and the report: when a second process may help, and the
cyclic collector around imports and forks.

The numerical stack lives as long as the process, so the collector is kept off it
(:func:`settled_imports`); a fork copies every page the collector touches, so the objects that
exist are frozen around it (:func:`frozen_collector`). Objects a host froze itself stay frozen:
``gc.unfreeze`` cannot tell them from ours, so where any are frozen nothing is frozen or unfrozen.
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import os
import sys
import threading
from collections.abc import Iterator


def can_fork() -> bool:
    """Whether a second process may help: Linux, two cores or more, one thread, not a
    multiprocessing worker (a batch run keeps the cores busy), ``MATID_REPORT_FORK`` not 0."""
    import multiprocessing

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    return (
        sys.platform.startswith("linux")  # macOS: fork after system frameworks are loaded is unsafe
        and cores > 1
        and threading.active_count() == 1
        and multiprocessing.parent_process() is None
        and os.environ.get("MATID_REPORT_FORK", "1") != "0"
    )


@contextlib.contextmanager
def frozen_collector() -> Iterator[None]:
    """``gc.freeze`` for the block and ``gc.unfreeze`` after it, unless objects are frozen already."""
    freeze = gc.get_freeze_count() == 0
    if freeze:
        gc.freeze()
    try:
        yield
    finally:
        if freeze:
            gc.unfreeze()


@contextlib.contextmanager
def settled_imports(*modules: str) -> Iterator[None]:
    """Import ``modules`` without the cyclic collector, then keep it off what they made.

    A numerical stack (the fits' scipy, pint and scikit-fem: ~130 000 objects; the report's
    matplotlib another ~100 000) lives as long as the process, yet each full collection
    walks all of it: in ``matid demo`` with both in one process that was 0.19 s during the
    imports and 0.37 s in five full collections after them (measured with gc.callbacks).
    ``gc.freeze`` moves what exists to a generation the collector skips; on the way out
    ``gc.unfreeze`` hands it back, since :func:`main` may run inside a longer-lived process
    (tests, notebooks). Garbage made inside the block is collected as usual. Where objects
    are frozen already (by the host, or an outer block) nothing is frozen or unfrozen:
    ``gc.unfreeze`` cannot tell them from ours (the rule of :mod:`matid.report.imagejob`).
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        for module in modules:
            importlib.import_module(module)
    finally:
        if enabled:
            gc.enable()
    with frozen_collector():
        yield
