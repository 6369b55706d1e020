"""matid.app.render_worker: the report rendered by a child forked before the fits (matid fit/demo)."""

from __future__ import annotations

import dataclasses
import os
import pickle
import signal
import threading
import time

import pytest

from matid.app.render_worker import RenderWorker, can_fork, render_report
from tests.report.test_report import bend_result, make_result

pytestmark = pytest.mark.skipif(not can_fork(), reason="needs fork, two cores and one thread")


def start() -> RenderWorker:
    worker = RenderWorker.start()
    # None here means a thread outlived an earlier test (e.g. tqdm's monitor, matid.app.batch)
    assert worker is not None, f"no worker: threads {threading.enumerate()}"
    return worker


def where(result, *, units):
    """A renderer that says which process ran it (module level: it pickles by reference)."""
    return {"pid": str(os.getpid()).encode(), "echo": pickle.dumps((result, units))}


def crash(result, *, units):
    raise ZeroDivisionError(f"renderer crashed on {result}")


def test_the_worker_renders_in_its_own_process_what_the_renderer_returns():
    with start() as worker:
        files = worker.render(where, {"fits": [1.5, 2.5]}, units="cgs")()
    assert int(files["pid"]) != os.getpid()
    assert pickle.loads(files["echo"]) == ({"fits": [1.5, 2.5]}, "cgs")


def test_a_renderer_that_does_not_pickle_renders_here():
    with start() as worker:
        files = worker.render(lambda result, *, units: where(result, units=units), "r", units="SI")()
    assert int(files["pid"]) == os.getpid()


def test_a_renderer_that_raises_in_the_worker_raises_here():
    with start() as worker, pytest.raises(ZeroDivisionError, match="crashed on r"):
        worker.render(crash, "r", units="SI")()


def test_a_dead_worker_means_rendering_here():
    with start() as worker:
        os.kill(worker._pid, signal.SIGKILL)
        time.sleep(0.05)
        files = worker.render(where, "r", units="SI")()
    assert int(files["pid"]) == os.getpid()


def test_an_unused_worker_is_killed_and_reaped_at_once():
    worker = start()
    pid = worker._pid
    started = time.perf_counter()
    worker.close()
    assert time.perf_counter() - started < 0.5  # not waiting for its imports
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, os.WNOHANG)  # reaped: no zombie left


def test_one_report_per_worker():
    with start() as worker:
        worker.render(where, "r", units="SI")()
        with pytest.raises(RuntimeError, match="one report"):
            worker.render(where, "r", units="SI")


def test_no_worker_when_forking_is_switched_off(monkeypatch):
    monkeypatch.setenv("MATID_REPORT_FORK", "0")
    assert not can_fork() and RenderWorker.start() is None


@pytest.mark.parametrize("make", [make_result, bend_result])
def test_a_study_result_renders_the_same_after_the_trip_to_the_worker(make):
    # every test kind, read-only mappings, figure hooks, a three-point bend; a run date, so
    # that the PDF's creation date is the result's, not the clock's
    result = dataclasses.replace(make(), started="2024-11-26T14:03:12+01:00")
    back = pickle.loads(pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))
    assert back.study.tests[0].params == result.study.tests[0].params
    with pytest.raises(TypeError):
        back.study.tests[0].params["x"] = 1.0  # still a read-only view
    with start() as worker:
        there = worker.render(render_report, result, units="cgs")()
    assert there == render_report(result, units="cgs")


def slow(result, *, units):
    time.sleep(30)
    return {"late": b""}


def test_a_job_whose_files_are_never_taken_is_not_waited_for():
    # the caller failed between render() and taking the files (e.g. making the tables)
    worker = start()
    worker.render(slow, "r", units="SI")
    pid = worker._pid
    started = time.perf_counter()
    worker.close()
    assert time.perf_counter() - started < 5  # killed, not waited for through its render
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, os.WNOHANG)  # reaped: no zombie left
