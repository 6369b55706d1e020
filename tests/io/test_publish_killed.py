"""A run killed the instant its temporary folder exists leaves nothing the next claim cannot clean
(the kill loop of tests/test_fuzz.py found a '.out.matid-new-XXXX' left under load: the folder was
made by tempfile.mkdtemp and only then listed in the lock file)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from matid.io.publish import claim_output

CHILD = textwrap.dedent(
    """
    import os, sys, tempfile
    from pathlib import Path
    from matid.io.publish import claim_output

    def dies_once_made(make):  # the folder exists, then the process is gone (as by kill -9)
        def wrapped(*args, **kwargs):
            made = make(*args, **kwargs)
            os._exit(9)
        return wrapped

    out = Path(sys.argv[1])
    claim = claim_output(out)
    os.mkdir = dies_once_made(os.mkdir)
    tempfile.mkdtemp = dies_once_made(tempfile.mkdtemp)
    claim.publish({"report.html": "new"})
    """
)


def test_a_run_killed_once_its_temporary_folder_exists_leaves_nothing_behind(tmp_path):
    out = tmp_path / "out"
    with claim_output(out) as claim:
        claim.publish({"report.html": "old"})
    run = subprocess.run([sys.executable, "-c", CHILD, str(out)], capture_output=True, text=True)
    assert run.returncode == 9, run.stderr
    assert [p.name for p in tmp_path.iterdir() if ".matid-new-" in p.name]  # the kill left its folder
    with claim_output(out):  # the next claim cleans what the killed run listed
        pass
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.matid-lock", "out"]
    assert (out / "report.html").read_text() == "old"


def test_a_users_folder_named_like_a_temporary_one_is_never_touched(tmp_path):
    out = tmp_path / "out"
    mine = tmp_path / ".out.matid-new-zz"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    for _ in range(2):
        with claim_output(out) as claim:
            claim.publish({"report.html": "x"})
    assert (mine / "notes.txt").read_text() == "mine"
