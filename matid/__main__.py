"""``python -m matid``: the same as the ``matid`` command."""

from matid.app.cli import run

if __name__ == "__main__":
    run()
