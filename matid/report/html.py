"""The HTML report: one self-contained file, plots inlined as base64 PNG, no script, no assets.

The page is ``templates/report.html`` rendered by jinja2 with autoescape on, so every piece
of user text (study name, notes, metadata, warnings) is escaped.
"""

from __future__ import annotations

import base64
import functools

import jinja2

from matid.report.content import Report
from matid.report.images import Images, render_images
from matid.report.quantities import Nested
from matid.report.verdict import STATUS_CLASS


def render_html(report: Report, images: Images | None = None) -> bytes:
    """The report page as UTF-8 bytes (figures from ``images``, rendered here if not given)."""
    images = render_images(report) if images is None else images
    page = template("matid.report", "report.html").render(
        report=report,
        plots=images.plots,
        drawings=images.drawings,
        data_uri=data_uri,
        nested=lambda value: isinstance(value, Nested),
        status_class=STATUS_CLASS,
    )
    return page.encode("utf-8")


@functools.cache
def template(package: str, name: str) -> jinja2.Template:
    """The page template ``name`` of ``package``'s templates folder, compiled once per process
    (autoescaped, strict: a missing value is an error, not an empty cell)."""
    env = jinja2.Environment(
        loader=jinja2.PackageLoader(package, "templates"),
        autoescape=True,
        trim_blocks=True,
        lstrip_blocks=True,
        undefined=jinja2.StrictUndefined,
    )
    return env.get_template(name)


def data_uri(png: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")
