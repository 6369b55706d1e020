"""The PDF report: A4 portrait pages drawn with matplotlib and saved through PdfPages.

A title page (header, summary table, warnings), then one part per test-kind section (the
same plots as the HTML report and the same tables) and the provenance.
Pages are laid out by :class:`matid.report.layout.Flow`. Figures are the PNGs rendered once
for both documents (:mod:`matid.report.images`; their image streams encoded by the process
that drew them where it could, :func:`_prepared_images`); fonts are embedded (Type 3 with a ToUnicode
map), so the text can be searched and extracted.
"""

from __future__ import annotations

import io
from datetime import UTC

import matplotlib
from matplotlib.backends.backend_pdf import PdfPages

from matid.report.content import Block, Report, Section, Table, TestView
from matid.report.images import Image, Images, render_images
from matid.report.layout import SANS, Flow, wrap
from matid.report.quantities import Nested

AMBER, AMBER_EDGE, GREY_BOX, GREY_EDGE = "#fff4d6", "#e0a800", "#f3f4f6", "#8a94a6"
FIT_HEIGHT = 4.6  # inches of a fit plot on the page (its PNG scaled to the text width)
SQUEEZE = 0.85  # a drawing may shrink to this share of its height to fit the rest of a page
#: Type 3 fonts: 25 % less PDF time than TrueType (42) subsetting, and the text still extracts
#: and searches (matplotlib writes a ToUnicode map); measured on the demo report.
RC = {"pdf.fonttype": 3, "font.family": SANS, "axes.unicode_minus": False}


def render_pdf(report: Report, images: Images | None = None) -> bytes:
    """The report as PDF bytes (figures from ``images``, rendered here if not given)."""
    images = render_images(report) if images is None else images
    buffer = io.BytesIO()
    metadata = {
        "Title": f"{report.study}: matid stiffness report",
        "Subject": "Stiffness identification (E_b, E_t, E_s, E_e) of catheter tubes",
        "Creator": f"matid {report.matid_version}",
    }
    when = report.run_date
    if when is not None:  # the same result gives the same bytes
        # in UTC: matplotlib writes the sign of a non-zero utcoffset the wrong way round
        metadata["CreationDate"] = when.astimezone(UTC) if when.tzinfo else when
    with matplotlib.rc_context(RC), PdfPages(buffer, metadata=metadata) as pdf:
        flow = Flow(pdf, footer=f"{report.study} · matid {report.matid_version}")
        _prepared_images(pdf, flow)
        _title_page(flow, report)
        for section in report.sections:
            _section(flow, section, images)
        _provenance(flow, report)
        flow.close()
    return buffer.getvalue()


def _prepared_images(pdf: PdfPages, flow: Flow) -> None:
    """Let the PDF write the image streams the image job's child prepared for its figures
    (:func:`matid.report.images.pdf_image`, the bytes ``PdfFile._writeImg`` writes) instead of
    encoding their pixels again when it closes; the other images as ``PdfFile.writeImages`` does."""
    file = pdf._ensure_file() if hasattr(pdf, "_ensure_file") else None
    if file is None or not all(hasattr(file, n) for n in ("_images", "_unpack", "_writeImg", "writeImages")):
        return  # another matplotlib: it writes every image itself

    def write_images() -> None:
        compression = matplotlib.rcParams["pdf.compression"]
        for img, _name, ob in file._images.values():
            source = flow.sources.get(id(img))
            prepared = source[1].stream() if source is not None and source[0] is img else None
            if prepared is not None and prepared[0] == compression:
                _, extra, png, data = prepared
                file.beginStream(ob.id, file.reserveObject("length of image stream"), extra, png=png)
                file.currentstream.write(data)
                file.endStream()
                continue
            data, adata = file._unpack(img)  # PdfFile.writeImages
            smask = None
            if adata is not None:
                smask = file.reserveObject("smask")
                file._writeImg(adata, smask.id)
            file._writeImg(data, ob.id, smask)

    file.writeImages = write_images


# -- pages --------------------------------------------------------------------------------------


def _title_page(flow: Flow, report: Report) -> None:
    flow.new_page()
    flow.paragraph("Stiffness identification report", size=10, color="#5f6368")
    flow.heading(report.study, level=0)
    software = ", ".join([f"matid {report.matid_version}", *(f"{k} {v}" for k, v in report.versions)])
    for key, value in [
        ("Temperature", report.temperature),
        ("Run started", report.started),
        ("Runtime", report.runtime),
        ("Units", report.units),
        ("Software", software),
    ]:
        flow.paragraph(f"{key}: {value}", size=8.5)
    flow.space(0.1)
    if report.sections:
        flow.paragraph(
            "Sections: " + "; ".join(f"{s.title} ({s.parameters})" for s in report.sections) + "; Provenance",
            size=8.5,
        )
    flow.heading("Summary of stiffnesses", level=1)
    flow.paragraph(
        f"Values in {report.units} units, as in stiffness.json and stiffness.csv, rounded to two "
        "significant figures of the standard error; 95 % confidence interval from-to; "
        "⚠ [n] points to warning n below the table.",
        size=8,
        color="#5f6368",
    )
    flow.table(report.summary, size=6.5)
    count = len(report.notes) + len(report.failures)
    if count:
        items = [f"could not be fitted: {line}" for line in report.failures]
        items += [f"[{n.number}] {n.where}: {n.text}" for n in report.notes]
        flow.box(f"{count} warning{'s' if count != 1 else ''}", items, (AMBER, AMBER_EDGE))
    else:
        flow.box("No warnings", ["Every fit completed without a warning."], ("#eaf6ec", "#3d9a4b"))
    if report.pending:
        flow.box("Not yet fitted (by design, not an error)", list(report.pending), (GREY_BOX, GREY_EDGE))
    if report.moduli:
        flow.heading("Material moduli", level=2)
        flow.paragraph(
            "E = E_e / A, E = E_b / I and G = E_t / J of the tube section (diameters of the study, "
            "taken as exact).",
            size=8,
            color="#5f6368",
        )
        flow.table(report.moduli, size=6.5)


def _section(flow: Flow, section: Section, images: Images) -> None:
    flow.new_page()
    flow.heading(f"{section.title} ({section.parameters})", level=1)
    for block in section.blocks:
        _block(flow, section, block, images)


def _block(flow: Flow, section: Section, block: Block, images: Images) -> None:
    if block.plot:
        flow.need(0.45 + FIT_HEIGHT)  # keep the specimen's heading with its fit plot
    flow.heading(f"{section.title}, specimen {block.specimen}", level=2)
    for status, line in block.messages:
        colours = (AMBER, AMBER_EDGE) if status == "failed" else (GREY_BOX, GREY_EDGE)
        flow.lines(
            wrap(line, flow.width - 0.3, 8.5, mono=False, bold=True),
            size=8.5,
            mono=False,
            box=colours,
            weight="bold",
        )
        flow.space(0.1)
    if block.plot:
        image = images.plots[block.anchor]
        flow.image(image.png, max_height=FIT_HEIGHT)
        flow.paragraph(image.caption, size=7.5, color="#5f6368")
        flow.space(0.08)
    if block.parameters and block.parameters.rows:
        flow.heading("Parameters", level=3)
        flow.table(block.parameters)
    if block.warnings:
        items = [f"[{n}] {w}" for n, w in enumerate(block.warnings, 1)]
        flow.box("Warnings of this fit", items, (AMBER, AMBER_EDGE))
    for note in block.fe_notes:
        flow.paragraph(note, size=7.5, color="#5f6368")
        flow.space(0.08)
    if block.correlation:
        flow.heading("Correlation of the estimates", level=3)
        flow.table(block.correlation)
    for image in images.drawings.get(block.anchor, []):
        _drawing(flow, image)
    if block.info:
        _info(flow, block.info)
    for extra in block.extras:
        flow.heading(extra.title, level=3)
        if extra.png:
            flow.image(extra.png)
        else:
            flow.box(f"Figure could not be drawn: {extra.title}", [str(extra.error)], (AMBER, AMBER_EDGE))
    if block.tests:
        flow.heading("Tests", level=3)
        for test in block.tests:
            _test(flow, test)


def _drawing(flow: Flow, image: Image) -> None:
    """A rendered drawing under its title, its caption below."""
    if not image.png:
        flow.box(f"Figure could not be drawn: {image.title}", [image.error], (AMBER, AMBER_EDGE))
        return
    caption_lines = wrap(image.caption, flow.width, 7.5, mono=False)
    around = 0.3 + len(caption_lines) * 7.5 * 1.35 / 72  # title and caption, kept with the plot
    height = min(flow.width * image.height / image.width, 5.0)
    if around + height > flow.room() >= around + SQUEEZE * height:
        height = flow.room() - around  # a little smaller rather than a new page for want of a few lines
    flow.need(around + height)
    flow.heading(image.title, level=3)
    flow.image(image.png, max_height=height)
    flow.lines(caption_lines, size=7.5, mono=False, color="#5f6368")
    flow.space(0.08)


def _info(flow: Flow, info) -> None:
    """The fit's details: quantities in a two-column table, nested values as small tables after it."""
    flow.heading("Fit window and details", level=3)
    plain = tuple((label, value) for label, value in info if not isinstance(value, Nested))
    if plain:
        flow.table(Table(("item", "value"), plain, (False, False)))
    for label, value in info:
        if isinstance(value, Nested):
            flow.need(0.6)
            flow.paragraph(label, size=7.5, weight="bold")
            numeric = (False, *(True,) * (len(value.header) - 1))
            flow.table(Table(value.header, value.rows, numeric), size=6.5)


def _test(flow: Flow, test: TestView) -> None:
    rows = f", {test.n_rows} rows" if test.n_rows is not None else ""
    head = f"{test.file}  (sha256 {test.sha_short}{rows})"
    if test.exclude:
        head += "  EXCLUDED: exclude = true, left out of the fit"
    details = []
    if test.setup:
        details.append(f"Set-up: {test.setup}")
    if test.note:
        details.append(f"Note: {test.note}")
    if test.units:
        details.append("Units as written: " + ", ".join(f"{c} [{u}]" for c, u in test.units))
    details += [f"{k}: {v}" for k, v in test.metadata]
    head_lines = wrap(head, flow.width, 8, mono=True, bold=True)
    lines = [line for text in details for line in wrap(text, flow.width - 0.2, 7.5, mono=False)]
    flow.need(min(len(head_lines) * 8 + len(lines) * 7.5, 400) * 1.35 / 72)  # keep a test together
    flow.lines(head_lines, size=8, mono=True, weight="bold")
    flow.lines(lines, size=7.5, mono=False, indent=0.2)
    flow.space(0.08)


def _provenance(flow: Flow, report: Report) -> None:
    flow.new_page()
    flow.heading("Provenance", level=1)
    flow.paragraph("Every input file with its full SHA-256 checksum.", size=8.5)
    rows = tuple((name, n, sha) for name, n, sha, _ in report.provenance.rows)
    if rows:
        flow.table(Table(("file", "rows", "sha256"), rows, (False, True, False)), size=6.5)
        for name, _, _, path in report.provenance.rows:
            flow.paragraph(f"{name}: {path}", size=6.5, mono=True, color="#5f6368")
    else:
        flow.paragraph("No input files were read.", size=8.5)
