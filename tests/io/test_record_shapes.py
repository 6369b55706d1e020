"""Readers on records in the shapes real exports have (issue 28 item 4).

- An Instron WaveMatrix export with two cycle counters no test uses, whose names differ only
  inside brackets (read as units): they must not stop the read.
- The same file named by two tests of a study (same sha256) is refused, instead of doubling
  the rows silently.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from matid.errors import DataError
from matid.io.ingest.read import load_measurements, read_table
from matid.io.study import load_study

#: A WaveMatrix-style header as the issue quotes it: the two cycle counters are unused.
WAVEMATRIX_HEADER = (
    '"Total Time (s)","Total Cycle Count(Linear Waveform)","Rotary Position (deg)",'
    '"Rotary Torque (N·m)","Total Cycle Count(Rotary Waveform)"'
)


def _wavematrix(path: Path) -> Path:
    angle = np.linspace(0.0, 30.0, 40)
    rows = [
        f"{0.1 * i:.3f},{i // 10},{a:.5f},{0.002 * a:.6f},{i // 20}" for i, a in enumerate(angle)
    ]
    path.write_text("\n".join([WAVEMATRIX_HEADER, *rows]) + "\n", encoding="utf-8")
    return path


def test_two_unused_columns_whose_names_differ_only_in_brackets_do_not_stop_a_read(tmp_path):
    path = _wavematrix(tmp_path / "wavematrix.csv")
    table = read_table(
        path, "torsion", columns={"twist_angle": "Rotary Position", "torque": "Rotary Torque"}
    )
    np.testing.assert_allclose(table["twist_angle"][-1], np.deg2rad(30.0))
    np.testing.assert_allclose(table["torque"][-1], 0.06)
    assert table.n_rows == 40


def test_a_used_column_written_twice_is_still_refused(tmp_path):
    path = tmp_path / "twice.csv"
    path.write_text("twist_angle [deg],torque [N m],torque [N m]\n0,0,0\n1,1,1\n2,2,2\n", encoding="utf-8")
    with pytest.raises(DataError, match="appears twice"):
        read_table(path, "torsion")


STUDY = """
[study]
name = "twice"

[[specimen]]
id = "T1"
outer_diameter = "2.4 mm"
inner_diameter = "1.6 mm"

[[test]]
kind = "torsion"
specimen = "T1"
file = "a.csv"
length = "60 mm"

[[test]]
kind = "torsion"
specimen = "T1"
file = "{second}"
length = "60 mm"
"""


def _torsion_csv(path: Path) -> Path:
    angle = np.linspace(0.0, 20.0, 30)
    path.write_text(
        "twist_angle [deg],torque [N m]\n" + "".join(f"{a:.4f},{1e-4 * a:.6g}\n" for a in angle),
        encoding="utf-8",
    )
    return path


def test_the_same_file_named_twice_in_a_study_is_refused(tmp_path):
    _torsion_csv(tmp_path / "a.csv")
    shutil.copy(tmp_path / "a.csv", tmp_path / "copy_of_a.csv")  # same bytes, another name
    for second in ("a.csv", "copy_of_a.csv"):
        (tmp_path / "study.toml").write_text(STUDY.format(second=second), encoding="utf-8")
        with pytest.raises(DataError, match=r"#1 and #2 .*name the same (file|contents)"):
            load_measurements(load_study(tmp_path / "study.toml"))


def test_two_different_files_of_one_specimen_are_read(tmp_path):
    _torsion_csv(tmp_path / "a.csv")
    other = tmp_path / "b.csv"
    other.write_text((tmp_path / "a.csv").read_text() + "20.5,0.00205\n", encoding="utf-8")
    (tmp_path / "study.toml").write_text(STUDY.format(second="b.csv"), encoding="utf-8")
    assert len(load_measurements(load_study(tmp_path / "study.toml"))) == 2
