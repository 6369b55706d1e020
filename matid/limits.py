"""Every bound matid puts on an input, in one place (docs/limits.md; docs/contract.md section 11).

An input past a bound is refused with a DataError (exit 2) whose message names the
file, the key or row, and the bound; free text past :data:`MAX_TEXT` is the one
exception: it is kept, cut and marked. The bounds are far beyond any bench test and
close enough that no input can take the machine's memory or minutes of its time
before it is refused: sizes and row counts are checked before anything is parsed.

docs/limits.md lists these with the bounds other modules own (scene files and elements,
unit text, preamble lines).
"""

from __future__ import annotations

#: Largest study.toml read, in bytes (a scene file has the same bound, in matid.rod.scenes).
MAX_TOML_BYTES = 1 << 20
#: Deepest nesting in a study or scene TOML: the level of its deepest value (a top-level key is level 1;
#: ``[[test]]`` with ``window = { force = [..] }`` reaches 5). Python's TOML parser recurses per level.
MAX_TOML_DEPTH = 16
#: Longest string value of a TOML key that is not free text (file names, ids, quantities, units).
MAX_VALUE_CHARS = 4096
#: Longest free text kept (a study's name and temperature, a test's note, a file's metadata); cut beyond.
MAX_TEXT = 2000
#: Most ``[[specimen]]``, ``[[test]]`` or ``[[fixed]]`` entries of one study, each.
MAX_ENTRIES = 1000
#: Characters of an input value quoted in a message; a longer value is elided (the message stays one line).
SHOWN_CHARS = 80
#: Largest data file read, in bytes (``/dev/zero`` never ends; a bench record is megabytes).
MAX_CSV_BYTES = 100 * 2**20
#: Most lines of a data file (header and preamble included): the longest records of contract section 10.
MAX_CSV_ROWS = 10_000_000
