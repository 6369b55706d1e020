"""A heading taller than the space left on a page (a study name of thousands of characters)."""

from __future__ import annotations

import io

from pypdf import PdfReader
from reportlab.lib.pagesizes import A4
from reportlab.platypus import SimpleDocTemplate

from matid.report.pdfparts import Heading, para, register_fonts


def test_a_heading_too_tall_for_the_page_splits_and_keeps_its_outline_entry():
    # the fuzzer's case: a 3000-character unbroken study name used to end in
    # TypeError: Heading.__init__() got an unexpected keyword argument 'bulletText'
    register_fonts()
    title = "x" * 3000
    out = io.BytesIO()
    story = [para("before " * 400), Heading(title, 18, key="study", level=0), para("after")]
    SimpleDocTemplate(out, pagesize=A4).build(story)
    reader = PdfReader(io.BytesIO(out.getvalue()))
    assert [item.title for item in reader.outline] == [title]
    text = "".join(page.extract_text() for page in reader.pages).replace("\n", "")
    assert text.count("x") >= 3000 and "after" in text
