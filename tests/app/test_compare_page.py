"""summary.html of a batch (issue 22): failed studies first, each study linked to its report,
mean ± sd only within one section, values to check marked. Built from outcomes, without fits."""

from __future__ import annotations

import re
import statistics
from pathlib import Path

from matid.app.compare import comparison_page
from matid.app.outcome import StudyOutcome

TOML = """[study]
name = "{name}"
{specimens}
[[test]]
kind = "torsion"
specimen = "{first}"
file = "t.csv"
length = "60 mm"
"""


def study(folder: Path, sections: dict[str, tuple[str, str]]) -> str:
    """A readable study.toml with the given specimens (id -> outer, inner diameter)."""
    folder.mkdir(parents=True)
    specimens = "".join(
        f'[[specimen]]\nid = "{sid}"\nouter_diameter = "{od}"\ninner_diameter = "{idia}"\n'
        for sid, (od, idia) in sections.items()
    )
    (folder / "study.toml").write_text(
        TOML.format(name=folder.name, specimens=specimens, first=next(iter(sections)))
    )
    (folder / "t.csv").write_text("twist_angle [deg],torque [N mm]\n0,0\n1,1\n")
    return str(folder)


def row(specimen: str, value: float, status: str = "ok") -> dict:
    return {"specimen": specimen, "parameter": "E_b", "value": value, "stderr": 0.01 * value,
            "ci95_low": 0.98 * value, "ci95_high": 1.02 * value, "unit": "N m^2", "n_points": 20,
            "method": "linear", "warnings": "" if status == "ok" else "a warning",
            "status": status}  # fmt: skip


def outcomes(tmp_path: Path) -> list[StudyOutcome]:
    small = study(tmp_path / "small", {"A": ("2 mm", "1.5 mm"), "B": ("2 mm", "1.5 mm")})
    large = study(tmp_path / "large", {"C": ("4 mm", "3 mm")})
    rows_small = [row("A", 6e-5), row("B", 7e-5, "check")]
    return [
        StudyOutcome(small, "small", 0, rows=rows_small, paths=[str(tmp_path / "out/small/report.html")]),
        StudyOutcome(
            large, "large", 0, rows=[row("C", 9e-4)], paths=[str(tmp_path / "out/large/report.html")]
        ),
        StudyOutcome(str(tmp_path / "broken"), "broken", 2, error="study.toml: no [[test]] entries"),
    ]


def test_failed_study_first_and_each_study_linked(tmp_path):
    page = comparison_page(outcomes(tmp_path))
    assert page.index("broken") < page.index("small") and page.index("1 failed") < page.index("<h2>Studies")
    assert '<a href="small/report.html">small</a>' in page and '<a href="large/report.html">large</a>' in page
    assert '<a href="broken/report.html">' not in page  # no report was written


def test_mean_and_sd_only_within_one_section_and_only_of_values_ok(tmp_path):
    """small/A (ok) and small/B (check it) share a section: only A is pooled, B is named as left out;
    large/C, another section, is never pooled with them."""
    page = comparison_page(outcomes(tmp_path))
    assert re.search(
        r"<td>E_b</td><td>1</td><td>6e-05</td><td></td><td></td><td>N m\^2</td><td>tube 2/1.5 mm</td>"
        r"<td>small / B \(check it\)</td>", page
    )
    assert re.search(
        r"<td>E_b</td><td>1</td><td>0.0009</td><td></td><td></td><td>N m\^2</td><td>tube 4/3 mm</td><td></td>", page
    )
    for pooled in ([6e-5, 7e-5], [6e-5, 7e-5, 9e-4]):
        assert f"<td>{statistics.fmean(pooled):.4g}</td>" not in page


def test_the_terminal_summary_pools_the_same_way(tmp_path):
    from types import SimpleNamespace

    from matid.app.cli import batch_summary

    text = batch_summary(SimpleNamespace(outcomes=outcomes(tmp_path)))
    assert "E_b (tube 2/1.5 mm): 6e-05 N m^2 (one specimen, status ok); left out: small / B (check it)" in text
    assert "E_b (tube 4/3 mm): 0.0009 N m^2 (one specimen, status ok)" in text
    assert f"{statistics.fmean([6e-5, 7e-5]):.5g}" not in text and "of 2 specimens" not in text
    assert "of 3 specimens" not in text


def test_values_to_check_are_marked(tmp_path):
    page = comparison_page(outcomes(tmp_path))
    marked = re.findall(r"<td>(\w+) / (\w)</td>.*?<td class=\"mark\">([^<]*)</td>", page)
    assert [(s, m) for _, s, m in marked] == [("A", "use it"), ("B", "⚠ check it"), ("C", "use it")]
