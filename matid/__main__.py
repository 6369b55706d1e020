"""``python -m matid``: the same as the ``matid`` command."""

import sys

from matid.cli import main

if __name__ == "__main__":
    sys.exit(main())
