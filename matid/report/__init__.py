"""The report: presents a StudyResult as HTML and PDF, and computes nothing.

``render_report(result, units="SI")`` returns ``{"report.html": bytes, "report.pdf": bytes}``;
the caller writes them (atomically, see :func:`matid.io.results.atomic_write`). Content is built
once (:mod:`matid.report.content`), its figures drawn once by matplotlib to PNG
(:mod:`matid.report.images`), then typeset by :mod:`matid.report.html` (jinja2 template, plots
inlined as PNG) and :mod:`matid.report.pdf` (A4 pages typeset by reportlab's platypus), all in
this process. The hook for extra figures of a fit, ``TestFit.info["figures"]``, is described in
:mod:`matid.report.figures`; the three-point-bend figures drawn from ``info["plot_data"]`` in
:mod:`matid.report.bend`.
"""

from __future__ import annotations

from matid.model.results import StudyResult
from matid.report.content import build_report
from matid.report.html import render_html
from matid.report.images import render_images
from matid.report.pdf import render_pdf
from matid.units import UNIT_SYSTEMS

__all__ = ["render_report"]


def render_report(result: StudyResult, *, units: str = "SI") -> dict[str, bytes]:
    """{'report.html': ..., 'report.pdf': ...} rendered in memory; the caller writes them atomically."""
    if units not in UNIT_SYSTEMS:
        raise ValueError(f"units must be one of {', '.join(UNIT_SYSTEMS)}, got {units!r}")
    report = build_report(result, units)
    images = render_images(report)  # each figure drawn once, for both documents
    return {"report.html": render_html(report, images), "report.pdf": render_pdf(report, images)}
