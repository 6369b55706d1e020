"""The report rendered by a process started before the fits, so that their imports overlap.

``matid fit`` and ``matid demo`` on one study import two stacks: the fits' (scipy, pint,
scikit-fem) and the report's (matplotlib and its PDF backend, PIL, jinja2). On two cores
they need not wait for each other. :class:`RenderWorker` forks a child before the fits'
imports; the child imports the report's stack and waits. When the fits are done, the CLI
sends it the renderer and the pickled :class:`~matid.io.results.StudyResult` (~80 kB for the
demo), computes the stiffness tables meanwhile, and takes back the rendered files.

The worker never writes a file: the CLI publishes what it sends back exactly as it would
publish a report rendered in its own process. Whenever the worker cannot help (no fork
here, a renderer or a result that does not pickle, a worker that died or whose renderer
raised), :meth:`RenderWorker.render` renders in the calling process instead, so the
outputs, the errors and their exit codes are those of rendering in one process.
"""

from __future__ import annotations

import os
import pickle
import signal
import struct
import sys
from collections.abc import Callable, Mapping

from matid.app.processes import can_fork, settled_imports

_HEADER = struct.Struct(">Q")  # the length of the pickle that follows


def render_report(result, *, units: str = "SI") -> dict[str, bytes]:
    """:func:`matid.report.render_report`, imported on first use (the report's stack is heavy)."""
    from matid import report

    return report.render_report(result, units=units)


class RenderWorker:
    """A forked child that imports the report's stack now and renders one report later."""

    def __init__(self, pid: int, to_child: int, from_child: int) -> None:
        self._pid, self._to, self._from = pid, to_child, from_child
        self._used = False
        self._answered = False  # the reply to its job was read

    @classmethod
    def start(cls) -> RenderWorker | None:
        """The worker, or None where :func:`can_fork` says no or the fork fails."""
        if not can_fork():
            return None
        for stream in (sys.stdout, sys.stderr):  # what they hold is not written twice
            if stream is not None:  # None: Python started without it (`matid demo >&-`)
                stream.flush()
        down, up = os.pipe(), os.pipe()
        try:
            pid = os.fork()
        except OSError:  # a process limit
            for fd in (*down, *up):
                os.close(fd)
            return None
        if pid == 0:  # the child: never returns
            os.close(down[1])
            os.close(up[0])
            _serve(down[0], up[1])
        os.close(down[0])
        os.close(up[1])
        return cls(pid, down[1], up[0])

    def render(
        self, renderer: Callable[..., Mapping[str, bytes]], result, *, units: str
    ) -> Callable[[], Mapping[str, bytes]]:
        """Send the job now; the returned function gives the rendered files (waiting for them).

        The job is done here, by ``renderer`` itself, when it cannot be sent or the worker fails.
        """
        if self._used:
            raise RuntimeError("a RenderWorker renders one report")
        self._used = True
        try:
            _send(self._to, pickle.dumps((renderer, result, units), protocol=pickle.HIGHEST_PROTOCOL))
        except (pickle.PicklingError, TypeError, AttributeError, OSError):
            return lambda: renderer(result, units=units)

        def take() -> Mapping[str, bytes]:
            try:
                status, files = pickle.loads(_receive(self._from))
            except (EOFError, OSError, pickle.UnpicklingError):
                status, files = "died", None
            self._answered = True
            if status != "ok":  # rendered again here: the same error, raised where it is handled
                return renderer(result, units=units)
            return files

        return take

    def close(self) -> None:
        """Close the pipes and reap the child, killed first unless its reply was read: a child
        without a job, or rendering one whose files nobody will take (the caller failed)."""
        for fd in (self._to, self._from):
            try:
                os.close(fd)
            except OSError:
                pass
        if not self._answered:
            try:
                os.kill(self._pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        try:
            os.waitpid(self._pid, 0)
        except ChildProcessError:  # SIGCHLD ignored: the kernel reaped it
            pass

    def __enter__(self) -> RenderWorker:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _serve(inbox: int, outbox: int) -> None:
    """The child: import the report's stack, render the one job that comes, exit."""
    code = 0
    try:
        with settled_imports("matid.report"):
            renderer, result, units = pickle.loads(_receive(inbox))
            try:
                reply = ("ok", dict(renderer(result, units=units)))
            except BaseException as exc:  # noqa: BLE001 -- the parent renders again and raises it
                reply = ("error", f"{type(exc).__name__}: {exc}")
            _send(outbox, pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL))
    except BaseException:  # noqa: BLE001 -- no job (EOF), an import that failed, a signal
        code = 1
    finally:
        os._exit(code)  # never unwind into the parent's stack, atexit handlers or buffers


def _send(fd: int, payload: bytes) -> None:
    with os.fdopen(os.dup(fd), "wb") as pipe:
        pipe.write(_HEADER.pack(len(payload)))
        pipe.write(payload)


def _receive(fd: int) -> bytes:
    with os.fdopen(os.dup(fd), "rb") as pipe:
        head = pipe.read(_HEADER.size)
        if len(head) < _HEADER.size:
            raise EOFError("the other process closed the pipe")
        (size,) = _HEADER.unpack(head)
        payload = pipe.read(size)
    if len(payload) < size:
        raise EOFError("the other process closed the pipe mid-message")
    return payload
