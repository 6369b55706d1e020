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

A batch stops whole (docs/contract.md section 11). With local processes
(``--jobs``) a worker never publishes: it writes a study's files into a hidden
folder that this process staged (:meth:`matid.io.publish.Claim.stage`, holding the
output's lock), and this process swaps it in (:meth:`~matid.io.publish.Claim.swap`)
in its main thread, where SIGINT and SIGTERM are handled: once the batch is
stopped or killed, nothing swaps. A worker that published itself could do it in
the moment between the signal and the batch's reaction to it (seen under load:
a study published after SIGTERM, or after SIGKILL, in 2 of 180 runs). Each local worker process
runs a thread that ends it (``os._exit``) as soon as the batch's process is gone
(the sentinel of :func:`multiprocessing.parent_process`, readable once the parent
died, even by SIGKILL) or the batch is stopped (a shared
:class:`multiprocessing.Event`). SIGINT (Ctrl-C) and, while a batch runs in the
main thread, SIGTERM (:class:`Terminated`) stop it: the event is set, the pool's
processes killed (:func:`multiprocessing.active_children`, less the children this
process had before), the queued studies cancelled, the staged folders removed,
and the interrupt raised on (exit 130 / 143). Studies that finished keep their
folders; no summary is written for an interrupted batch. At most
:data:`AHEAD` studies per process are staged at a time (each holds a lock file open).
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
#: Studies staged (handed to the pool, their outputs locked) per local process at most.
AHEAD = 2


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


def fit_one(
    source: str, out: str, units: str = "SI", strict: bool = False, staged: str | None = None
) -> StudyOutcome:
    """Load, fit and write one study into ``out``; never raises: errors become the outcome's code.

    With ``staged`` (a batch's local worker) the files are written into that folder, which the batch
    staged beside ``out`` and swaps in itself (:func:`_swap`); the outcome's paths say they were."""
    from matid.app.pipeline import output_files, run_study, write_outputs
    from matid.io.publish import fill
    from matid.io.results import table_rows
    from matid.io.study import load_study

    clock = time.perf_counter()
    name = study_folder_name(source)
    try:
        result = run_study(load_study(source))
        if staged is None:
            paths = write_outputs(result, Path(out), units=units)
        else:
            files = output_files(result, units=units)
            fill(Path(staged), files, Path(out))
            paths = [Path(out) / n for n in files]
    except Exception as exc:
        return _failed(source, exc, time.perf_counter() - clock)
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


def _failed(source: str, exc: Exception, runtime_s: float = 0.0) -> StudyOutcome:
    """The outcome of a study stopped by ``exc``: the code and message of `matid fit`; a bug keeps its
    traceback for --debug."""
    code = exit_code(exc)
    error = error_message(exc) + (f"\n{traceback.format_exc()}" if code == 3 else "")
    return StudyOutcome(source, study_folder_name(source), code, error=error, runtime_s=runtime_s)


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
    returned in the order of ``tasks``."""
    outcomes: dict[int, StudyOutcome] = {}
    for i, future in completed:
        outcomes[i] = _outcome(future, tasks[i])
        done(outcomes[i])
    return [outcomes[i] for i in range(len(tasks))]


def _outcome(future, task: tuple) -> StudyOutcome:
    """A finished future's outcome; a worker that died, was lost or could not unpickle the task gives
    code 3 (not the study's fault)."""
    try:
        return future.result()
    except Exception as exc:
        return _worker_failed(task, exc)


def _worker_failed(task: tuple, exc: Exception) -> StudyOutcome:
    error = f"worker failed: {type(exc).__name__}: {exc}"
    return StudyOutcome(task[0], study_folder_name(task[0]), 3, error=error)


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
    """In a worker: wait until the batch stops or the batch's process is gone, then end this process
    (its study is not published either way: the batch swaps it in, :func:`_swap`)."""
    import multiprocessing
    from multiprocessing.connection import wait

    parent = multiprocessing.parent_process()  # set in every process a pool starts
    while not stop.is_set():
        if wait([parent.sentinel], timeout=WATCH_S):
            break  # the parent died (even by SIGKILL): nothing of this batch may go on
    os._exit(Terminated.exit_code)  # at once: no work goes on for a dead or stopped batch


def _start_worker(stop) -> None:
    """Initializer of each pool process: start the watching thread."""
    threading.Thread(target=_watch, args=(stop,), name="matid-batch-watch", daemon=True).start()


def _run_processes(tasks: list[tuple], jobs: int, done: Callable) -> list[StudyOutcome]:
    """Each task in a process of a local pool, its output staged and swapped in here; results in the
    order of ``tasks``."""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, ProcessPoolExecutor, wait

    # forkserver: workers start clean (no inherited threads, e.g. a progress bar's). Nothing is
    # preloaded in the server: while it imports, it cannot see this process die, and it outlived a
    # killed batch by 6.5 s (measured, load 12); each worker imports the pipeline on its first study.
    context = multiprocessing.get_context("forkserver")
    stop = context.Event()
    others = set(multiprocessing.active_children())  # this process's children that are not the pool's
    pool = ProcessPoolExecutor(jobs, mp_context=context, initializer=_start_worker, initargs=(stop,))
    outcomes: dict[int, StudyOutcome] = {}
    running: dict[Any, tuple[int, Any, Path]] = {}  # future -> (task index, claim, staged folder)
    queue = iter(enumerate(tasks))
    try:
        while True:
            while len(running) < AHEAD * jobs and (item := next(queue, None)) is not None:
                i, task = item
                staged = _stage(task)
                if isinstance(staged, StudyOutcome):  # its output cannot be written: not fitted
                    outcomes[i] = staged
                    done(staged)
                    continue
                try:
                    running[pool.submit(fit_one, *task, str(staged[1]))] = (i, *staged)
                except BrokenExecutor as exc:  # a worker died: the pool takes no more studies
                    staged[0].discard(staged[1])
                    outcomes[i] = _worker_failed(task, exc)
                    done(outcomes[i])
            if not running:
                break
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in finished:
                i, claim, folder = running.pop(future)
                outcomes[i] = _swap(_outcome(future, tasks[i]), claim, folder)
                done(outcomes[i])
    except BaseException:  # SIGINT, SIGTERM (Terminated), or a failing progress callback
        stop.set()
        for worker in set(multiprocessing.active_children()) - others:
            worker.kill()  # now: no work goes on for a stopped batch
        pool.shutdown(wait=True, cancel_futures=True)
        for _, claim, folder in running.values():
            claim.discard(folder)
        raise
    pool.shutdown(wait=True)
    return [outcomes[i] for i in range(len(tasks))]


def _stage(task: tuple):
    """(claim, staged folder) of a task's output (:meth:`matid.io.publish.Claim.stage`), or the outcome
    of a study whose output cannot be written (a DataError or OutputError, before it is fitted)."""
    from matid.io.publish import claim_output

    claim = None
    try:
        claim = claim_output(Path(task[1]))
        return claim, claim.stage()
    except MatidError as exc:
        if claim is not None:
            claim.release()
        return _failed(task[0], exc)


def _swap(outcome: StudyOutcome, claim, folder: Path) -> StudyOutcome:
    """Publish the folder a worker filled (its outcome has paths), here in the batch's main thread:
    an interrupt is raised before a swap or after it, and once the batch stopped or died nothing
    swaps; a folder the worker did not fill is removed. The output's lock is dropped."""
    try:
        if not outcome.paths:
            claim.discard(folder)
            return outcome
        try:
            claim.swap(folder, [Path(p).name for p in outcome.paths])
        except MatidError as exc:
            return _failed(outcome.source, exc, outcome.runtime_s)
        return outcome
    finally:
        claim.release()


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
