"""The exit codes of ``matid`` (docs/contract.md section 5), by name.

The codes of a batch rank as their numbers (the batch exits with the worst, the largest).
"""

from __future__ import annotations

#: Every fit done (with ``--strict``: and no warning).
OK = 0
#: Some fits failed (the rest written), a warning under ``--strict``, or another MatidError.
FAILED = 1
#: The input cannot be used (a DataError; also a usage error).
BAD_INPUT = 2
#: A bug in matid.
BUG = 3
#: The outputs could not be written (disk full, ENOSPC; an I/O error): the previous ones are unchanged.
NOT_WRITTEN = 4
#: Stopped by SIGINT (Ctrl-C) or SIGTERM: 128 + the signal's number, as a shell reports it.
INTERRUPTED, TERMINATED = 130, 143
