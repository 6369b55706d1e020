"""Text from inputs written into CSV and XLSX cells as text, never as a formula (contract section 11).

A spreadsheet reads a cell that starts with ``=``, ``+``, ``-`` or ``@`` (and, in
some, a tab or carriage return before them) as a formula: a specimen id
``=HYPERLINK(...)`` or ``=cmd|' /C calc'!A0`` would run when the table is opened.
Following OWASP's guidance on CSV injection, such a text cell is prefixed with a
single quote ``'``, which every spreadsheet shows as the start of text. Numbers
are never passed through here: a negative number stays a number.

Control characters (C0 but tab and newline; DEL; C1) are shown escaped
(``\\x1b``), so that no cell carries an escape code to a terminal and openpyxl
never refuses a cell (it refuses most of C0). Bidirectional controls (U+202E
and kin) are shown escaped too: they would reorder what follows them. A carriage return is one of them
(a CRLF becomes a newline first): Python's csv module quotes a field holding a
newline but not one holding a lone CR, which a spreadsheet reads as the end of
the row, so ``"x\\r=1+1"`` would start a row with a formula.
"""

from __future__ import annotations

import re

#: First characters that make a spreadsheet read a cell as a formula (OWASP, CSV injection).
FORMULA_LEADS = ("=", "+", "-", "@", "\t", "\r")
#: Control characters (C0 but tab and newline; DEL; C1) and the bidirectional controls (U+061C,
#: U+200E-F, U+202A-E, U+2066-9), which reorder the rest of a terminal line or a cell ("Trojan source").
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def _code(char: str) -> str:
    point = ord(char)
    return f"\\x{point:02x}" if point < 0x100 else f"\\u{point:04x}"


def escaped(text: str) -> str:
    """``text`` with every control character but tab and newline written as ``\\xNN``, and every
    bidirectional control as ``\\uNNNN`` (CRLF: newline)."""
    return _CONTROL.sub(lambda m: _code(m.group()), text.replace("\r\n", "\n"))


def text_cell(value: object) -> str:
    """A text cell's content: control characters escaped, a formula-leading text prefixed with ``'``."""
    text = escaped(str(value))
    return "'" + text if text.startswith(FORMULA_LEADS) else text


def cell(value: object) -> object:
    """A cell's value for a table: numbers (not booleans) and None as they are, anything else as text."""
    if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)):
        return value
    return text_cell(value)
