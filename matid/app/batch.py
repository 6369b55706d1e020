"""Many studies in one run: ``matid fit A B C --out DIR [--jobs N | --scheduler ADDRESS]``.

docs/contract.md section 8. Each study is fitted by :func:`fit_one`, a task with
plain arguments and a plain result that never raises, so it runs the same in this
process, in a local process pool (``--jobs``) or on a Dask cluster
(``--scheduler``). Each writes ``DIR/<study folder name>/`` through
:func:`matid.app.pipeline.write_outputs`; then :func:`run_batch` writes
``DIR/summary.csv``, ``DIR/summary.xlsx`` and the comparison page
``DIR/summary.html`` (:mod:`matid.app.compare`). One failed study does not stop the
others; the exit code of the batch is the worst of the studies' (0 < 1 < 2 < 3 < 4).

On a Dask cluster the workers read the study folders and write into DIR by the
same paths as this process: the cluster must share that file system.

A batch stops whole (docs/contract.md section 11). Each local worker process runs a
thread that ends it (``os._exit``) as soon as the batch's process is gone (the
sentinel of :func:`multiprocessing.parent_process`, readable once the parent died,
even by SIGKILL) or the batch is stopped (a shared :class:`multiprocessing.Event`),
and a worker checks the event again just before it publishes. SIGINT (Ctrl-C) and,
while a batch runs in the main thread, SIGTERM (:class:`Terminated`) stop it: the
event is set, the pool's processes killed (:func:`multiprocessing.active_children`,
less the children this process had before), the queued studies cancelled,
temporary folders the workers left removed, and the interrupt raised on (exit 130
/ 143). Studies that finished keep their folders; no summary is written for an
interrupted batch.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from matid.app.outcome import SUMMARY_NAMES, StudyOutcome, error_message, exit_code, study_code
from matid.errors import DataError, MatidError

#: Seconds between a worker's looks at the batch's stop event (the parent's death wakes it at once).
WATCH_S = 0.05
#: The stop event of the batch in a worker process (None in the batch's own process and on Dask).
_STOP = None


class Terminated(KeyboardInterrupt):
    """SIGTERM during a batch: it stops as after Ctrl-C, and ``matid`` exits 143."""

    exit_code = 143


@dataclass(frozen=True)
class BatchResult:
    outcomes: list[StudyOutcome]  # in the order the studies were given
    paths: list[Path]  # the summary files

    @property
    def code(self) -> int:
        """The worst exit code of the studies."""
        return max((o.code for o in self.outcomes), default=0)


def study_folder_name(source: str | Path) -> str:
    """The name of the output folder of a study: its folder's name (the toml's folder for a toml path)."""
    path = Path(source).resolve()
    return path.parent.name if path.suffix.lower() == ".toml" else path.name


class Stopped(BaseException):
    """Raised in a worker whose batch was stopped, at the last moment before a study would be published
    (a BaseException: no ``except Exception`` on the way may turn it into an outcome)."""


def _unless_stopped() -> None:
    """Raise :class:`Stopped` once the batch's stop event is set (a worker's last look before publishing:
    the watching thread ends the process within WATCH_S, this closes that window)."""
    if _STOP is not None and _STOP.is_set():
        raise Stopped


def fit_one(source: str, out: str, units: str = "SI", strict: bool = False) -> StudyOutcome:
    """Load, fit and write one study into ``out``; never raises: errors become the outcome's code."""
    from matid.app.pipeline import run_study, write_outputs
    from matid.io.results import table_rows
    from matid.io.study import load_study

    clock = time.perf_counter()
    name = study_folder_name(source)
    try:
        result = run_study(load_study(source))
        _unless_stopped()
        paths = write_outputs(result, Path(out), units=units, before_swap=_unless_stopped)
    except Stopped:  # the batch was stopped: publish nothing more (the new folder is already gone)
        os._exit(Terminated.exit_code)
    except Exception as exc:  # the code and message of `matid fit`; a bug keeps its traceback for --debug
        code = exit_code(exc)
        error = error_message(exc) + (f"\n{traceback.format_exc()}" if code == 3 else "")
        return StudyOutcome(source, name, code, error=error, runtime_s=time.perf_counter() - clock)
    warnings = result.warnings()
    code = study_code(result, strict)
    return StudyOutcome(
        source,
        name,
        code,
        rows=table_rows(result, units),
        warnings=warnings,
        failures=[f"{f.specimen} {f.kind}: {f.reason}" for f in result.failures],
        paths=[str(p) for p in paths],
        runtime_s=time.perf_counter() - clock,
    )


def run_batch(
    sources: Sequence[str | Path],
    out: str | Path,
    *,
    units: str = "SI",
    jobs: int | None = None,
    scheduler: str | None = None,
    strict: bool = False,
    on_done: Callable[[StudyOutcome], None] | None = None,
) -> BatchResult:
    """Fit every study into ``out/<folder name>/`` and write the summary files; see the module docstring.

    ``jobs`` local processes (default: the number of cores; 1 runs in this process),
    or the Dask scheduler at ``scheduler``. ``on_done`` is called once per finished
    study, in completion order (for progress). Two studies with the same folder name
    would write into the same place: a DataError before anything runs.
    """
    out = Path(out)
    names = [study_folder_name(s) for s in sources]
    for source, name in zip(sources, names, strict=True):
        _check_folder_name(source, name, out)
    for name in names:
        if names.count(name) > 1:
            same = [str(s) for s, n in zip(sources, names, strict=True) if n == name]
            raise DataError(f"studies {', '.join(same)} share the folder name {name!r}; rename one", file=out)
    tasks = [(str(s), str(out / n), units, strict) for s, n in zip(sources, names, strict=True)]
    done = on_done or (lambda _: None)
    jobs = min(jobs or os.cpu_count() or 1, len(tasks))
    with _sigterm_interrupts():
        if scheduler:
            outcomes = _run_dask(tasks, scheduler, done)
        elif jobs == 1:
            outcomes = []
            for task in tasks:
                outcomes.append(fit_one(*task))
                done(outcomes[-1])
        else:
            outcomes = _run_processes(tasks, jobs, done)
    from matid.app.compare import write_summary

    return BatchResult(outcomes, write_summary(outcomes, out))


def _check_folder_name(source: str | Path, name: str, out: Path) -> None:
    """A study's output folder DIR/<name> must not be a file the batch writes into DIR (a summary, its
    temporary file) or a lock or temporary folder of another study's: a DataError before any fit."""
    hidden = name.startswith(".") and (
        ".matid-" in name or any(name.startswith(f".{n}.") for n in SUMMARY_NAMES)
    )
    if name in SUMMARY_NAMES or hidden:
        raise DataError(
            f"the study {source} would be written into {out / name}, but '{name}' is the name of an "
            f"output of the batch ({', '.join(SUMMARY_NAMES)}, or matid's temporary and lock files); "
            "rename its folder",
            file=out,
        )


def _gather(completed: Iterable[tuple[int, Any]], tasks: list[tuple], done: Callable) -> list[StudyOutcome]:
    """The outcomes of (task index, finished future) pairs in completion order, each passed to ``done``;
    returned in the order of ``tasks``. A worker that died, was lost or could not unpickle the task
    gives code 3 (not the study's fault)."""
    outcomes: dict[int, StudyOutcome] = {}
    for i, future in completed:
        try:
            outcomes[i] = future.result()
        except Exception as exc:
            error = f"worker failed: {type(exc).__name__}: {exc}"
            outcomes[i] = StudyOutcome(tasks[i][0], study_folder_name(tasks[i][0]), 3, error=error)
        done(outcomes[i])
    return [outcomes[i] for i in range(len(tasks))]


@contextlib.contextmanager
def _sigterm_interrupts():
    """While the batch runs in the main thread, SIGTERM raises :class:`Terminated` there (as SIGINT
    raises KeyboardInterrupt); elsewhere (a thread) the process's handlers stay as they are."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum, frame):
        raise Terminated()

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _watch(stop) -> None:
    """In a worker: wait until the batch stops or the batch's process is gone, then end this process."""
    import multiprocessing
    from multiprocessing.connection import wait

    parent = multiprocessing.parent_process()  # set in every process a pool starts
    while not stop.is_set():
        if wait([parent.sentinel], timeout=WATCH_S):
            break  # the parent died (even by SIGKILL): nothing of this batch may go on
    os._exit(Terminated.exit_code)  # at once: no study of a dead or stopped batch is published


def _start_worker(stop) -> None:
    """Initializer of each pool process: remember the stop event, start the watching thread."""
    global _STOP
    _STOP = stop
    threading.Thread(target=_watch, args=(stop,), name="matid-batch-watch", daemon=True).start()


def _run_processes(tasks: list[tuple], jobs: int, done: Callable) -> list[StudyOutcome]:
    """Each task in a process of a local pool; results in the order of ``tasks``."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    # forkserver: workers start clean (no inherited threads, e.g. a progress bar's). Nothing is
    # preloaded in the server: while it imports, it cannot see this process die, and it outlived a
    # killed batch by 6.5 s (measured, load 12); each worker imports the pipeline on its first study.
    context = multiprocessing.get_context("forkserver")
    stop = context.Event()
    others = set(multiprocessing.active_children())  # this process's children that are not the pool's
    pool = ProcessPoolExecutor(jobs, mp_context=context, initializer=_start_worker, initargs=(stop,))
    try:
        futures = {pool.submit(fit_one, *task): i for i, task in enumerate(tasks)}
        outcomes = _gather(((futures[f], f) for f in as_completed(futures)), tasks, done)
    except BaseException:  # SIGINT, SIGTERM (Terminated), or a failing progress callback
        stop.set()
        for worker in set(multiprocessing.active_children()) - others:
            worker.kill()  # now: a worker half-way through a publication must not finish it
        pool.shutdown(wait=True, cancel_futures=True)
        _tidy([Path(task[1]) for task in tasks])
        raise
    pool.shutdown(wait=True)
    return outcomes


def _tidy(outs: list[Path]) -> None:
    """Remove the temporary folders that stopped workers left beside their output folders."""
    from matid.io.publish import claim_output

    for out in outs:
        if any(out.parent.glob(f".{out.name}.matid-new-*")):
            with contextlib.suppress(MatidError, OSError), claim_output(out):
                pass  # a claim cleans what a crashed run left (matid.io.publish.Claim._recover)


def _run_dask(tasks: list[tuple], address: str, done: Callable) -> list[StudyOutcome]:
    """Each task on the Dask cluster at ``address``; results in the order of ``tasks``."""
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise MatidError("--scheduler needs dask.distributed: pip install 'matid[dask]'") from exc
    try:
        client = Client(address, timeout="10s", set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise MatidError(f"cannot reach the Dask scheduler at {address}: {exc}") from exc
    with client:
        futures = [client.submit(fit_one, *task, pure=False) for task in tasks]
        index = {f.key: i for i, f in enumerate(futures)}
        try:
            completed = as_completed(futures, loop=client.loop)  # this client, not a global default
            return _gather(((index[f.key], f) for f in completed), tasks, done)
        except BaseException:  # interrupted: the queued studies are not started (running ones may finish)
            client.cancel(futures)
            raise


class Progress:
    """Progress of a batch on stderr: a tqdm bar on a terminal, else one timestamped line per study."""

    def __init__(self, total: int, *, quiet: bool = False, stream=None) -> None:
        self.stream = stream or sys.stderr
        self.total, self.count, self.quiet = total, 0, quiet
        self.clock = time.perf_counter()
        self.bar = None
        if not quiet and getattr(self.stream, "isatty", lambda: False)():
            from tqdm import tqdm

            class Bar(tqdm):
                # no monitor thread: it outlives the bar (tqdm 4.70), and a batch leaves no thread behind
                monitor_interval = 0

            self.bar = Bar(total=total, unit="study", file=self.stream, desc="fitting studies")

    def __call__(self, outcome: StudyOutcome) -> None:
        from matid.toml import escaped

        self.count += 1
        status = escaped(f"{outcome.name}: {'done' if outcome.code == 0 else f'exit {outcome.code}'}")
        if self.bar is not None:
            self.bar.set_postfix_str(status, refresh=False)
            self.bar.update(1)
        elif not self.quiet:
            elapsed = time.perf_counter() - self.clock
            print(f"[{elapsed:6.1f} s] {self.count}/{self.total} {status} "
                  f"({outcome.runtime_s:.1f} s)", file=self.stream, flush=True)  # fmt: skip

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
