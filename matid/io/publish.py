"""Publishing an output folder whole: a reader sees the old report or the new one, never a mix.

``matid fit --out DIR`` writes four files (docs/contract.md section 4) that belong
together. Writing them one by one, even each atomically, leaves a mix of old
and new files when the process dies between two of them. Here instead:

1. :func:`claim_output` checks ``DIR`` before any fitting (a file, under a file,
   read-only, or holding files matid did not write: a :class:`DataError`, exit 2
   naming the folder) and takes an exclusive ``fcntl.flock`` on the lock file
   ``.DIR.matid-lock`` beside it, so a second writer to the same folder is refused
   (exit 2). The kernel drops the lock when the process dies, even by ``kill -9``.
   Leftovers of a crashed run beside ``DIR`` are cleaned here (see 3).
2. :meth:`Claim.publish` writes every file into a fresh hidden folder
   ``.DIR.matid-new-XXXX`` beside ``DIR`` (same filesystem), fsyncs the files and
   the folder, then makes it ``DIR`` in ONE step: Linux ``renameat2(...,
   RENAME_EXCHANGE)`` swaps the two folder names atomically, and the old folder,
   now under the hidden name, is removed. ``DIR/report.html`` etc. stay at the
   same paths. When ``DIR`` does not exist yet, a plain ``rename`` publishes.
   The three steps are :meth:`Claim.stage`, :func:`fill` and :meth:`Claim.swap`:
   a batch fills in its worker processes and swaps in its own (:mod:`matid.app.batch`).
3. Where ``renameat2`` is missing (not Linux, an old kernel, a filesystem without
   it), two renames stand in: ``DIR`` -> ``.DIR.matid-old-XXXX``, then the new
   folder -> ``DIR``. Between the two a reader finds no ``DIR`` (never a mix); a
   crash just there leaves the old report whole under the hidden name, and the
   next claim of ``DIR`` moves it back before doing anything else.
4. Only folders matid made are ever removed or moved back: each hidden folder's
   name is appended to the lock file (fsynced) right after it is made, by the
   process holding the lock; the next claim acts on the names listed there and
   then empties the list. A user's own ``.DIR.matid-new-zz`` is never touched.

A failure while writing (disk full, I/O error) removes the new folder and raises
:class:`OutputError` (exit 1) saying the previous report is unchanged. Because
the whole folder is replaced, ``DIR`` may only hold matid outputs; anything else
in it is refused rather than deleted.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import os
import secrets
import shutil
import stat
import weakref
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

from matid.errors import DataError, MatidError

try:
    import fcntl
except ImportError:  # not POSIX (Windows): no lock; the publication itself still works
    fcntl = None  # type: ignore[assignment]

#: Files matid writes into an output folder; a folder holding anything else is not replaced.
OUTPUT_NAMES = frozenset(
    {
        "report.html",
        "report.pdf",
        "stiffness.csv",
        "stiffness.json",
        "stiffness.xlsx",
        "solution.json",
        "shape.png",
    }
)
NEW, OLD, LOCK = ".matid-new-", ".matid-old-", ".matid-lock"
AT_FDCWD, RENAME_EXCHANGE = -100, 2
#: Most bytes of the lock file's list of temporary folders read back (a run lists two names at most).
MAX_JOURNAL = 1 << 16
#: Names drawn for a temporary folder before giving up (each 48 random bits).
FRESH_TRIES = 16


class OutputError(MatidError):
    """The outputs could not be written (disk full, I/O error); the previous ones are unchanged."""


def _hidden(real: Path, suffix: str) -> str:
    return f".{real.name}{suffix}"


def _is_temporary(name: str, real: Path) -> bool:
    """``name`` is a name matid gives a temporary folder of ``real`` (a listed name is checked again:
    the lock file is a plain file a user could edit)."""
    return any(name.startswith(_hidden(real, t)) and "/" not in name for t in (NEW, OLD))


def _is_own_leftover(name: str) -> bool:
    """matid's own hidden files: a temp file of the older per-file writes (``.report.html.ab12cd``),
    or the lock or a temp folder of an output folder nested in this one. They go with the old folder."""
    own = any(name.startswith(f".{n}.") for n in OUTPUT_NAMES) or any(t in name for t in (NEW, OLD, LOCK))
    return name.startswith(".") and own


def check_output(out: Path, names: frozenset[str] = OUTPUT_NAMES) -> Path:
    """The real path of ``out`` if matid can publish there; a DataError (exit 2) naming it otherwise."""
    out = Path(out)
    if str(out).strip() == "" or out.name in ("", ".", ".."):
        raise DataError("--out must name a folder of its own (not '.', '..' or a root)", file=out)
    real = Path(os.path.realpath(out))
    if real.exists() and not real.is_dir():
        raise DataError("--out is a file, not a folder", file=out)
    ancestor = real.parent
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise DataError(f"--out lies under {ancestor}, which is a file, not a folder", file=out)
    for folder in (real, ancestor) if real.exists() else (ancestor,):
        if not os.access(folder, os.W_OK | os.X_OK):
            raise DataError(f"--out: the folder {folder} is read-only", file=out)
    if real.is_dir():
        foreign = sorted(n for n in os.listdir(real) if n not in names and not _is_own_leftover(n))
        if foreign:
            raise DataError(
                f"--out holds '{foreign[0]}'{f' and {len(foreign) - 1} more' if len(foreign) > 1 else ''}, "
                "which matid did not write; matid replaces the whole folder when it publishes, "
                "so choose an empty folder or one matid wrote",
                file=out,
            )
    return real


#: Claims held by this process, by real path: a second claim of the same folder reuses the first.
_CLAIMS: weakref.WeakValueDictionary[Path, Claim] = weakref.WeakValueDictionary()


class Claim:
    """The exclusive right of this process to publish into one output folder (see the module docstring)."""

    def __init__(self, out: Path, real: Path) -> None:
        self.out, self.real = Path(out), real
        self.fd: int | None = None
        try:
            real.parent.mkdir(parents=True, exist_ok=True)
            self.fd = os.open(real.parent / _hidden(real, LOCK), os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            raise DataError(
                f"--out: cannot create the folder or its lock file: {exc.strerror}", file=out
            ) from exc
        try:
            if fcntl is not None:
                fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            self.release()
            if exc.errno in (errno.EWOULDBLOCK, errno.EACCES, errno.EAGAIN):
                raise DataError(
                    "--out is being written by another matid run; wait for it or choose another folder",
                    file=out,
                ) from exc
            raise DataError(f"--out: cannot lock the folder: {exc.strerror}", file=out) from exc
        self._recover()

    def __enter__(self) -> Claim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    def __del__(self) -> None:
        self.release()

    def release(self) -> None:
        """Drop the lock (the lock file stays: removing it would race with a waiting writer)."""
        if self.fd is not None:
            os.close(self.fd)  # closing the only descriptor releases the flock
            self.fd = None

    def _recover(self) -> None:
        """Undo what a crashed run left beside the folder: put a moved-away report back, drop temp folders.

        Only the folders listed in the lock file (:meth:`made`) are touched, so a user's folder that
        happens to be named like one is never deleted; the list is emptied afterwards."""
        parent, real = self.real.parent, self.real
        os.lseek(self.fd, 0, os.SEEK_SET)
        listed = os.read(self.fd, MAX_JOURNAL).decode("utf-8", "replace").split("\n")
        ours = [parent / n for n in dict.fromkeys(listed) if _is_temporary(n, real) and (parent / n).is_dir()]
        olds = sorted(
            (p for p in ours if p.name.startswith(_hidden(real, OLD))), key=lambda p: p.stat().st_mtime
        )
        if olds and not real.exists():
            os.rename(olds.pop(), real)  # a crash between the two fallback renames
        for stale in ours:
            if stale.exists():
                shutil.rmtree(stale, ignore_errors=True)
        os.ftruncate(self.fd, 0)

    def made(self, folder: Path) -> Path:
        """Record ``folder`` (a hidden temporary folder this run just made) in the lock file, fsynced, so
        that a later claim may remove it (or move it back) if this run dies; returns it."""
        if self.fd is not None:
            os.lseek(self.fd, 0, os.SEEK_END)
            os.write(self.fd, f"{folder.name}\n".encode())
            os.fsync(self.fd)
        return folder

    def fresh(self, kind: str) -> Path:
        """A new hidden temporary folder beside the output (``kind``: NEW or OLD), its name recorded
        in the lock file BEFORE the folder is made: a run killed between the two leaves a listed name
        without a folder (skipped by the next claim), never an unlisted folder that no claim may
        remove (tempfile.mkdtemp first, then the record, left one under load: test_fuzz's kill loop).
        A name that exists already (a user's) is taken off the list again and another is drawn."""
        for _ in range(FRESH_TRIES):
            folder = self.real.parent / (_hidden(self.real, kind) + secrets.token_hex(6))
            self.made(folder)
            try:
                os.mkdir(folder, 0o700)
                return folder
            except FileExistsError:
                self._unlist(folder.name)
        raise FileExistsError(f"no free temporary folder name beside {self.real} after {FRESH_TRIES} tries")

    def _unlist(self, name: str) -> None:
        """Take ``name`` off the lock file's list (it was listed but is not ours)."""
        os.lseek(self.fd, 0, os.SEEK_SET)
        listed = os.read(self.fd, MAX_JOURNAL).decode("utf-8", "replace").split("\n")
        kept = "".join(f"{n}\n" for n in listed if n and n != name)
        os.ftruncate(self.fd, 0)
        os.lseek(self.fd, 0, os.SEEK_SET)
        os.write(self.fd, kept.encode())
        os.fsync(self.fd)

    def publish(self, files: Mapping[str, bytes | str]) -> list[Path]:
        """Write ``files`` (name -> content) into a new folder and swap it in; returns the output paths."""
        new = self.stage(files)
        fill(new, files, self.out)
        return self.swap(new, files)

    def stage(self, names: Iterable[str] = ()) -> Path:
        """A new hidden folder beside the output, recorded in the lock file, for :func:`fill` (in this
        process or another: a batch's worker) and then :meth:`swap` or :meth:`discard`."""
        if self.fd is None:
            raise RuntimeError("stage on a released claim")
        check_output(self.out, OUTPUT_NAMES | frozenset(names))
        try:
            return self.fresh(NEW)
        except OSError as exc:
            raise OutputError(
                f"{self.out}: cannot write the outputs: {exc.strerror}; nothing was written, the previous "
                "contents of the folder are unchanged"
            ) from exc

    def swap(self, new: Path, names: Iterable[str]) -> list[Path]:
        """Make the staged and filled folder ``new`` the output in one step; returns the output paths.
        On an error (or an interrupt) ``new`` is removed and the old contents stay."""
        names = list(names)
        with _removed_on_error(new, self.out):
            check_output(self.out, OUTPUT_NAMES | frozenset(names))
            _swap_in(new, self.real, self.fresh)
            os.ftruncate(self.fd, 0)  # the temporary folders are gone: nothing left to list
        return [self.out / name for name in names]

    def discard(self, new: Path) -> None:
        """Remove the staged folder ``new`` (nothing published) and drop the lock."""
        shutil.rmtree(new, ignore_errors=True)
        if self.fd is not None:
            os.ftruncate(self.fd, 0)
        self.release()


def fill(new: Path, files: Mapping[str, bytes | str], out: Path) -> None:
    """Write ``files`` into the staged folder ``new`` (:meth:`Claim.stage`) of the output ``out``, each
    fsynced, and give it the mode of ``out``. A write error removes ``new`` and raises OutputError."""
    with _removed_on_error(new, out):
        _fill(new, files, mode=_folder_mode(Path(os.path.realpath(out))))


@contextlib.contextmanager
def _removed_on_error(new: Path, out: Path):
    """Remove the staged folder ``new`` on any error or interrupt; an OSError (a full disk, a
    read-only folder) becomes the OutputError (exit 4) that says the old contents stay."""
    try:
        yield
    except OSError as exc:
        shutil.rmtree(new, ignore_errors=True)
        raise OutputError(
            f"{out}: cannot write the outputs: {exc.strerror or exc}; "
            "the previous contents of the folder are unchanged"
        ) from exc
    except BaseException:
        shutil.rmtree(new, ignore_errors=True)
        raise


def _folder_mode(real: Path) -> int:
    """Keep the mode of the folder being replaced; a new one gets the usual 0777 minus umask."""
    try:
        return stat.S_IMODE(real.stat().st_mode)
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o777 & ~umask


def _fill(folder: Path, files: Mapping[str, bytes | str], *, mode: int) -> None:
    """Write and fsync every file, then the folder itself, so the swap publishes complete files."""
    for name, content in files.items():
        if not name or "/" in name or name in (".", ".."):
            raise ValueError(f"not a plain output file name: {name!r}")
        data = content.encode("utf-8") if isinstance(content, str) else content
        fd = os.open(folder / name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view) :]
            os.fsync(fd)
        finally:
            os.close(fd)
    os.chmod(folder, mode)
    _fsync_dir(folder)


def _fsync_dir(folder: Path) -> None:
    if not hasattr(os, "O_DIRECTORY"):  # Windows cannot open a folder to fsync it
        return
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _swap_in(new: Path, real: Path, fresh: Callable[[str], Path]) -> None:
    """Make ``new`` the folder ``real`` in one atomic step (two renames where the syscall is missing);
    ``fresh`` makes a recorded temporary folder (:meth:`Claim.fresh`)."""
    if not real.exists():
        os.rename(new, real)
    elif exchange(new, real):
        shutil.rmtree(new, ignore_errors=True)  # ``new`` now holds the old report
    else:
        old = fresh(OLD)
        os.rename(real, old)  # replaces the empty placeholder folder
        os.rename(new, real)
        shutil.rmtree(old, ignore_errors=True)
    _fsync_dir(real.parent)


def _renameat2():
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_RENAMEAT2 = _renameat2()


def exchange(a: Path, b: Path) -> bool:
    """Swap the names ``a`` and ``b`` atomically (renameat2 RENAME_EXCHANGE); False where unsupported."""
    if _RENAMEAT2 is None:
        return False
    if _RENAMEAT2(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def claim_output(out: Path) -> Claim:
    """Check ``out`` and lock it for this process (reentrant); keep the returned claim until published."""
    real = check_output(out)
    held = _CLAIMS.get(real)
    if held is not None and held.fd is not None:
        return held
    claim = Claim(out, real)
    _CLAIMS[real] = claim
    return claim


def publish(files: Mapping[str, bytes | str], out: Path) -> list[Path]:
    """Publish ``files`` as the folder ``out`` whole, under this process's claim or a short one of its own."""
    return claim_output(out).publish(files)
