"""Parsing of the section-7 keys of a ``[[test]]``, booleans and free text, for :mod:`matid.io.study`.

``columns``, ``units``, ``negate``, ``window`` and ``encoding`` (docs/contract.md
section 7): each names a data column the test kind uses (its :attr:`~matid.model.kind.Kind.columns`),
checked here with the nearest valid name suggested. Free text is bounded. The data
file of a test lies inside the study's folder unless ``[study] allow_outside = true``
(:func:`data_file`, section 11).
"""

from __future__ import annotations

import codecs
import difflib
from collections.abc import Callable
from pathlib import Path

from matid.errors import DataError
from matid.fits.kinds import BY_NAME
from matid.limits import MAX_TEXT
from matid.toml import shown
from matid.units import UnitError, si_factor

#: Keys of a [[test]] on how its file is read (section 7), parsed here.
READING_KEYS = ("columns", "units", "negate", "window", "encoding")
#: Keys of a [[specimen]] that give a section other than a closed tube (docs/contract.md section 10).
SECTION_KEYS = ("width", "height", "slit")

TRUNCATED = " [... truncated]"


def bounded_text(value: object, limit: int = MAX_TEXT) -> str:
    """Free text cut to ``limit`` characters, marked when cut (a 1 MB note is not a report)."""
    text = str(value)
    return text if len(text) <= limit else text[:limit] + TRUNCATED


def nearest(word: str, valid: tuple[str, ...] | list[str]) -> str:
    """`` (did you mean `x`?)`` for the closest valid word, or ``""``."""
    match = difflib.get_close_matches(word, list(valid), n=1, cutoff=0.5)
    return f" (did you mean `{match[0]}`?)" if match else ""


def boolean(source: Path, where: str, entry: dict, key: str) -> bool:
    value = entry.get(key, False)
    if not isinstance(value, bool):
        raise DataError(
            f"{where}: {key} must be a boolean (true or false, unquoted), got '{shown(value)}'",
            file=source,
        )
    return value


def text(source: Path, where: str, entry: dict, key: str, default: str = "") -> str:
    value = entry.get(key, default)
    if not isinstance(value, str):
        raise DataError(f"{where}: {key} must be a string, got '{shown(value)}'", file=source)
    return bounded_text(value)


def _column_key(source: Path, where: str, key: str, name: object, kind: str) -> str:
    """``name`` checked to be a data column the ``kind`` uses."""
    valid = list(BY_NAME[kind].columns)
    if name not in valid:
        raise DataError(
            f"{where}: {key}: `{shown(name)}` is not a column of {kind} tests "
            f"(one of {', '.join(valid)}){nearest(str(name), valid)}",
            file=source,
        )
    return str(name)


def _table(source: Path, where: str, entry: dict, key: str) -> dict:
    value = entry.get(key, {})
    if not isinstance(value, dict):
        raise DataError(f"{where}: {key} must be a table like {{ force = ... }}", file=source)
    return value


def window(
    source: Path, where: str, entry: dict, kind: str, value: Callable[..., float]
) -> dict[str, tuple[float, float]]:
    window = {}
    for name, bounds in _table(source, where, entry, "window").items():
        column = _column_key(source, where, "window", name, kind)
        if not isinstance(bounds, list) or len(bounds) != 2:
            got = shown(bounds)
            raise DataError(f'{where}: window.{column} must be ["low", "high"], got {got}', file=source)
        q = BY_NAME[kind].columns[column]
        low, high = (value(source, where, f"window.{column}", b, q) for b in bounds)
        if not low < high:
            raise DataError(f"{where}: window.{column} needs low < high, got {shown(bounds)}", file=source)
        window[column] = (low, high)
    return window


def columns(source: Path, where: str, entry: dict, kind: str) -> dict[str, str | int]:
    """matid name -> the file's header text, or its column number (1 = the first column; a file
    without a header row is read with its columns named this way)."""
    columns: dict[str, str | int] = {}
    for name, header in _table(source, where, entry, "columns").items():
        column = _column_key(source, where, "columns", name, kind)
        text = isinstance(header, str) and header.strip() and len(header) <= 200
        number = isinstance(header, int) and not isinstance(header, bool) and header >= 1
        if not (text or number):
            raise DataError(
                f"{where}: columns.{column} must be the file's header text or a column number "
                f"(1 = the first column), got '{shown(header)}'",
                file=source,
            )
        columns[column] = header
    return columns


def units(source: Path, where: str, entry: dict, kind: str) -> dict[str, str]:
    units = {}
    for name, unit in _table(source, where, entry, "units").items():
        column = _column_key(source, where, "units", name, kind)
        if not isinstance(unit, str):
            raise DataError(f"{where}: units.{column} must be a unit string", file=source)
        try:
            si_factor(unit, BY_NAME[kind].columns[column])
        except UnitError as exc:
            raise DataError(f"{where}: units.{column}: {exc}", file=source) from exc
        units[column] = unit
    return units


def negate(source: Path, where: str, entry: dict, kind: str) -> tuple[str, ...]:
    names = entry.get("negate", [])
    if not isinstance(names, list):
        raise DataError(f'{where}: negate must be a list like ["force"]', file=source)
    return tuple(_column_key(source, where, "negate", name, kind) for name in names)


#: Text encodings of Python's that are not the character set of a file (the "Python Specific
#: Encodings" of the codecs documentation, and the stateful UTF-7): ingest finds the byte offset of a
#: row by encoding the text before it again, which these do not give back.
NOT_FILE_ENCODINGS = frozenset(
    {"idna", "punycode", "raw-unicode-escape", "unicode-escape", "undefined", "utf-7"}
)


def encoding(source: Path, where: str, entry: dict) -> str | None:
    """The codec name of ``encoding``: a text encoding Python knows (bytes <-> str). A bytes-to-bytes
    or str-to-str codec (rot13, hex, base64, bz2, uu, zlib, quopri) cannot read a file as text:
    ``str.encode`` and ``bytes.decode`` accept text encodings only, and say so with a LookupError.
    The codecs of :data:`NOT_FILE_ENCODINGS` are text encodings but not of files."""
    if "encoding" not in entry:
        return None
    name = str(entry["encoding"])
    examples = "e.g. utf-8, cp1252, gbk, utf-16"
    try:
        codec = codecs.lookup(name).name
    except LookupError as exc:
        raise DataError(f"{where}: unknown encoding '{shown(name)}' ({examples})", file=source) from exc
    try:
        "".encode(codec)
        b"".decode(codec)
    except (LookupError, UnicodeError) as exc:  # not a text encoding; "undefined" refuses everything
        raise DataError(
            f"{where}: encoding '{shown(name)}' is not a text encoding ({examples})", file=source
        ) from exc
    if codec in NOT_FILE_ENCODINGS:
        raise DataError(
            f"{where}: encoding '{shown(name)}' is not a text encoding of files ({examples})", file=source
        )
    return codec


def data_file(source: Path, where: str, name: str, outside: bool = False) -> Path:
    """The data file's absolute path, links resolved; inside the study's folder unless ``outside``.

    A symlink loop is an input error, not a crash; a file outside the folder (``../x``,
    an absolute path, a link leading out) is refused unless ``[study] allow_outside = true``
    (docs/contract.md section 11): a study handed over must not read the reader's files.
    """
    try:
        root, path = source.parent.resolve(), (source.parent / name).resolve()
    except (OSError, RuntimeError) as exc:
        message = f"{where}: file '{shown(name)}' cannot be resolved ({shown(exc)})"
        raise DataError(message, file=source) from exc
    if not (outside or path.is_relative_to(root)):
        raise DataError(
            f"{where}: file = '{shown(name)}' is {shown(path, 200)}, outside the study folder "
            f"{shown(root, 200)}; move it in, or set [study] allow_outside = true",
            file=source,
        )
    return path


def section(source: Path, where: str, entry: dict, length: Callable[[str], float]) -> dict[str, object]:
    """The section keys of a [[specimen]] as Specimen arguments: diameters (and ``slit``) or
    ``width`` and ``height``; ``length(key)`` reads one length in SI."""
    rectangle = [k for k in ("width", "height") if k in entry]
    if rectangle:
        clash = [k for k in ("outer_diameter", "inner_diameter", "slit") if k in entry]
        if clash or len(rectangle) < 2:
            why = f"also gives {clash[0]}" if clash else f"gives {rectangle[0]} without the other"
            raise DataError(
                f"{where}: a rectangular section needs both width and height and no diameters; it {why}",
                file=source,
            )
        return {"width": length("width"), "height": length("height")}
    slit = boolean(source, where, entry, "slit")
    if slit and "inner_diameter" not in entry:
        raise DataError(f"{where}: a slit (open) tube needs inner_diameter", file=source)
    inner = length("inner_diameter") if "inner_diameter" in entry else 0.0
    return {"outer_diameter": length("outer_diameter"), "inner_diameter": inner, "slit": slit}
