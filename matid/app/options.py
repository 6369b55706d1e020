"""Options and argument types shared by the ``matid`` subcommands.

Standard library only: building the parser must not load the numerical stack.
"""

from __future__ import annotations

import argparse

#: The ``--units`` choices as shown in the help; :func:`_unit_system` checks a given name against
#: :data:`matid.units.UNIT_SYSTEMS` itself (tests/app/test_cli.py holds the two equal).
UNITS_METAVAR = "{SI,cgs}"


def add_command(subparsers, name: str, command, **kwargs) -> argparse.ArgumentParser:
    """The subparser ``name`` (``kwargs``: help, description), run by ``command(args)``, with the
    options every command takes."""
    parser = subparsers.add_parser(name, **kwargs)
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    parser.set_defaults(command=command)
    return parser


def _unit_system(name: str) -> str:
    """``--units NAME``: one of :data:`matid.units.UNIT_SYSTEMS`, read (and pint loaded) only when given."""
    if name == "SI":  # the default, which argparse passes through here too
        return name
    from matid.units import UNIT_SYSTEMS

    if name not in UNIT_SYSTEMS:
        choices = ", ".join(repr(n) for n in sorted(UNIT_SYSTEMS))
        raise argparse.ArgumentTypeError(f"invalid choice: {name!r} (choose from {choices})")
    return name


def add_units_and_strict(parser: argparse.ArgumentParser) -> None:
    """``--units`` and ``--strict`` of the commands that fit."""
    # No ``choices``: argparse iterates them while the parser is built, which would load pint
    # for every command; a ``type`` is called only for a --units that is given.
    parser.add_argument(
        "--units",
        type=_unit_system,
        metavar=UNITS_METAVAR,
        default="SI",
        help="unit system of the reported stiffnesses (default SI: N, N m^2, N s; cgs: dyn, dyn cm^2, dyn s)",
    )
    parser.add_argument(
        "--strict",
        action="store_true",
        help="exit 1 when there is any warning or a value whose status is not ok, e.g. not identifiable "
        "(docs/contract.md sections 5 and 7)",
    )


# The names of these two types appear in argparse's message for a value they cannot read.
def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _fraction(text: str) -> float:
    value = float(text)
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"must be in (0, 1), got {value}")
    return value
