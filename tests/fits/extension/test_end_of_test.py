"""A Deben Microtest record ends with the stage's end-of-test row, and rows are named by file line
(issue 28, benchmarks/real_records.md: ppieczywek/TDA ``BC_0_W_R.013.MTR``).

A Deben .MTR (19 quoted header lines, quoted names, no units row) ends with ``0,0,0,0,1,0,"0"``:
time, elongation and force all 0 after the last sample (Code 1). That row is not a sample: the fit
leaves it out and says so with its file line; any other row where time does not increase still
stops the read, at the line an editor shows. The records are made up here, of the same shape.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.app.pipeline import run_study
from matid.errors import DataError
from matid.io.study import load_study
from tests.fits.extension.test_start import K1, STRAIN, sls_ramp_hold

GAUGE_MM = 10.0
DT = 0.1  # s: "Start Sampletime : 100ms"
RATE = 0.002  # 1/s
END = '0,0,0,0,1,0,"0"'


def _deben_rows(seed: int) -> list[str]:
    """An SLS ramp to STRAIN and a hold (closed form), 0.1 s apart, as a Deben stage writes rows."""
    rng = np.random.default_rng(seed)
    ramp = STRAIN / RATE
    t = np.arange(1, int((ramp + 60.0) / DT) + 1) * DT
    eps = np.minimum(RATE * t, STRAIN)
    force = sls_ramp_hold(t, RATE, ramp) + rng.normal(0.0, 0.003, t.size)
    return [
        f'{a:.1f},{e * GAUGE_MM:.5f},{f:.4f},{e * GAUGE_MM + 0.003:.5f},0,100,"0.5 mm/min"'
        for a, e, f in zip(t, eps, force, strict=True)
    ]


def _deben(path: Path, rows: list[str]) -> Path:
    """A Deben Microtest .MTR: 19 quoted header lines (decimal commas), the quoted names on line 20."""
    head = [f'"File : C:\\CURVES\\{path.name} saved 2005-02-18 at 23:19:14"', '"Sample : Default"']
    head += ['"Span : 10,0"', '"Width : 5,0"', '"Thickness : 1,0"', '"Start Sampletime : 100ms"']
    head += ['"Start Speed : 0.5 mm/min"', '"Gain : x20"', '"Video file : "', '"Scale : 0,039"']
    head += [f'"Number of points : {len(rows) - 1}"', '"Ver5.5.29"', '""', '""', '""']
    head += ['"Test duration : 100,0s"', '"Max travel : 1,0mm"', '"Max extension : 1,0mm"']
    head += ['"Comment : 200N tensile with 1119:1 gearbox &  256 line encoder. Calibrated at 200N."']
    head += ['"Point","Elongation","Force","Position","Code","Samplerate","Motorspeed"']
    assert len(head) == 20
    path.write_bytes(("\n".join(head + rows) + "\n").encode("latin-1"))
    return path


def _study(folder: Path, rows: list[str]) -> Path:
    _deben(folder / "BC.MTR", rows)
    (folder / "study.toml").write_text(
        '[study]\nname = "deben"\n\n[[specimen]]\nid = "S1"\nwidth = "5 mm"\nheight = "1 mm"\n\n'
        '[[test]]\nkind = "extension"\nspecimen = "S1"\nfile = "BC.MTR"\ngauge_length = "10 mm"\n'
        'columns = { time = "Point", elongation = "Elongation", force = "Force" }\n'
        'units = { time = "s", elongation = "mm", force = "N" }\n',
        encoding="utf-8",
    )
    return folder / "study.toml"


def _line_of(path: Path, text: str) -> int:
    """The 1-based line of ``path`` that is ``text`` (as an editor shows it)."""
    return path.read_text(encoding="latin-1").splitlines().index(text) + 1


@pytest.mark.parametrize("seed", range(2))
def test_the_end_of_test_row_is_left_out_with_a_warning_naming_its_file_line(tmp_path, seed):
    study = _study(tmp_path, [*_deben_rows(seed), END])
    (fit,) = run_study(load_study(study)).fits
    e_e = next(e for e in fit.estimates if e.parameter == "E_e")
    assert e_e.value == pytest.approx(K1, rel=0.01)
    assert e_e.ci95[0] <= K1 <= e_e.ci95[1], e_e.ci95
    line = _line_of(tmp_path / "BC.MTR", END)
    (said,) = [w for w in e_e.warnings if "end-of-test row" in w]
    assert f"file line {line}" in said and "not read" in said
    assert sum(fit.info["left_out"]["BC.MTR"].values()) >= 1


@pytest.mark.parametrize(
    "last",
    [
        '0,0,.05,0,1,0,"0"',  # a force that is not 0: a sample, not the end-of-test row
        '0,.001,0,0,1,0,"0"',  # an elongation that is not 0
    ],
)
def test_a_last_row_where_time_falls_back_but_not_all_zero_is_refused_at_its_file_line(tmp_path, last):
    study = _study(tmp_path, [*_deben_rows(0), last])
    with pytest.raises(DataError, match="time must increase strictly") as caught:
        run_study(load_study(study))
    assert caught.value.row == _line_of(tmp_path / "BC.MTR", last)


def test_a_row_whose_time_goes_back_is_named_by_its_file_line_past_blank_lines(tmp_path):
    """Time going back mid-record, after a blank line: the message names the file's line, not the
    row's index among the data."""
    rows = _deben_rows(0)
    bad = rows[300].replace(rows[300].split(",")[0], "0.5", 1)
    rows = [*rows[:100], "", *rows[100:300], bad, *rows[301:]]
    study = _study(tmp_path, rows)
    with pytest.raises(DataError, match="time must increase strictly") as caught:
        run_study(load_study(study))
    line = _line_of(tmp_path / "BC.MTR", bad)
    assert line == 20 + 302  # 20 header lines, 301 rows and a blank line before it
    assert caught.value.row == line
    assert f"row {line}," in str(caught.value)
