"""Figures rendered by a second process while the PDF is drawn (matid.report.imagejob): same bytes."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

from matid.report import imagejob, images, render_report
from matid.report.content import build_report
from matid.report.figures import FIT_SIZE, drawing_png, fit_figure, png_bytes, png_size
from matid.report.html import render_html
from matid.report.images import drawing_image, fit_image, render_images, rgba_pixels
from matid.report.pdf import render_pdf
from tests.report.test_report import bend_result, make_result

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")


def _result(make):
    return dataclasses.replace(make(), started="2024-11-26T10:00:00+01:00")  # a fixed CreationDate


def _sequential(result) -> dict[str, bytes]:
    """The report as drawn before the job existed: every figure first, then the PDF, then the page."""
    report = build_report(result, "SI")
    images = render_images(report)
    return {"report.html": render_html(report, images), "report.pdf": render_pdf(report, images)}


@pytest.fixture(scope="module", params=[make_result, bend_result], ids=["kinds", "bend"])
def case(request):
    result = _result(request.param)
    return result, _sequential(result)


def test_forked_and_in_process_reports_are_the_sequential_bytes(case, monkeypatch):
    result, want = case
    started = []
    real_start = imagejob.ImageJob._start
    monkeypatch.setattr(imagejob.ImageJob, "_start", lambda self: started.append(1) or real_start(self))
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    assert render_report(result) == want
    assert started == [1]
    monkeypatch.setattr(imagejob, "_can_fork", lambda: False)
    assert render_report(result) == want
    assert started == [1]


def test_a_child_that_dies_leaves_the_rest_to_the_parent(case, monkeypatch):
    result, want = case
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    real_sent, sent = imagejob._sent, []

    def dies_after_one(key, task):  # runs in the child
        if sent:
            os._exit(9)
        sent.append(key)
        return real_sent(key, task)

    monkeypatch.setattr(imagejob, "_sent", dies_after_one)
    started, here = [], []
    real_start, real_here = imagejob.ImageJob._start, imagejob.ImageJob._render_here
    monkeypatch.setattr(imagejob.ImageJob, "_start", lambda self: started.append(1) or real_start(self))
    monkeypatch.setattr(
        imagejob.ImageJob, "_render_here", lambda self, key: here.append(key) or real_here(self, key)
    )
    assert render_report(result) == want
    assert started == [1] and here  # a child was forked, and the parent drew what it left


def test_a_figure_of_another_size_makes_the_pdf_drawn_again(case, monkeypatch):
    result, want = case
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    monkeypatch.setattr(imagejob, "pixels", lambda size, dpi=0: (7, 5))
    relayouts = []
    real_pdf = imagejob.Pending.result

    def counted(self):
        try:
            return real_pdf(self)
        except imagejob.Relayout:
            relayouts.append(self.key)
            raise

    monkeypatch.setattr(imagejob.Pending, "result", counted)
    assert render_report(result) == want
    assert len(relayouts) == 1


def test_predicted_pixels_are_the_rendered_ones():
    report = build_report(_result(bend_result), "SI")
    drawings = [d for s in report.sections for b in s.blocks for d in b.drawings]
    fits = [b.fit for s in report.sections for b in s.blocks if b.plot]
    assert drawings and fits
    for drawing in drawings:
        assert imagejob.pixels(drawing.size) == png_size(drawing_png(drawing))
    assert imagejob.pixels(FIT_SIZE) == png_size(png_bytes(fit_figure(fits[0])))
    for size in [(7.5, 3.2), (6.3, 2.9), (7.1, 4.45), (5.55, 3.35)]:
        assert imagejob.pixels(size) == png_size(png_bytes(imagejob.Figure(figsize=size)))


def test_the_parent_renders_figures_the_child_has_not_begun(case, monkeypatch):
    import time

    result, want = case
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    real_sent = imagejob._sent
    monkeypatch.setattr(
        imagejob, "_sent", lambda key, task: time.sleep(0.3) or real_sent(key, task)
    )  # a slow child
    here = []
    real_here = imagejob.ImageJob._render_here
    monkeypatch.setattr(
        imagejob.ImageJob, "_render_here", lambda self, key: here.append(key) or real_here(self, key)
    )
    started = []
    real_start = imagejob.ImageJob._start
    monkeypatch.setattr(imagejob.ImageJob, "_start", lambda self: started.append(1) or real_start(self))
    assert render_report(result) == want
    assert started == [1] and here  # a child was forked, and the parent did not only wait


def _fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def _host_freeze() -> list:
    """Freeze every object, as a host that forks workers might; returns one of them."""
    import gc

    host = ["the host's"]
    gc.collect()
    gc.freeze()
    return host


def _frozen(obj) -> bool:
    import gc

    return not any(o is obj for o in gc.get_objects())  # the frozen generation is not listed


linux = pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="counts /proc/self/fd")


@linux
@pytest.mark.parametrize("host_frozen", [False, True], ids=["gc", "host-frozen-gc"])
def test_a_fork_that_fails_leaves_the_report_to_this_process(case, monkeypatch, host_frozen):
    import errno
    import gc

    result, want = case
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    tried = []

    def fails():
        tried.append(1)
        raise BlockingIOError(errno.EAGAIN, "Resource temporarily unavailable")  # a process limit

    host = _host_freeze() if host_frozen else None
    monkeypatch.setattr(os, "fork", fails)
    try:
        frozen, fds = gc.get_freeze_count(), _fds()
        assert render_report(result) == want
        assert tried == [1]
        if host_frozen:
            assert _frozen(host)  # the count itself drops by the frozen objects freed meanwhile
        else:
            assert gc.get_freeze_count() == frozen == 0
        assert _fds() == fds  # the pipe's ends closed
    finally:
        gc.unfreeze()


@linux
def test_the_host_s_frozen_objects_stay_frozen_when_the_child_starts(case, monkeypatch):
    import gc

    result, want = case
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    host = _host_freeze()
    forks, real_fork = [], os.fork
    monkeypatch.setattr(os, "fork", lambda: forks.append(1) or real_fork())
    try:
        fds = _fds()
        assert _frozen(host)
        assert render_report(result) == want
        assert forks == [1]
        assert _frozen(host)
        assert _fds() == fds
    finally:
        gc.unfreeze()


@linux
@pytest.mark.parametrize("pidfd", [True, False], ids=["pidfd", "no-pidfd"])
@pytest.mark.parametrize("host", ["ignores", "reaps"])
def test_a_host_that_ignores_or_reaps_sigchld(case, monkeypatch, host, pidfd):
    """The host's handling of SIGCHLD reaps the child before the job does; with a pidfd, the job
    does not signal a pid that may by then be another process's."""
    import gc
    import signal

    result, want = case
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    if not pidfd:  # a kernel before 5.3
        monkeypatch.setattr(imagejob, "_pidfd", lambda pid: -1)
    forks, real_fork = [], os.fork
    monkeypatch.setattr(os, "fork", lambda: forks.append(pid := real_fork()) or pid)
    kills, real_kill = [], os.kill
    monkeypatch.setattr(os, "kill", lambda pid, sig: kills.append(pid) or real_kill(pid, sig))
    reaped = []

    def reap(signum, frame):
        while True:
            try:
                pid, _ = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if not pid:
                return
            reaped.append(pid)

    old = signal.signal(signal.SIGCHLD, signal.SIG_IGN if host == "ignores" else reap)
    try:
        frozen, fds = gc.get_freeze_count(), _fds()
        got = render_report(result)
        assert gc.get_freeze_count() == frozen
        assert _fds() == fds
    finally:
        signal.signal(signal.SIGCHLD, old)
    assert got == want
    assert len(forks) == 1 and forks[0] > 0
    if pidfd:
        assert forks[0] not in kills
    if host == "reaps":
        assert reaped == forks


@linux
@pytest.mark.parametrize("pidfd", [True, False], ids=["pidfd", "no-pidfd"])
def test_close_stops_a_child_that_is_still_rendering(monkeypatch, pidfd):
    import signal
    import time

    if not pidfd:
        monkeypatch.setattr(imagejob, "_pidfd", lambda pid: -1)
    sent = []
    for module, name in [(os, "kill"), (signal, "pidfd_send_signal")]:
        real = getattr(module, name)
        monkeypatch.setattr(
            module, name, lambda to, sig, real=real, name=name: sent.append(name) or real(to, sig)
        )
    report = build_report(_result(bend_result), "SI")
    monkeypatch.setattr(imagejob, "_sent", lambda key, task: time.sleep(120))  # in the child
    fds = _fds()
    started = time.monotonic()
    job = imagejob.ImageJob(report, fork=True)
    assert job._pid
    job.close()
    assert time.monotonic() - started < 60
    assert sent == ["pidfd_send_signal" if pidfd else "kill"]
    assert _fds() == fds


def test_the_pdf_takes_the_pixels_the_figures_were_drawn_with(case, monkeypatch):
    """With the child, no figure's PNG is decoded for the PDF (only the PNGs a fit hands in,
    ``info["figures"]``): the pixels come from drawing the figure, through the shared canvas
    from the child, and the bytes are the sequential ones."""
    result, want = case
    report = build_report(result, "SI")
    given = [e.png for s in report.sections for b in s.blocks for e in b.extras if e.png]
    decoded = []

    def counted(png):
        decoded.append(png)
        return rgba_pixels(png)

    monkeypatch.setattr(imagejob, "rgba_pixels", counted)
    monkeypatch.setattr(images, "rgba_pixels", counted)
    monkeypatch.setattr(imagejob, "_can_fork", lambda: True)
    assert render_report(result) == want
    assert decoded == given
    monkeypatch.setattr(imagejob, "_can_fork", lambda: False)  # figures given to the PDF as PNG
    assert render_report(result) == want
    assert len(decoded) > 2 * len(given)


def test_kept_pixels_are_the_decoded_png():
    report = build_report(_result(bend_result), "SI")
    blocks = [b for s in report.sections for b in s.blocks]
    drawings = [d for b in blocks for d in b.drawings]
    assert drawings
    for drawing in drawings:
        image = drawing_image(drawing, pixels=True)
        assert image.png == drawing_png(drawing) and drawing_image(drawing).pixels is None
        np.testing.assert_array_equal(image.pixels, rgba_pixels(image.png))
    block = next(b for b in blocks if b.plot)
    image = fit_image(block, "SI", "Three-point bend", pixels=True)
    assert image.png == fit_image(block, "SI", "Three-point bend").png
    np.testing.assert_array_equal(image.pixels, rgba_pixels(image.png))
