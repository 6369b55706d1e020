"""The summary of a batch: ``summary.csv``, ``summary.xlsx`` and the comparison page ``summary.html``.

docs/contract.md section 8. The tables hold every specimen of every study, one
row per parameter, the study folder name first. The page shows, per parameter,
each specimen's value with its 95 % interval and the mean ± sd across specimens
of one section (sample standard deviation, n - 1; no sd from a single specimen;
tubes of different sizes are never pooled), failed studies first, a link to each
study's report, values to check marked, and every warning listed.
"""

from __future__ import annotations

import base64
import html
import io
import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path

from matid.app.outcome import SUMMARY_NAMES, StudyOutcome
from matid.io.results import CSV_COLUMNS, atomic_write, csv_text

#: Columns of summary.csv and of the sheet ``summary``: the study folder name, then stiffness.csv's.
from matid.model.results import PARAMETER_ORDER
from matid.toml import escaped

SUMMARY_COLUMNS = ["study", *CSV_COLUMNS]
#: Columns of the sheet ``studies``.
STUDY_COLUMNS = ["study", "source", "exit_code", "error", "warnings", "runtime_s"]
#: Parameters left out of the comparison: sls_k1 is E_e under another name.
_COMPARE_SKIP = {"sls_k1"}


def summary_rows(outcomes: Sequence[StudyOutcome]) -> list[dict[str, object]]:
    """Every row of every study's stiffness table, the study folder name first."""
    return [{"study": o.name, **row} for o in outcomes for row in o.rows]


def study_rows(outcomes: Sequence[StudyOutcome]) -> list[dict[str, object]]:
    """One row per study: folder name, path given, exit code, error, number of warnings, run time."""
    return [
        {"study": o.name, "source": o.source, "exit_code": o.code, "error": o.error.split("\n")[0],
         "warnings": len(o.warnings), "runtime_s": round(o.runtime_s, 2)}
        for o in outcomes
    ]  # fmt: skip


def statistics_by_parameter(
    rows: Sequence[dict], geometry: Mapping[tuple[str, str], str] | None = None
) -> list[dict[str, object]]:
    """Per parameter (in table order) and, given ``geometry`` ((study, specimen) -> section),
    per section: unit, n specimens pooled, mean, sd (None for n < 2), cv, the rows pooled and the rows
    ``left_out``. Only values whose status is ``ok`` are pooled: a value to check, or one the data do
    not determine, is left out and named, never averaged in."""
    out = []
    for name in PARAMETER_ORDER:
        if name in _COMPARE_SKIP:
            continue
        groups: dict[str, list[dict]] = {}
        for r in rows:
            if r["parameter"] == name:
                section = geometry.get((r["study"], r["specimen"]), "") if geometry else ""
                groups.setdefault(section, []).append(r)
        for section, group in groups.items():
            pooled = [r for r in group if r.get("status", "ok") == "ok" and r["value"] is not None]
            values = [float(r["value"]) for r in pooled]
            mean = statistics.fmean(values) if values else None
            sd = statistics.stdev(values) if len(values) > 1 else None
            cv = None if sd is None or not mean else abs(sd / mean)
            out.append({"parameter": name, "unit": group[0]["unit"], "n": len(values), "mean": mean, "sd": sd,
                        "cv": cv, "rows": pooled, "left_out": [r for r in group if r not in pooled],
                        "geometry": section})  # fmt: skip
    return out


def left_out_text(stat: Mapping) -> str:
    """The values a mean leaves out, by study / specimen with their status ("" when none)."""
    from matid.report.verdict import STATUS_WORDS

    return ", ".join(
        f"{r['study']} / {r['specimen']} ({STATUS_WORDS.get(str(r.get('status')), r.get('status'))})"
        for r in stat["left_out"]
    )


def geometry_of(outcomes: Sequence[StudyOutcome]) -> dict[tuple[str, str], str]:
    """(study, specimen) -> its section in words ("tube 2/1.5 mm"), read from each study.toml;
    "section not known" for a study that cannot be read again."""
    from matid.errors import MatidError
    from matid.io.study import load_study

    out: dict[tuple[str, str], str] = {}
    for o in outcomes:
        try:
            specimens = load_study(o.source).specimens if o.rows else ()
        except (MatidError, OSError):
            specimens = ()
        known = {s.id: s.section.describe() for s in specimens}
        for row in o.rows:
            out[(o.name, row["specimen"])] = known.get(row["specimen"], "section not known")
    return out


def write_summary(outcomes: Sequence[StudyOutcome], out: Path) -> list[Path]:
    """Write summary.csv, summary.xlsx and summary.html into ``out`` (each atomically); returns the paths."""
    from matid.io.xlsx import workbook

    rows = summary_rows(outcomes)
    csv_name, xlsx_name, html_name = SUMMARY_NAMES  # the names run_batch keeps free of study folders
    files: dict[str, str | bytes] = {
        csv_name: csv_text(rows, SUMMARY_COLUMNS),
        xlsx_name: workbook(
            {"summary": (SUMMARY_COLUMNS, rows), "studies": (STUDY_COLUMNS, study_rows(outcomes))}
        ),
        html_name: comparison_page(outcomes),
    }
    for name, content in files.items():
        atomic_write(out / name, content)
    return [out / name for name in files]


def comparison_figure(stats: Sequence[dict]) -> bytes:
    """PNG: one panel per parameter and section, each specimen's value with its 95 % interval (values
    left out of the mean hollow and grey), the mean ± sd of the pooled ones shaded."""
    from matplotlib.figure import Figure

    height = sum(0.9 + 0.28 * (s["n"] + len(s["left_out"])) for s in stats) or 1.0
    fig = Figure(figsize=(7.5, height), layout="constrained")
    axes = fig.subplots(max(len(stats), 1), 1, squeeze=False)[:, 0]
    for ax, s in zip(axes, stats, strict=False):
        shown = [r for r in (*s["rows"], *s["left_out"]) if r["value"] is not None]
        labels = [escaped(f"{r['study']} / {r['specimen']}") for r in shown]  # no control glyphs
        if s["sd"] is not None:
            ax.axvspan(
                s["mean"] - s["sd"], s["mean"] + s["sd"], color="tab:blue", alpha=0.12, label="mean ± sd"
            )
        if s["mean"] is not None:
            ax.axvline(s["mean"], color="tab:blue", lw=1, label="mean")
        for pooled, style in ((True, {"color": "black"}), (False, {"color": "grey", "mfc": "white"})):
            mine = [(i, r) for i, r in enumerate(shown) if (r in s["rows"]) == pooled]
            if not mine:
                continue
            values = [float(r["value"]) for _, r in mine]
            low = [0.0 if r["ci95_low"] is None else v - r["ci95_low"] for v, (_, r) in zip(values, mine, strict=True)]
            high = [0.0 if r["ci95_high"] is None else r["ci95_high"] - v for v, (_, r) in zip(values, mine, strict=True)]
            label = "value, 95 % interval" if pooled else "left out of the mean (not ok)"
            ax.errorbar(values, [i for i, _ in mine], xerr=[low, high], fmt="o", ms=4, capsize=3, label=label,
                        **style)  # fmt: skip
        ax.set_yticks(list(range(len(labels))), labels)
        ax.invert_yaxis()
        ax.set_xlabel(f"{s['parameter']} [{s['unit']}]")
        if s.get("geometry"):
            ax.set_title(f"{s['parameter']}, {s['geometry']}", fontsize="medium", loc="left")
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4), useMathText=True)
    legend = {label: handle for ax in axes for handle, label in zip(*ax.get_legend_handles_labels(), strict=True)}
    if legend:
        fig.legend(legend.values(), legend.keys(), loc="outside upper left", ncols=4, frameon=False,
                   fontsize="small")  # fmt: skip
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    return buffer.getvalue()


def _num(x: object, digits: int = 4) -> str:
    return "" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.{digits}g}"


def _percent(x: float | None) -> str:
    return "" if x is None else f"{100 * x:.2g} %"


def comparison_page(outcomes: Sequence[StudyOutcome]) -> str:
    """The self-contained HTML comparison page (figure inlined as PNG): failed studies first,
    statistics per parameter within one section, each specimen's value marked when to check."""
    geometry = geometry_of(outcomes)
    stats = statistics_by_parameter(summary_rows(outcomes), geometry)
    esc = html.escape
    stat_rows = "".join(
        f"<tr><td>{s['parameter']}</td><td>{s['n']}</td><td>{_num(s['mean'])}</td><td>{_num(s['sd'], 2)}</td>"
        f"<td>{_percent(s['cv'])}</td><td>{esc(s['unit'])}</td><td>{esc(s['geometry'])}</td>"
        f"<td>{esc(left_out_text(s))}</td></tr>"
        for s in stats
    )
    failed = [o for o in outcomes if o.code != 0]
    failed_box = "".join(f"<li><b>{esc(o.name)}</b> (exit {o.code}): {esc(_why(o))}</li>" for o in failed)
    study_table = "".join(
        f"<tr><td>{_link(o)}</td><td>{o.code}</td><td>{len(o.warnings)}</td>"
        f"<td>{o.runtime_s:.1f} s</td><td>{esc(o.error.split(chr(10))[0])}</td></tr>"
        for o in sorted(outcomes, key=lambda o: o.code == 0)
    )
    warnings = "".join(f"<li>{esc(o.name)}: {esc(w)}</li>" for o in outcomes for w in o.warnings)
    figure = base64.b64encode(comparison_figure(stats)).decode() if stats else ""
    return _PAGE.format(
        n_studies=len(outcomes),
        n_specimens=len({(r["study"], r["specimen"]) for r in summary_rows(outcomes)}),
        failed=f'<div class="failed"><h2>{len(failed)} failed</h2><ul>{failed_box}</ul></div>' * bool(failed),
        stats=stat_rows or "<tr><td colspan=8>no values</td></tr>",
        values=_value_rows(stats) or "<tr><td colspan=7>no values</td></tr>",
        studies=study_table,
        figure=f'<img alt="values per specimen with 95 % intervals" src="data:image/png;base64,{figure}">'
        if figure else "<p>No values to compare.</p>",
        warnings=f"<ul>{warnings}</ul>" if warnings else "<p>No warnings.</p>",
    )  # fmt: skip


def _why(o: StudyOutcome) -> str:
    return o.error.split("\n")[0] if o.error else "; ".join(o.failures) or "warnings (--strict)"


def _link(o: StudyOutcome) -> str:
    """The study's name, linked to its report.html (relative to summary.html) when it was written."""
    name = html.escape(o.name)
    written = any(Path(p).name == "report.html" for p in o.paths)
    return f'<a href="{name}/report.html">{name}</a>' if written else name


def _value_rows(stats: Sequence[dict]) -> str:
    """Each specimen's value by parameter and section, values to check marked (page 1's words)."""
    from matid.report.verdict import STATUS_WORDS

    esc = html.escape
    rows = []
    for s in stats:
        for r in (*s["rows"], *s["left_out"]):
            low, high = _num(r["ci95_low"]), _num(r["ci95_high"])
            interval = f"{low} to {high}" if low and high else ""
            status = str(r.get("status", "ok"))
            mark = ("⚠ " if status == "check" else "") + STATUS_WORDS.get(status, "")
            rows.append(
                f"<tr><td>{s['parameter']}</td><td>{esc(s['geometry'])}</td>"
                f"<td>{esc(r['study'])} / {esc(r['specimen'])}</td><td>{_num(r['value'])}</td>"
                f'<td>{interval}</td><td>{esc(str(r["unit"]))}</td><td class="mark">{mark}</td></tr>'
            )
    return "".join(rows)


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>matid: comparison of studies</title>
<style>
body {{ font-family: sans-serif; max-width: 60em; margin: 1em auto; padding: 0 1em; }}
table {{ border-collapse: collapse; margin: 0.5em 0 1.5em; }}
td, th {{ border-bottom: 1px solid #ccc; padding: 0.2em 0.8em; text-align: left; }}
td:nth-child(n+2) {{ font-variant-numeric: tabular-nums; }}
td.mark {{ color: #8a5a00; font-weight: 600; }}
.failed {{ background: #fde2e1; border-left: 6px solid #c0392b; padding: 0.3em 1em; margin: 1em 0; }}
img {{ max-width: 100%; }}
</style></head><body>
<h1>Comparison of {n_studies} studies, {n_specimens} specimens</h1>
{failed}
<h2>Studies</h2>
<p>Failed studies first; each name links to its report.</p>
<table><thead><tr><th>study</th><th>exit code</th><th>warnings</th><th>run time</th><th>error</th></tr>
</thead>
<tbody>{studies}</tbody></table>
<h2>Mean ± standard deviation across specimens of one section</h2>
<p>Specimens of different sections are never pooled, and only values whose status is "use it" are: a value
to check, or one the data do not determine, is left out of the mean and named in the last column.</p>
<table><thead><tr><th>parameter</th><th>specimens pooled</th><th>mean</th><th>sd</th><th>cv</th><th>unit</th>
<th>section</th><th>left out (status)</th></tr></thead>
<tbody>{stats}</tbody></table>
<h2>Each specimen with its 95 % interval</h2>
{figure}
<table><thead><tr><th>parameter</th><th>section</th><th>study / specimen</th><th>value</th>
<th>95 % interval</th><th>unit</th><th>status</th></tr></thead>
<tbody>{values}</tbody></table>
<h2>Warnings</h2>
{warnings}
</body></html>
"""
