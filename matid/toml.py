"""Reading a study or scene TOML safely: bounded size, nesting, text and values (contract section 11).

:mod:`tomllib` parses whatever it is given: a document nested 5 000 deep makes it
recurse past Python's limit (RecursionError, an exit 3), a dotted key or table name
of thousands of parts costs it time quadratic in their number (20 000 parts: 14 s;
a 1 MiB file: hours), and an ESC or BEL written as ``\\u001b`` reaches ids, outputs
and the terminal. Here every such document is refused with a DataError (exit 2)
naming the file and the key, its value shown escaped and elided:

1. the file is a regular file of at most :data:`~matid.limits.MAX_TOML_BYTES`
   (for a study; a scene file is read by :mod:`matid.rod.scenes`), UTF-8;
2. before parsing, no dotted key or table name has more than
   :data:`~matid.limits.MAX_TOML_DEPTH` parts (a linear scan of the text);
3. tomllib parses; a RecursionError there is a document nested too deeply;
4. the parsed document is walked (without recursion): nesting at most
   ``MAX_TOML_DEPTH``, no control character (C0 but tab, newline and CR; DEL;
   C1) in any key or string, and no string longer than
   :data:`~matid.limits.MAX_VALUE_CHARS` but under a free-text key.
"""

from __future__ import annotations

import re
import stat
import tomllib
from collections.abc import Collection
from pathlib import Path

from matid.errors import DataError
from matid.limits import MAX_TOML_BYTES, MAX_TOML_DEPTH, MAX_VALUE_CHARS, SHOWN_CHARS

#: Control characters refused in a TOML key or string (tab, newline and CR are text).
CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")
#: Control characters shown escaped in messages and cells (C0 but tab and newline; DEL; C1) and the
#: bidirectional controls (U+061C, U+200E-F, U+202A-E, U+2066-9), which reorder the rest of a
#: terminal line or a cell ("Trojan source").
_SHOWN_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069]")
_KEY = r"""(?:[A-Za-z0-9_-]++|"(?:[^"\\\n]|\\.)*+"|'[^'\n]*+')"""
#: A dotted key or table name of more than MAX_TOML_DEPTH parts, where a key may start.
_DEEP_KEY = re.compile(rf"(?:^|[\[{{,])[ \t]*+(?:{_KEY}[ \t]*+\.[ \t]*+){{{MAX_TOML_DEPTH}}}", re.M)


def _code(char: str) -> str:
    point = ord(char)
    return f"\\x{point:02x}" if point < 0x100 else f"\\u{point:04x}"


def escaped(text: str) -> str:
    """``text`` with every control character but tab and newline written as ``\\xNN``, and every
    bidirectional control as ``\\uNNNN`` (CRLF: newline)."""
    return _SHOWN_CONTROL.sub(lambda m: _code(m.group()), text.replace("\r\n", "\n"))


def shown(value: object, limit: int = SHOWN_CHARS) -> str:
    """``value`` for a one-line message: control characters and newlines escaped, elided past ``limit``."""
    text = escaped(str(value)).replace("\n", "\\n").replace("\t", "\\t")
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def load_toml(path: Path, what: str = "study file", free_text: Collection[str] = ()) -> dict:
    """The checked document of the TOML file ``path`` (see the module docstring); DataError otherwise."""
    try:
        info = path.stat()
        if not stat.S_ISREG(info.st_mode):
            raise DataError(f"the {what} is not a regular file", file=path)
        if info.st_size > MAX_TOML_BYTES:
            raise DataError(f"the {what} is {info.st_size} bytes, more than MAX_TOML_BYTES = "
                            f"{MAX_TOML_BYTES}", file=path)  # fmt: skip
        with path.open("rb") as handle:
            data = handle.read(MAX_TOML_BYTES + 1)
    except OSError as exc:
        raise DataError(f"cannot read the {what}: {exc.strerror}", file=path) from exc
    if len(data) > MAX_TOML_BYTES:
        raise DataError(f"the {what} grew past MAX_TOML_BYTES = {MAX_TOML_BYTES} while read", file=path)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(f"not valid TOML: not UTF-8 ({exc.reason} at byte {exc.start})", file=path) from exc
    return parse_toml(text, path, free_text)


def parse_toml(text: str, path: Path, free_text: Collection[str] = ()) -> dict:
    """``text`` parsed by tomllib and checked (steps 2-4 of the module docstring)."""
    deep = _DEEP_KEY.search(text)
    if deep:
        line = text.count("\n", 0, deep.start()) + 1
        raise DataError(
            f"line {line}: a dotted key or table name of more than MAX_TOML_DEPTH = {MAX_TOML_DEPTH} parts",
            file=path,
        )
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DataError(f"not valid TOML: {shown(exc, 200)}", file=path) from exc
    except RecursionError:
        raise DataError(f"arrays or tables nested deeper than MAX_TOML_DEPTH = {MAX_TOML_DEPTH}",
                        file=path) from None  # fmt: skip
    check_document(doc, path, frozenset(free_text))
    return doc


def check_document(doc: dict, path: Path, free_text: frozenset[str]) -> None:
    """Nesting, control characters and value lengths of a parsed document, walked with a stack."""
    stack: list[tuple[tuple, object]] = [((), doc)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, (dict, list)):
            if len(where) >= MAX_TOML_DEPTH and value:
                raise DataError(f"{key_path(where)}: nested deeper than MAX_TOML_DEPTH = {MAX_TOML_DEPTH}",
                                file=path)  # fmt: skip
            items = list(value.items() if isinstance(value, dict) else enumerate(value))
            for key, item in reversed(items):  # popped in document order: the first problem is named
                if isinstance(key, str):
                    _check_text(key, (*where, key), path, "key", MAX_VALUE_CHARS)
                stack.append(((*where, key), item))
        elif isinstance(value, str):
            free = bool(where) and where[-1] in free_text
            _check_text(value, where, path, "value", None if free else MAX_VALUE_CHARS)


def _check_text(text: str, where: tuple, path: Path, what: str, limit: int | None) -> None:
    bad = CONTROL.search(text)
    if bad:
        raise DataError(
            f"{key_path(where)}: control character U+{ord(bad.group()):04X} in the {what} '{shown(text)}'; "
            "matid does not take control characters from a TOML file",
            file=path,
        )
    if limit is not None and len(text) > limit:
        raise DataError(
            f"{key_path(where)}: a {what} of {len(text)} characters, more than MAX_VALUE_CHARS = {limit}: "
            f"'{shown(text)}'",
            file=path,
        )


def key_path(where: tuple) -> str:
    """Where a value sits, as the study's messages say it: ``[[test]] #2: columns.force``, ``x[0][1]``."""
    if not where:
        return "the document"
    head, rest = shown(where[0]), list(where[1:])
    if len(rest) > 1 and isinstance(rest[0], int) and isinstance(rest[1], str):  # in an array of tables
        label, rest = f"[[{head}]] #{rest[0] + 1}", rest[1:]
    elif rest and isinstance(rest[0], str):
        label = f"[{head}]"
    else:
        return head + "".join(f"[{k}]" if isinstance(k, int) else f".{shown(k)}" for k in rest)
    tail = "".join(f"[{k}]" if isinstance(k, int) else f".{shown(k)}" for k in rest).lstrip(".")
    return f"{label}: {tail}" if tail else label
