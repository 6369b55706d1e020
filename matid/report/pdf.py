"""The PDF report: A4 pages typeset by reportlab's platypus from the report's content model.

The same :class:`~matid.report.content.Report` the HTML page shows, in the same order: a first
page (study, summary table, warnings, moduli), one part per test-kind section (each specimen's
fit plot, parameters, warnings, drawings, details and tests) and the provenance. Each page has
a header (the study) and a footer (matid's version, the page number); the PDF outline has one
entry per section of the HTML page and one per specimen block. Figures are the PNGs rendered
once for both documents (:mod:`matid.report.images`); text is in embedded DejaVu fonts
(:mod:`matid.report.pdfparts`) and can be searched and extracted.
"""

from __future__ import annotations

import io

from reportlab.lib import colors
from reportlab.lib.pagesizes import A4
from reportlab.lib.units import inch
from reportlab.platypus import BaseDocTemplate, CondPageBreak, Frame, PageBreak, PageTemplate, TableStyle
from reportlab.platypus.flowables import Flowable, HRFlowable

from matid.report.content import Block, Report, Section, Table, TestView
from matid.report.images import Image, Images
from matid.report.pdfparts import (
    AMBER,
    GREEN,
    GREY,
    MUTED,
    RULE,
    SANS,
    Together,
    assemble,
    binary_streams,
    box,
    figure,
    heading,
    para,
    picture,
    register_fonts,
    space,
    table,
)
from matid.report.quantities import Nested
from matid.report.verdict import STATUS_CLASS

MARGIN_X, MARGIN_TOP, MARGIN_BOTTOM = 0.65 * inch, 0.75 * inch, 0.75 * inch
WIDTH = A4[0] - 2 * MARGIN_X  # of the text, points
FIT_HEIGHT = 4.3 * inch  # the most a fit plot takes of a page (its PNG scaled to the text width)
DRAWING_HEIGHT = 4.6 * inch


def render_pdf(report: Report, images: Images) -> bytes:
    """The report as PDF bytes, its figures from ``images``."""
    register_fonts()
    buffer = io.BytesIO()
    doc = _document(buffer, report)
    story = _first_page(report)
    for i, section in enumerate(report.sections):
        story += _section(section, images, first=i == 0)
    story += _provenance(report)
    story += _glossary(report)
    with binary_streams():
        doc.build(assemble(story))
    return buffer.getvalue()


def _document(buffer: io.BytesIO, report: Report) -> BaseDocTemplate:
    doc = BaseDocTemplate(
        buffer,
        pagesize=A4,
        leftMargin=MARGIN_X,
        rightMargin=MARGIN_X,
        topMargin=MARGIN_TOP,
        bottomMargin=MARGIN_BOTTOM,
        title=f"{report.study}: matid stiffness report",
        subject="Stiffness identification (E_b, E_t, E_s, E_e) of catheter tubes",
        creator=f"matid {report.matid_version}",
        author=f"matid {report.matid_version}",
    )
    frame = Frame(MARGIN_X, MARGIN_BOTTOM, WIDTH, A4[1] - MARGIN_TOP - MARGIN_BOTTOM, 0, 0, 0, 0, id="text")
    header, footer = f"{report.study}: stiffness identification report", f"matid {report.matid_version}"

    def decorate(canvas, document) -> None:
        canvas.showOutline()  # the viewer opens with the outline shown
        canvas.saveState()
        canvas.setFont(SANS, 7)
        canvas.setFillColor(MUTED)
        canvas.drawString(MARGIN_X, A4[1] - 0.45 * inch, header)
        canvas.setStrokeColor(RULE)
        canvas.setLineWidth(0.5)
        canvas.line(MARGIN_X, A4[1] - 0.5 * inch, A4[0] - MARGIN_X, A4[1] - 0.5 * inch)
        canvas.drawString(MARGIN_X, 0.4 * inch, footer)
        canvas.drawRightString(A4[0] - MARGIN_X, 0.4 * inch, f"page {document.page}")
        canvas.restoreState()

    doc.addPageTemplates([PageTemplate("page", [frame], onPage=decorate)])
    return doc


def _table(t: Table | Nested, *, size: float = 7.0, numeric=None, mono=()) -> Flowable:
    numeric = t.numeric if numeric is None else numeric
    return table(t.header, t.rows, numeric, width=WIDTH, size=size, mono=mono)


def _part(title: str, key: str) -> list[Flowable]:
    """A part's heading, in the outline under ``key``, over a rule."""
    return [
        heading(title, 14, key=key),
        HRFlowable(width="100%", thickness=1.2, color=RULE, spaceBefore=0, spaceAfter=6),
    ]


# -- the first page ------------------------------------------------------------------------------


def _first_page(report: Report) -> list[Flowable]:
    """The study and its run, the summary table with each value's status, the warnings and the
    material moduli."""
    story = [*_title(report), space(8), *_part("Summary of stiffnesses", "summary")]
    story += [para(f"{words}: {meaning}", 8, space=1) for words, meaning in report.status_legend]
    story.append(para(report.summary_intro, 8, muted=True, space=4))
    story += [_summary_table(report.summary), space(8)]
    if report.use:
        title = para("Which value to use where a stiffness is estimated twice", 8.5, bold=True)
        story += [box(title, report.use, GREEN, width=WIDTH), space(8)]
    story += _warnings(report)
    if report.moduli:
        intro = para(report.moduli_intro, 8, muted=True, space=4)
        story.append(Together([*_part("Material moduli", "moduli"), intro, _table(report.moduli, size=6.5)]))
        story.append(space(12))
    return story


def _title(report: Report) -> list[Flowable]:
    story = [para("Stiffness identification report", 10, muted=True, space=2), heading(report.study, 18)]
    story += [para(f"{key}: {value}", 8.5) for key, value in report.meta]
    if report.sections:
        parts = "; ".join(f"{s.title} ({s.parameters})" for s in report.sections)
        story += [space(4), para(f"Sections: {parts}; Provenance", 8.5)]
    return story


def _summary_table(summary: Table) -> Flowable:
    """Page 1's table with each status word on the colour of its box (green, amber, grey)."""
    flowable = _table(summary, size=6.5)
    column = summary.header.index("status")
    faces = {"ok": GREEN[0], "check": AMBER[0], "none": colors.HexColor("#fde2e1")}
    commands = []
    for i, row in enumerate(summary.rows, start=1):
        face = faces.get(STATUS_CLASS.get(row[column], ""))
        if face is not None:
            commands.append(("BACKGROUND", (column, i), (column, i), face))
    flowable.setStyle(TableStyle(commands))
    return flowable


def _warnings(report: Report) -> list[Flowable]:
    """The warnings box (its title in the outline, as the HTML page's warnings section), then
    what is not yet fitted."""
    count = len(report.notes) + len(report.failures)
    if count:
        items = [f"could not be fitted: {line}" for line in report.failures]
        items += [f"[{n.number}] {n.where}: {n.text}" for n in report.notes]
        title = heading(f"{count} warning{'s' if count != 1 else ''}", 11, key="warnings")
        story = [box(title, items, AMBER, width=WIDTH)]
    else:
        title = heading("No warnings", 11, key="warnings")
        story = [box(title, ["Every fit completed without a warning."], GREEN, width=WIDTH)]
    if report.pending:
        title = para("Not yet fitted (by design, not an error)", 8.5, bold=True)
        story += [space(6), box(title, report.pending, GREY, width=WIDTH)]
    return [*story, space(10)]


# -- the sections --------------------------------------------------------------------------------


#: Room (points) the first section needs below page 1's content to start on the same page: so that
#: the end of page 1 (the moduli, the last warnings) never stands alone on a page of its own.
FIRST_SECTION_ROOM = 0.45 * A4[1]


def _section(section: Section, images: Images, *, first: bool = False) -> list[Flowable]:
    """A test-kind section from a new page (the first one: on the same page when there is room)."""
    start = CondPageBreak(FIRST_SECTION_ROOM) if first else PageBreak()
    story = [start, *_part(f"{section.title} ({section.parameters})", section.kind)]
    for block in section.blocks:
        story += _block(section, block, images)
    return story


def _block(section: Section, block: Block, images: Images) -> list[Flowable]:
    story: list[Flowable] = [
        heading(f"{section.title}, specimen {block.specimen}", 11.5, key=block.anchor, level=1)
    ]
    for status, line in block.messages:
        colours = AMBER if status == "failed" else GREY
        story += [box(para(line, 8.5, bold=True), (), colours, width=WIDTH), space(6)]
    if block.plot:
        image = images.plots[block.anchor]
        story.append(figure(None, picture(image.png, width=WIDTH, max_height=FIT_HEIGHT), image.caption))
    if block.parameters and block.parameters.rows:
        story += [heading("Parameters", 9.5), _table(block.parameters), space(6)]
    if block.warnings:
        items = [f"[{n}] {w}" for n, w in enumerate(block.warnings, 1)]
        story += [box(para("Warnings of this fit", 8.5, bold=True), items, AMBER, width=WIDTH), space(6)]
    story += [para(note, 7.5, muted=True, space=4) for note in block.fe_notes]
    if block.correlation:
        story += [heading("Correlation of the estimates", 9.5), _table(block.correlation), space(6)]
    story += [_drawing(image) for image in images.drawings.get(block.anchor, [])]
    story += _info(block.info)
    for extra in block.extras:
        if extra.png:
            story.append(figure(extra.title, picture(extra.png, width=WIDTH, max_height=DRAWING_HEIGHT), ""))
        else:
            story += [_failed(extra.title, str(extra.error)), space(6)]
    if block.tests:
        story.append(heading("Tests", 9.5))
        story += [_test(test) for test in block.tests]
    return [*story, space(10)]


def _failed(title: str, error: str) -> Flowable:
    return box(para(f"Figure could not be drawn: {title}", 8.5, bold=True), [error], AMBER, width=WIDTH)


def _drawing(image: Image) -> Together:
    """A rendered drawing under its title, its caption below; or why it could not be drawn."""
    if not image.png:
        return Together([_failed(image.title, image.error), space(6)])
    return figure(image.title, picture(image.png, width=WIDTH, max_height=DRAWING_HEIGHT), image.caption)


def _info(info) -> list[Flowable]:
    """The fit's details: quantities in a two-column table, nested values as small tables after it."""
    if not info:
        return []
    story: list[Flowable] = [heading("Fit window and details", 9.5)]
    plain = tuple((label, value) for label, value in info if not isinstance(value, Nested))
    if plain:
        story += [table(("item", "value"), plain, (False, False), width=WIDTH), space(4)]
    for label, value in info:
        if isinstance(value, Nested):
            numeric = (False, *(True,) * (len(value.header) - 1))
            story.append(para(label, 7.5, bold=True, keep=True, space=2))
            story += [_table(value, size=6.5, numeric=numeric), space(4)]
    return story


def _test(test: TestView) -> Together:
    """One test's file, checksum, set-up, note, units and metadata, kept together on a page."""
    rows = f", {test.n_rows} rows" if test.n_rows is not None else ""
    head = f"{test.file}  (sha256 {test.sha_short}{rows})"
    if test.exclude:
        head += "  EXCLUDED: exclude = true, left out of the fit"
    details = [*test.details, *(f"{k}: {v}" for k, v in test.metadata)]
    lines = [para(head, 8, mono=True, bold=True, space=1)] + [para(d, 7.5) for d in details]
    return Together([*lines, space(5)])


def _glossary(report: Report) -> list[Flowable]:
    story = [space(12), *_part("Glossary", "glossary")]
    return story + [para(f"{term}: {meaning}", 8, space=2) for term, meaning in report.glossary]


# -- provenance ----------------------------------------------------------------------------------


def _provenance(report: Report) -> list[Flowable]:
    story = [PageBreak(), *_part("Provenance", "provenance")]
    story.append(para("Every input file with its full SHA-256 checksum.", 8.5, space=4))
    rows = tuple((name, n, sha) for name, n, sha, _ in report.provenance.rows)
    if not rows:
        return [*story, para("No input files were read.", 8.5)]
    files = Table(("file", "rows", "sha256"), rows, (False, True, False))
    story += [_table(files, size=6.5, mono=(False, False, True)), space(6)]
    story += [
        para(f"{name}: {path}", 6.5, mono=True, muted=True) for name, _, _, path in report.provenance.rows
    ]
    return story
