"""Units: parsed once on the way in, formatted once on the way out.

Everything inside matid is SI. A quantity in study.toml or a scene is a string
``"<number> <unit>"`` or a bare number meaning SI; a CSV column carries its unit
in its header. Both go through :func:`to_si`, which checks the dimension of the
unit against what the field needs (``"length"``, ``"force"``, ...).

Machine spellings (docs/contract.md section 7) are taught to pint itself: ``Nm``
(pint alone reads nano-metre), ``Sec``/``secs`` are defined units, and a pint
preprocessor reads the separators machines put between unit names (``in-lb``,
``N.m``, ``in.lbf``, ``N·m``) as products and drops the trailing dot of
``deg.``. ``lb`` in a force or torque unit (``in-lb``, ``lb``) is the
pound-force, as on every load frame.

Two units need care with pint's default registry: pint's ``G`` is the
Gaussian-CGS gauss (sqrt dimensions, not convertible to tesla), and ``emu`` is
not defined. Lab files mean the magnetic flux density 1 G = 1e-4 T and the
magnetic moment 1 emu = 1e-3 A m^2, so those tokens are rewritten to SI
definitions before pint parses them.
"""

from __future__ import annotations

import math
import re
import sys
from functools import lru_cache

import pint

#: Between two unit names: a hyphen, a dot or a middle dot means a product.
_SEPARATOR = re.compile(r"(?<=[A-Za-z])\s*[-.\u00b7\u22c5]\s*(?=[A-Za-z])")
_TRAILING_DOT = re.compile(r"(?<=[A-Za-z])\.$")


def _machine_separators(text: str) -> str:
    """pint preprocessor: ``in-lb``, ``N.m``, ``N·m`` -> products; ``deg.`` -> ``deg``."""
    return _SEPARATOR.sub("*", _TRAILING_DOT.sub("", text.strip()))


def _registry() -> pint.UnitRegistry:
    """pint's registry, its parsed definitions cached in the user's cache folder (0.12 s -> 0.02 s
    per process, measured); without a usable cache (read-only home, a damaged or half-written
    cache file) it is built from the definitions as before."""
    try:
        return pint.UnitRegistry(preprocessors=[_machine_separators], cache_folder=":auto:")
    except Exception:  # noqa: BLE001 - a cache is an optimisation: any failure of it means no cache
        return pint.UnitRegistry(preprocessors=[_machine_separators])


ureg = _registry()
ureg.define("Nm = newton * meter")
ureg.define("Sec = second = _ = Secs")
ureg.define("lab_gauss = 1e-4 * tesla")
ureg.define("lab_emu = 1e-3 * ampere * meter ** 2")

#: Per physical kind of field: its pint dimensionality and the SI unit it is reported in.
#: Angles and strains are dimensionless in pint; they are told apart by the unit names allowed.
_KINDS: dict[str, tuple[str, str]] = {
    "length": ("[length]", "m"),
    "force": ("[force]", "N"),
    "torque": ("[force] * [length]", "N m"),
    "time": ("[time]", "s"),
    "field": ("[mass] / [time] ** 2 / [current]", "T"),
    "moment": ("[current] * [length] ** 2", "A m^2"),
    "moment_per_length": ("[current] * [length]", "A"),
    "bending_stiffness": ("[force] * [length] ** 2", "N m^2"),
    "viscosity": ("[force] * [time]", "N s"),
    "force_per_length": ("[force] / [length]", "N/m"),
    "curvature": ("1 / [length]", "1/m"),
    "angle": ("", "rad"),
    "strain": ("", "1"),
    "dimensionless": ("", "1"),
}
DIMENSIONS = {kind: dimension for kind, (dimension, _) in _KINDS.items()}
SI_UNITS = {kind: unit for kind, (_, unit) in _KINDS.items()}

_STRAIN_UNITS = {"1", "-", "%", "percent", "mm/mm", "m/m", "", "ratio"}
_POUND = re.compile(r"lb|pound", re.IGNORECASE)
#: Longest unit text read: a longer one is not a unit (and pint's parser is not fed it).
MAX_UNIT_CHARS = 64

#: Largest magnitude (SI) a value of each kind can have on a catheter bench: a
#: value beyond it is a unit or export mistake, not a measurement.
PHYSICAL_BOUND: dict[str, float] = {
    "length": 10.0,
    "force": 1e6,
    "torque": 1e4,
    "time": 1e9,
    "field": 1e3,
    "moment": 1e3,
    "angle": 1e5,
    "strain": 1e3,
    "bending_stiffness": 1e6,
    "viscosity": 1e12,
}

#: Range (SI) in which a bare number in study.toml is believable for its kind,
#: and the unit to suggest when it is not. A catheter's 60 (m) is not a length.
PLAUSIBLE_BARE: dict[str, tuple[float, float, str]] = {
    "length": (1e-6, 1.0, "mm"),
    "force": (1e-3, 1e6, "N"),
    "bending_stiffness": (1e-10, 1.0, "N mm^2"),
    "viscosity": (1e-3, 1e9, "N s"),
    "moment": (1e-7, 10.0, "A m^2"),
}

_TOKEN_REWRITES = [
    (re.compile(r"(?<![A-Za-z_])(G|Gs|gauss)(?![A-Za-z_])"), "lab_gauss"),
    (re.compile(r"(?<![A-Za-z_])emu(?![A-Za-z_])"), "lab_emu"),
    (re.compile(r"µ|μ"), "u"),
    (re.compile(r"°"), "deg"),
]


class UnitError(ValueError):
    """A unit string pint cannot parse, or of the wrong dimension."""


def _normalise(unit: str) -> str:
    text = unit.strip()
    for pattern, repl in _TOKEN_REWRITES:
        text = pattern.sub(repl, text)
    return text.replace("^", "**")


@lru_cache(maxsize=512)
def si_factor(unit: str, kind: str) -> float:
    """Multiplier taking a value in ``unit`` to SI for a field of ``kind``.

    Raises UnitError naming the unit when it is unknown or of another dimension.
    """
    if kind not in DIMENSIONS:
        raise ValueError(f"unknown quantity kind {kind!r}")
    text = unit.strip()
    if len(text) > MAX_UNIT_CHARS:
        raise UnitError(f"unit text of {len(text)} characters is not a unit (at most {MAX_UNIT_CHARS})")
    if kind == "strain" and text.lower() in _STRAIN_UNITS:
        return 0.01 if text.lower() in {"%", "percent"} else 1.0
    if kind == "dimensionless" and text in {"", "-", "1"}:
        return 1.0
    quantity = _parse(unit, text)
    if kind in ("angle", "strain"):
        return _dimensionless_factor(unit, quantity, kind)
    want = DIMENSIONS[kind]
    if kind in ("force", "torque") and not quantity.check(want) and _POUND.search(text):
        # A load frame's "lb" is the pound-force: in-lb is a torque, lb a force.
        quantity = quantity * ureg.standard_gravity
    if kind == "moment_per_length" and quantity.check("[current]"):
        # docs/contract.md section 6 writes per_length = "0.02 A" for "A m^2 per m":
        # read a bare current unit as that shorthand.
        return float(quantity.to("A").magnitude)
    if want and not quantity.check(want):
        raise UnitError(f"'{unit}' is not a unit of {kind} (expected like {SI_UNITS[kind]})")
    if not want and not quantity.dimensionless:
        raise UnitError(f"'{unit}' is not dimensionless")
    return _finite_factor(unit, float(quantity.to_base_units().magnitude))


def _parse(unit: str, text: str) -> pint.Quantity:
    """pint's reading of a unit text; every failure of its parser is a UnitError.

    pint lets through AssertionError ("-"), ZeroDivisionError ("1/0"), tokenize's
    TokenError ("(N") and more; any exception from parsing untrusted text means
    "not a unit", so all are caught here, at the edge.
    """
    try:
        return ureg.Quantity(1.0, _normalise(text))
    except Exception as exc:  # noqa: BLE001 - see docstring
        raise UnitError(f"unknown unit '{unit}'") from exc


def _dimensionless_factor(unit: str, quantity: pint.Quantity, kind: str) -> float:
    """Angles reduce to radian in pint, strains to a pure number: tell them apart."""
    base = quantity.to_base_units()
    is_angle = str(base.units) == "radian"
    if kind == "angle" and not is_angle:
        raise UnitError(f"'{unit}' is not an angle unit (use rad or deg)")
    if kind == "strain" and (is_angle or not base.dimensionless):
        raise UnitError(f"'{unit}' is not a strain unit (use 1 or %)")
    return _finite_factor(unit, float(base.magnitude))


def _finite_factor(unit: str, factor: float) -> float:
    if not (math.isfinite(factor) and factor > 0):
        raise UnitError(f"'{unit}' does not give a finite positive scale ({factor!r})")
    return factor


def to_si(value: object, kind: str) -> float:
    """Parse ``"<number> <unit>"`` (or a bare number, meaning SI) into SI.

    >>> to_si("30 mm", "length")
    0.03
    """
    if isinstance(value, bool):
        raise UnitError(f"expected a quantity of {kind}, got {value!r}")
    if isinstance(value, int) and abs(value) > sys.float_info.max:
        raise UnitError(f"'{value}' is not a finite number")
    if isinstance(value, (int, float)):
        number = float(value)
    elif isinstance(value, str):
        match = re.fullmatch(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*", value)
        if match is None:
            raise UnitError(f"cannot read a quantity from '{value}' (write e.g. '30 mm')")
        number = float(match.group(1)) * (si_factor(match.group(2), kind) if match.group(2) else 1.0)
    else:
        raise UnitError(f"expected a quantity of {kind}, got {value!r}")
    if not math.isfinite(number):
        raise UnitError(f"'{value}' is not a finite number")
    return number


def vector_to_si(values: object, kind: str) -> tuple[float, float, float]:
    """Parse a list of three quantities (a lab-frame vector) into SI."""
    if not isinstance(values, (list, tuple)) or len(values) != 3:
        raise UnitError(f"expected a list of three quantities of {kind}, got {values!r}")
    return tuple(to_si(v, kind) for v in values)


#: Output unit systems: for each reported kind, (unit label, factor from SI). Every kind of
#: :data:`matid.io.results.PARAMETER_KINDS` has a unit in every system (tests/test_units.py).
UNIT_SYSTEMS: dict[str, dict[str, tuple[str, float]]] = {
    "SI": {
        "force": ("N", 1.0),
        "bending_stiffness": ("N m^2", 1.0),
        "viscosity": ("N s", 1.0),
        "time": ("s", 1.0),
    },
    "cgs": {
        "force": ("dyn", 1e5),
        "bending_stiffness": ("dyn cm^2", 1e9),
        "viscosity": ("dyn s", 1e5),
        "time": ("s", 1.0),
    },
}


def unit_system(name: object) -> str:
    """``name`` if it is an output unit system (:data:`UNIT_SYSTEMS`); a UnitError naming the argument
    ``units`` and the choices otherwise."""
    if not isinstance(name, str) or name not in UNIT_SYSTEMS:
        choices = ", ".join(repr(n) for n in UNIT_SYSTEMS)
        raise UnitError(f"units must be one of {choices}, got {name!r}")
    return name


def from_si(value: float, kind: str, system: str = "SI") -> tuple[float, str]:
    """Convert an SI value of ``kind`` to the output unit ``system``; returns (value, unit)."""
    unit, factor = UNIT_SYSTEMS[unit_system(system)][kind]
    return value * factor, unit
