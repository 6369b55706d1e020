"""The report's figures rendered in a second process while the PDF is being drawn.

Rendering the figures (Agg, one PNG each) and drawing the PDF's pages are the two halves of
the report's time, and only the pages that show a figure need its pixels. :class:`ImageJob`
forks a child that renders every figure in the order the PDF shows them and streams the PNGs
back through a pipe (read by a thread as they come, so the child never waits). Meanwhile the
PDF places each figure at the size its PNG will have (:func:`pixels`, from the figure size
and the dpi alone) and needs the pixels only when it saves that figure's page; rather than
wait for them it renders figures the child has not begun, from the end of the list. The HTML
page then takes the same PNGs: each figure is still rendered once (twice at most when both
sides claim it at the same instant), and the bytes are those
:func:`matid.report.images.render_images` gives. The pixels each figure was drawn with go to
the PDF through shared memory laid out at the predicted sizes (no PNG is decoded for it).

Where the pixels turn out not to fit the place kept for them (a drawing that could not be
drawn, whose page shows the reason instead, or a size other than predicted), the PDF is
drawn again from the start with every figure known (:class:`Relayout`). Outside Linux,
with more than one thread, inside a worker process of a batch run (whose siblings keep the
cores busy), on one core or where the fork fails (a process limit), no child runs and each
figure is rendered when first asked for, in this process. The child is reaped whether or not
the host ignores or handles SIGCHLD (which reaps it first).
"""

from __future__ import annotations

import gc
import mmap
import os
import pickle
import signal
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from matid.app.processes import can_fork as _can_fork
from matid.app.processes import frozen_collector
from matid.report.content import KINDS, Report
from matid.report.figures import DPI, FIT_SIZE, Drawing
from matid.report.images import Image, Images, drawing_image, fit_image, pdf_image, rgba_pixels

Key = tuple[str, int]  # block anchor, 0 for the fit plot or 1 + the index of a drawing


class Relayout(Exception):
    """A figure's pixels do not fit the place the PDF kept for them: draw the PDF again."""


@dataclass(frozen=True)
class Pending:
    """The PNG of one figure, to come from the job; its size in pixels is known beforehand."""

    job: ImageJob
    key: Key
    width: int
    height: int

    def result(self) -> bytes:
        """The PNG; Relayout if the figure could not be drawn or has another size."""
        image = self.job.image(self.key)
        if not image.png or (image.width, image.height) != (self.width, self.height):
            raise Relayout(f"figure {self.key}: {image.error or 'not the size predicted'}")
        return image.png

    def stream(self) -> tuple | None:
        """The PDF image stream of the pixels, if the child prepared it (see ImageJob.stream)."""
        return self.job.stream(self.key)

    def pixels(self) -> np.ndarray:
        """The PNG's pixels as 8-bit RGBA; Relayout as :meth:`result`."""
        self.result()
        return self.job.pixels(self.key)


def pixels(size: tuple[float, float], dpi: float = DPI) -> tuple[int, int]:
    """Width and height in pixels of a figure of ``size`` inches saved as PNG at ``dpi`` (as Agg sizes it)."""
    width, height = Figure(figsize=size, dpi=dpi).bbox.size
    return int(width), int(height)


class ImageJob:
    """Every figure of ``report``: rendered by a forked child (see the module docstring) or here."""

    def __init__(self, report: Report, *, fork: bool | None = None) -> None:
        self._tasks: dict[Key, Callable[[], Image]] = {}
        self._sizes: dict[Key, tuple[float, float]] = {}
        self._anchors: list[str] = []  # every block has a (maybe empty) list of drawings
        for section in report.sections:
            title = KINDS[section.kind][0]
            for block in section.blocks:
                self._anchors.append(block.anchor)
                if block.plot:
                    key = (block.anchor, 0)
                    self._tasks[key] = _fit_task(block, report.units, title)
                    self._sizes[key] = FIT_SIZE
                for i, drawing in enumerate(block.drawings, start=1):
                    self._tasks[(block.anchor, i)] = _drawing_task(drawing)
                    self._sizes[(block.anchor, i)] = drawing.size
        self._done: dict[Key, Image] = {}
        self._streams: dict[Key, tuple] = {}  # the PDF image streams the child prepared (pdf_image)
        self._pixels: dict[Key, np.ndarray] = {}  # of the figures rendered, until the PDF takes them
        self._rc = matplotlib.rcParams.copy()  # the settings the figures are rendered with
        self._frames: dict[Key, tuple[bool, object]] = {}  # sent by the child, not yet taken
        self._arrived = threading.Condition()
        self._open = False  # the child may still send
        self._pid, self._reader = 0, None
        self._order = list(self._tasks)  # the order the child renders in
        self._claims: mmap.mmap | None = None
        self._canvas: mmap.mmap | None = None  # the child's pixels, shared (see _slots)
        self._slots: dict[Key, tuple[int, int, int]] = {}  # key -> offset, height, width in _canvas
        self._pidfd = -1  # the child's, where the kernel has pidfds
        if (_can_fork() if fork is None else fork) and self._tasks:
            self._start()

    # -- results ----------------------------------------------------------------------------

    def image(self, key: Key) -> Image:
        """The figure of ``key``, waiting for the child if it has not sent it yet."""
        if key not in self._done:
            self._steal(key)
        if key not in self._done:
            sent = self._take(key)
            meta = self._tasks[key].meta  # type: ignore[attr-defined]
            if sent is not None and sent[0]:
                png, width, height, rgba, shared = sent[1]  # type: ignore[misc]
                rgba = self._shared(key) if shared else rgba
                if rgba is not None:
                    self._pixels[key] = rgba
                self._done[key] = replace(meta, png=png, width=width, height=height)
            elif sent is not None and key[1] > 0:  # a drawing that could not be drawn: shown as such
                self._done[key] = replace(meta, png=b"", width=0, height=0, error=sent[1])
            else:  # no child, it stopped early, or a fit plot failed (to raise its own error here)
                self._render_here(key)
        return self._done[key]

    def pixels(self, key: Key) -> np.ndarray:
        """The pixels of the figure of ``key`` as 8-bit RGBA: those it was drawn with (handed out
        once: the PDF keeps them), else decoded from its PNG."""
        pixels = self._pixels.pop(key, None)
        return rgba_pixels(self.image(key).png) if pixels is None else pixels

    def _shared(self, key: Key) -> np.ndarray:
        """The pixels the child left in the shared canvas for ``key`` (a view, not a copy)."""
        offset, height, width = self._slots[key]
        data = np.frombuffer(self._canvas, np.uint8, height * width * 4, offset)  # type: ignore[arg-type]
        return data.reshape(height, width, 4)

    def stream(self, key: Key) -> tuple | None:
        """The PDF image stream of the figure's pixels if the child has sent it
        (:func:`~matid.report.images.pdf_image`; handed out once)."""
        return self._streams.pop(key, None)

    def _render_here(self, key: Key) -> None:
        with matplotlib.rc_context(self._rc):  # rendered as the child would, not in the PDF's settings
            image = self._tasks[key]()
        if image.pixels is not None:
            self._pixels[key] = image.pixels
        self._done[key] = replace(image, pixels=None)

    def _steal(self, key: Key) -> None:
        """Rather than wait for ``key``: render it here if the child has not begun it, else render
        the last figure the child has not begun, and look again. Each figure is claimed in a
        byte of shared memory first (a figure both sides claim at once is rendered twice, the
        same bytes either way)."""
        if self._claims is None:
            return
        i = self._order.index(key)
        while True:
            with self._arrived:
                if key in self._frames or not self._open:
                    return
            last = next((j for j in range(len(self._order) - 1, -1, -1) if not self._claims[j]), None)
            if last is None:
                return  # the child has every figure in hand: wait for it
            if not self._claims[i]:
                last = i
            self._claims[last] = 2
            self._render_here(self._order[last])
            if last == i:
                return

    def images(self) -> Images:
        """Every figure, rendered (for the HTML page, and the PDF drawn again after a Relayout)."""
        return self._collect(self.image)

    def pending(self) -> Images:
        """Every figure as a :class:`Pending` PNG, for the PDF to place before the pixels exist
        (without a child: every figure, rendered now)."""
        if not self._pid:
            return self.images()

        def placeholder(key: Key) -> Image:
            meta = self._tasks[key].meta  # type: ignore[attr-defined]
            width, height = pixels(self._sizes[key])
            return replace(meta, png=Pending(self, key, width, height), width=width, height=height)

        return self._collect(placeholder)

    def close(self) -> None:
        """Stop the child if it is still rendering (nothing more is wanted) and reap it. The host
        may reap it first (SIGCHLD ignored or handled): its pid is then signalled only through
        a pidfd, which cannot name another process that has since taken the same pid."""
        if not self._pid:
            return
        pid, pidfd = self._pid, self._pidfd
        self._pid, self._pidfd = 0, -1
        try:
            with self._arrived:
                sending = self._open  # the pipe has not reached its end: the child is alive
            if sending:
                _kill(pid, pidfd)
            self._reader.join()  # type: ignore[union-attr]
            try:
                if pidfd >= 0:
                    os.waitid(os.P_PIDFD, pidfd, os.WEXITED)
                else:
                    os.waitpid(pid, 0)
            except ChildProcessError:
                pass  # reaped by the host already
        finally:
            if pidfd >= 0:
                os.close(pidfd)
            if self._claims is not None:
                self._claims.close()
                self._claims = None
            self._canvas = None  # unmapped when the last view of it (the PDF's pixels) goes

    def _collect(self, get: Callable[[Key], Image]) -> Images:
        plots: dict[str, Image] = {}
        drawings: dict[str, list[Image]] = {anchor: [] for anchor in self._anchors}
        for anchor, index in self._tasks:
            if index == 0:
                plots[anchor] = get((anchor, 0))
            else:
                drawings[anchor].append(get((anchor, index)))
        return Images(plots, drawings)

    # -- the child --------------------------------------------------------------------------

    def _start(self) -> None:
        """Fork the child; where that fails (a process or file limit), leave every figure to this process."""
        claims = mmap.mmap(-1, len(self._order))  # shared with the child: 0 free, 1 child's, 2 ours
        # the figures' pixels, at the sizes predicted: sent through the pipe they would keep the
        # child waiting for this process's reader thread (which needs the GIL the PDF holds)
        offset = 0
        for key in self._order:
            width, height = pixels(self._sizes[key])
            self._slots[key] = (offset, height, width)
            offset += width * height * 4
        canvas = mmap.mmap(-1, max(offset, 1))  # pages are only taken as the child writes them
        try:
            read, write = os.pipe()
        except OSError:
            claims.close()
            return
        self._claims, self._canvas = claims, canvas
        try:
            with frozen_collector():  # else the collector touches, and so copies, every object in the child
                pid = os.fork()
                if pid == 0:
                    self._serve(read, write)  # never returns
        except OSError:
            os.close(read)
            os.close(write)
            claims.close()
            self._claims = self._canvas = None
            return
        os.close(write)
        self._pid, self._open, self._pidfd = pid, True, _pidfd(pid)
        # read as the figures come, so that the child never waits on a full pipe
        self._reader = threading.Thread(target=self._drain, args=(os.fdopen(read, "rb"),), daemon=True)
        self._reader.start()

    def _serve(self, read: int, write: int) -> None:
        """In the child: render, send, leave without running the parent's exit handlers."""
        code = 1
        try:
            gc.disable()  # a short life: the parent's garbage is not worth copying pages for
            os.close(read)
            with os.fdopen(write, "wb") as out:
                placed = []
                for i, (key, task) in enumerate(self._tasks.items()):
                    if self._claims[i]:  # the parent took it
                        continue
                    self._claims[i] = 1
                    sent = self._place(*_sent(key, task))
                    pickle.dump(sent, out, protocol=pickle.HIGHEST_PROTOCOL)
                    out.flush()
                    if sent[1] and sent[2][4]:  # type: ignore[index]
                        placed.append(key)
                # then, while the parent draws its last pages, the PDF's encoding of them
                for key in placed:
                    stream = (key, _STREAM, pdf_image(self._shared(key)))
                    pickle.dump(stream, out, protocol=pickle.HIGHEST_PROTOCOL)
                    out.flush()
            code = 0
        finally:
            os._exit(code)

    def _place(self, key: Key, ok: bool, payload: object) -> tuple[Key, bool, object]:
        """In the child: a figure's pixels put in the shared canvas if they have the size kept
        for them (else sent with the PNG)."""
        if ok:
            png, width, height, rgba = payload  # type: ignore[misc]
            if rgba is not None and rgba.shape == self._slots[key][1:] + (4,):
                self._shared(key)[:] = rgba
                return key, ok, (png, width, height, None, True)
            return key, ok, (png, width, height, rgba, False)
        return key, ok, payload

    def _drain(self, pipe) -> None:
        try:
            with pipe:
                while True:
                    key, ok, payload = pickle.load(pipe)
                    if ok == _STREAM:
                        if payload is not None:
                            self._streams[key] = payload
                        continue
                    with self._arrived:
                        self._frames[key] = (ok, payload)
                        self._arrived.notify_all()
        except Exception:  # noqa: BLE001 -- the end of the pipe: the child is done or gone
            pass
        finally:
            with self._arrived:
                self._open = False
                self._arrived.notify_all()

    def _take(self, key: Key) -> tuple[bool, object] | None:
        """What the child sent for ``key``, waiting while it may still send it; None if it never will."""
        with self._arrived:
            while key not in self._frames and self._open:
                self._arrived.wait()
            return self._frames.pop(key, None)


_STREAM = "stream"  # what the child sends after the figures: the PDF image streams of its pixels


def _sent(key: Key, task) -> tuple[Key, bool, object]:
    try:
        image = task()
    except Exception as exc:  # a fit plot that fails: the parent renders it again and raises
        return key, False, f"{type(exc).__name__}: {exc}"
    if not image.png:
        return key, False, image.error
    return key, True, (image.png, image.width, image.height, image.pixels)


class _Task:
    """Renders one figure; ``meta`` is its Image without the pixels (texts known beforehand)."""

    def __init__(self, render: Callable[[], Image], meta: Image) -> None:
        self.render, self.meta = render, meta

    def __call__(self) -> Image:
        return self.render()


def _fit_task(block, units: str, title: str) -> _Task:
    image = fit_image(block, units, title, png=False)
    return _Task(lambda: fit_image(block, units, title, pixels=True), image)


def _drawing_task(drawing: Drawing) -> _Task:
    return _Task(
        lambda: drawing_image(drawing, pixels=True),
        Image(b"", 0, 0, drawing.alt, drawing.caption, drawing.title),
    )


def _pidfd(pid: int) -> int:
    """A pidfd for the child just forked (-1 without pidfds, or if it has already left)."""
    try:
        return os.pidfd_open(pid)
    except (AttributeError, OSError):
        return -1


def _kill(pid: int, pidfd: int) -> None:
    """SIGKILL the child, through its pidfd where there is one; nothing if it has gone."""
    try:
        if pidfd >= 0:
            signal.pidfd_send_signal(pidfd, signal.SIGKILL)
        elif os.waitpid(pid, os.WNOHANG) == (0, 0):  # still ours and not yet exited
            os.kill(pid, signal.SIGKILL)
    except (ProcessLookupError, ChildProcessError):
        pass
