"""Make the README's pictures from this version's demo: ``python docs/make_images.py``.

Runs ``matid demo`` into a temporary folder and renders, with poppler's ``pdftoppm``,
page 1 of report.pdf to docs/report.png and the first page of the three-point-bend
section to docs/report_bend.png (found by its outline entry, read with pypdf).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

from pypdf import PdfReader

DOCS = Path(__file__).resolve().parent


def outline_page(pdf: Path, title_start: str) -> int:
    """1-based page of the first outline entry whose title starts with ``title_start``."""
    reader = PdfReader(pdf)
    stack = list(reader.outline)
    while stack:
        item = stack.pop(0)
        if isinstance(item, list):
            stack[:0] = item
        elif item.title.lower().startswith(title_start.lower()):
            return reader.get_destination_page_number(item) + 1
    raise SystemExit(f"{pdf}: no outline entry starting {title_start!r}")


def render(pdf: Path, page: int, out: Path, dpi: int = 70) -> None:
    stem = out.with_suffix("")
    subprocess.run(["pdftoppm", "-r", str(dpi), "-png", "-singlefile", "-f", str(page), "-l", str(page),
                    str(pdf), str(stem)], check=True)  # fmt: skip


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "demo"
        subprocess.run([sys.executable, "-m", "matid", "demo", "--out", str(out), "--quiet"], check=True)
        pdf = out / "report.pdf"
        render(pdf, 1, DOCS / "report.png")
        render(pdf, outline_page(pdf, "Three-point"), DOCS / "report_bend.png")
    print(f"wrote {DOCS / 'report.png'} and {DOCS / 'report_bend.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
