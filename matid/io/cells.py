"""Text from inputs written into CSV and XLSX cells as text, never as a formula (contract section 11).

A spreadsheet reads a cell that starts with ``=``, ``+``, ``-`` or ``@`` (and, in
some, a tab or carriage return before them) as a formula: a specimen id
``=HYPERLINK(...)`` or ``=cmd|' /C calc'!A0`` would run when the table is opened.
Following OWASP's guidance on CSV injection, such a text cell is prefixed with a
single quote ``'``, which every spreadsheet shows as the start of text. Numbers
are never passed through here: a negative number stays a number.

Control characters (C0 but tab and newline; DEL; C1) are shown escaped
(``\\x1b``), so that no cell carries an escape code to a terminal and openpyxl
never refuses a cell (it refuses most of C0). A carriage return is one of them
(a CRLF becomes a newline first): Python's csv module quotes a field holding a
newline but not one holding a lone CR, which a spreadsheet reads as the end of
the row, so ``"x\\r=1+1"`` would start a row with a formula.
"""

from __future__ import annotations

from matid.toml import escaped

#: First characters that make a spreadsheet read a cell as a formula (OWASP, CSV injection).
FORMULA_LEADS = ("=", "+", "-", "@", "\t", "\r")


def text_cell(value: object) -> str:
    """A text cell's content: control characters escaped, a formula-leading text prefixed with ``'``."""
    text = escaped(str(value))
    return "'" + text if text.startswith(FORMULA_LEADS) else text


def cell(value: object) -> object:
    """A cell's value for a table: numbers (not booleans) and None as they are, anything else as text."""
    if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)):
        return value
    return text_cell(value)
