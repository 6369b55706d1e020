"""Publishing an output folder whole (matid.io.publish): swap, fallback, recovery, checks, lock."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from matid.app.cli import main
from matid.errors import DataError
from matid.io import publish
from matid.io.publish import OutputError, check_output, claim_output
from tests import ROOT

OLD = {"report.html": b"old html", "report.pdf": b"old pdf", "stiffness.csv": b"old csv"}
NEW = {"report.html": "new html", "report.pdf": b"new pdf", "stiffness.json": "{}\n"}


def _contents(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def _beside(out: Path) -> list[str]:
    return sorted(
        p.name
        for p in out.parent.iterdir()
        if p.name.startswith(f".{out.name}.matid-") and "lock" not in p.name
    )


def _broken_study(tmp_path: Path) -> str:
    """A study whose toml is unreadable: an --out error first shows --out was checked before it."""
    folder = tmp_path / "study"
    folder.mkdir(exist_ok=True)
    (folder / "study.toml").write_text("not [ toml")
    return str(folder)


def _encoded(files):
    return {k: v.encode() if isinstance(v, str) else v for k, v in files.items()}


def test_publish_creates_then_replaces_the_whole_folder(tmp_path):
    out = tmp_path / "out"
    assert publish.publish(OLD, out) == [out / n for n in OLD]
    assert _contents(out) == OLD
    publish.publish(NEW, out)
    assert _contents(out) == _encoded(NEW)  # stiffness.csv of the old report is gone with it
    assert _beside(out) == []


def test_a_staged_folder_is_published_only_by_its_swap_and_a_discarded_one_leaves_nothing(tmp_path):
    """A batch stages a folder (recorded in the lock file), a worker fills it, the batch swaps it in or
    discards it (matid.app.batch): the old folder stays whole until the swap, and a discarded folder is
    gone with its lock."""
    out = tmp_path / "out"
    publish.publish(OLD, out)
    claim = claim_output(out)
    new = claim.stage(NEW)
    publish.fill(new, NEW, out)
    assert _beside(out) == [new.name] and _contents(out) == OLD  # filled, not yet published
    assert claim.swap(new, NEW) == [out / n for n in NEW]
    assert _contents(out) == _encoded(NEW) and _beside(out) == []
    new = claim.stage(OLD)
    publish.fill(new, OLD, out)
    claim.discard(new)
    assert claim.fd is None and _contents(out) == _encoded(NEW) and _beside(out) == []
    with claim_output(out) as again:  # the lock was dropped: another claim gets it at once
        assert again.fd is not None


@pytest.mark.skipif(publish._RENAMEAT2 is None, reason="no renameat2 in this libc")
def test_exchange_swaps_two_folders(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    (a / "x").write_text("a"), (b / "x").write_text("b")
    if not publish.exchange(a, b):
        pytest.skip("this filesystem does not support RENAME_EXCHANGE")
    assert ((a / "x").read_text(), (b / "x").read_text()) == ("b", "a")


CRASHER = textwrap.dedent(
    """
    import os, sys
    from pathlib import Path
    from matid.io import publish
    publish.exchange = lambda a, b: False  # the two-rename fallback
    real, calls = os.rename, []
    def rename(a, b):
        calls.append(b)
        if len(calls) == 2:
            os._exit(9)  # killed between the two renames
        real(a, b)
    publish.os.rename = rename
    publish.publish({"report.html": "newer"}, Path(sys.argv[1]))
    """
)


def test_without_renameat2_two_renames_publish_and_a_crash_between_them_is_recovered(tmp_path, monkeypatch):
    out = tmp_path / "out"
    publish.publish(OLD, out)
    monkeypatch.setattr(publish, "exchange", lambda a, b: False)
    publish.publish(NEW, out)
    assert _contents(out) == _encoded(NEW) and _beside(out) == []
    monkeypatch.undo()
    # a run killed after the first fallback rename: the report sits under the hidden -old- name, DIR is
    # missing, the new folder is left beside it
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    crash = subprocess.run([sys.executable, "-c", CRASHER, str(out)], env=env, timeout=60)
    assert crash.returncode == 9 and not out.exists() and len(_beside(out)) == 2
    with claim_output(out):
        assert _contents(out) == _encoded(NEW)
    assert _beside(out) == []


def test_a_users_folders_named_like_matids_temporaries_are_never_touched(tmp_path):
    """Before: a claim of DIR deleted every ``.DIR.matid-new-*`` and ``.DIR.matid-old-*`` beside it (a
    user's ``.T1.matid-new-zz`` with their files in it), and with DIR missing renamed a user's
    ``.DIR.matid-old-*`` to DIR. After: only the temporary folders matid made (and recorded in the
    lock file) are removed or moved back."""
    out = tmp_path / "T1"
    mine = {name: tmp_path / name for name in (".T1.matid-new-zz", ".T1.matid-old-zz")}
    for folder in mine.values():
        folder.mkdir()
        (folder / "data.txt").write_text("mine")
    with claim_output(out):
        assert not out.exists()  # nothing was moved to DIR
    publish.publish(OLD, out)
    publish.publish(NEW, out)
    assert _contents(out) == _encoded(NEW)
    for folder in mine.values():
        assert (folder / "data.txt").read_text() == "mine"
    assert sorted(_beside(out)) == sorted(mine)


def test_a_write_error_leaves_the_old_folder_and_no_temp_folder(tmp_path, monkeypatch):
    out = tmp_path / "out"
    publish.publish(OLD, out)

    write, calls = os.write, []

    def full(fd, data):  # the temporary folder's name reaches the lock file; the outputs do not fit
        calls.append(fd)
        if len(calls) == 1:
            return write(fd, data)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(publish.os, "write", full)
    with pytest.raises(OutputError, match="No space left on device.*unchanged"):
        publish.publish(NEW, out)
    monkeypatch.undo()
    assert len(calls) == 2  # failed while writing an output, inside the new folder
    assert _contents(out) == OLD and _beside(out) == []


def test_the_folder_mode_is_kept(tmp_path):
    out = tmp_path / "out"
    publish.publish(OLD, out)
    out.chmod(0o750)
    publish.publish(NEW, out)
    assert out.stat().st_mode & 0o777 == 0o750


@pytest.mark.parametrize(
    ("setup", "message"),
    [
        (lambda out: out.write_text("x"), "is a file"),
        (lambda out: out.parent.joinpath("f").write_text("x"), "which is a file"),
        (lambda out: (out.mkdir(), out.joinpath("mine.txt").write_text("x")), "holds 'mine.txt'"),
    ],
    ids=["a file", "under a file", "foreign files"],
)
def test_unusable_out_is_refused_before_fitting(tmp_path, capsys, setup, message):
    out = tmp_path / "out"
    setup(out)
    target = tmp_path / "f" / "out" if message == "which is a file" else out
    code = main(["fit", _broken_study(tmp_path), "--out", str(target)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert message in err and str(target) in err and "TOML" not in err


def test_a_read_only_out_is_refused(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    if os.geteuid() == 0:
        done = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(ro)], capture_output=True
        )
        if done.returncode != 0:
            pytest.skip("root without a tmpfs mount: cannot make a read-only folder")
    else:
        ro.chmod(0o555)
    try:
        assert main(["fit", _broken_study(tmp_path), "--out", str(ro / "out")]) == 2
        assert "read-only" in capsys.readouterr().err
        with pytest.raises(DataError, match="read-only"):
            check_output(ro / "out")
    finally:
        if os.geteuid() == 0:
            subprocess.run(["umount", "-l", str(ro)], check=False)
        else:
            ro.chmod(0o755)


def test_old_temp_files_of_per_file_writes_are_no_obstacle_and_go_away(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / ".report.html.x1y2z3").write_text("half")
    (out / ".inner.matid-lock").write_text("")
    publish.publish(NEW, out)
    assert _contents(out) == _encoded(NEW)


HOLDER = textwrap.dedent(
    """
    import sys, time
    from matid.io.publish import claim_output
    claim = claim_output(sys.argv[1])
    print("locked", flush=True)
    time.sleep(60)
    """
)


def test_a_second_writer_is_refused_while_the_first_holds_the_folder(tmp_path, capsys):
    out = tmp_path / "out"
    root = ROOT
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(out)],
        stdout=subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": str(root)},
    )
    try:
        assert holder.stdout.readline().strip() == b"locked"
        assert main(["fit", _broken_study(tmp_path), "--out", str(out)]) == 2
        assert "being written by another matid run" in capsys.readouterr().err
        with pytest.raises(DataError, match="another matid run"):
            publish.publish(NEW, out)
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
    publish.publish(NEW, out)  # the kernel dropped the killed holder's lock
    assert _contents(out) == _encoded(NEW)


def test_claims_are_reentrant_in_one_process_and_released(tmp_path):
    out = tmp_path / "out"
    with claim_output(out) as claim:
        assert claim_output(out) is claim
        publish.publish(OLD, out)  # under the held claim
    assert claim.fd is None
    with claim_output(out):
        pass
