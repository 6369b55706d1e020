"""Numbers with units for people: the labels and units of a fit's ``info`` items.

A fitter leaves its figures in ``TestFit.info`` under keys such as ``"noise_N"`` or
``"per_length_slopes"`` (SI values). The report shows each as a labelled quantity in the
chosen unit system: a key in :data:`INFO_KEYS` has a written label and a quantity kind; any
other key is read by its suffix (``_N``, ``_s``, ``_m``, ``_mm``, ``_Nm``, ``_Nm2``,
``_Ns``, ``_rad_per_m``, ``_pct``), or by its name when it is a parameter (``E_s``,
``E_b_torsion``, ...), and shown with its words as written otherwise. Nested values become
small tables: a mapping of mappings (or a list of mappings) one row per entry, a mapping of
numbers two columns. Nothing is printed as a dict dump.

Display units: lengths in mm (both systems, as on the test bench), forces in N or dyn,
stiffnesses in N m^2 or dyn cm^2, torques in N m or dyn cm, curvatures in 1/m or 1/cm,
moduli in MPa or dyn/cm^2, times in s.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from matid.model.study import PARAMETER_KINDS

#: kind -> unit system -> (unit label, factor from SI).
DISPLAY: dict[str, dict[str, tuple[str, float]]] = {
    "force": {"SI": ("N", 1.0), "cgs": ("dyn", 1e5)},
    "bending_stiffness": {"SI": ("N m^2", 1.0), "cgs": ("dyn cm^2", 1e9)},
    "torque": {"SI": ("N m", 1.0), "cgs": ("dyn cm", 1e7)},
    "viscosity": {"SI": ("N s", 1.0), "cgs": ("dyn s", 1e5)},
    "length": {"SI": ("mm", 1e3), "cgs": ("mm", 1e3)},
    "curvature": {"SI": ("rad/m", 1.0), "cgs": ("rad/cm", 1e-2)},
    "modulus": {"SI": ("MPa", 1e-6), "cgs": ("dyn/cm^2", 10.0)},
    "time": {"SI": ("s", 1.0), "cgs": ("s", 1.0)},
    "compliance": {"SI": ("mm/N", 1e3), "cgs": ("cm/dyn", 1e-3)},
    "percent": {"SI": ("%", 100.0), "cgs": ("%", 100.0)},
    "1": {"SI": ("", 1.0), "cgs": ("", 1.0)},
    "count": {"SI": ("", 1.0), "cgs": ("", 1.0)},
}


#: What follows a number whose quantity the fit did not name (an unregistered info key).
UNSTATED = "(unit not stated by the fit)"


@dataclass(frozen=True)
class Key:
    """How to show one info key: its label, the kind of its values and of its sub-keys."""

    label: str
    kind: str | None = None  # None: read the values as they are
    row_kind: str | None = None  # kind of the keys of a mapping value (e.g. free length)
    row_label: str = "entry"


#: Info keys of the fitters, labelled for people.
INFO_KEYS: dict[str, Key] = {
    "tau_s": Key("relaxation time τ = sls_eta / sls_k2", "time"),
    "time_window_s": Key("time range of the data (sampling step, longest run)", "time"),
    "reduced_chi2": Key("reduced χ² (residuals against the measurement noise)", "1"),
    "noise_N": Key("residual noise σ", "force", row_label="run"),
    "n_runs": Key("runs fitted", "count"),
    "free_lengths_m": Key("free lengths", "length"),
    "r2": Key("R² of the straight line", "1"),
    "per_length_slopes": Key("E_b of each free length alone", None, "length", "free length"),
    "linear_range": Key("end of the linear range", "x", row_label="run"),
    "excluded_points": Key("points left out of the fit", "count"),
    "spans_mm": Key("spans", "length"),
    "shear_share": Key("share of the deflection from shear", "percent"),
    "E_b_used": Key("E_b held in the E_s fit", "bending_stiffness"),
    "E_e_used": Key("E_e held in the E_s fit", "force"),
    "timoshenko_start_N": Key("E_s start value (Timoshenko formula)", "force"),
    "force_change_for_10pct_E_s_N (linearised)": Key("RMS force change for E_s + 10 % (linearised)", "force"),
    "sensitivity_to_noise": Key("RMS force change for E_s + 10 % / noise", "1"),
    "unloading_rows_excluded": Key("unloading rows left out", "count"),
    "fit_window": Key("fit window", "x"),
    "levels": Key("mesh levels tried", None, row_label="level"),
    "noise": Key("point-to-point noise of each record", "y", row_label="record"),
    "tare_offset": Key("tare offset held at", "y", row_label="record"),
    "tare_offset_estimated": Key("tare offset estimated", "y", row_label="record"),
    "tare_offset_p": Key("p-value of the tare offsets (small: an offset is present)", "1"),
    "fitted_x_range": Key("fitted range of x, from and to", "x", row_label="record"),
    "n_effective": Key("effective number of independent points", "count"),
    "interval_widening": Key("interval widening factor for correlated residuals", "1"),
    "residual_lag1_used": Key("lag-1 autocorrelation of the residuals used for the interval", "1"),
    "sign_flipped": Key("records whose sign was flipped", None),
    "left_out": Key("points left out, by reason", "count", row_label="record, points"),
    "rows_left_out": Key("rows left out, by reason", "count", row_label="record, rows"),
    "left_out_rows": Key("rows left out (first, last of each stretch)", "count", row_label="record, rows"),
    "left_out_tests": Key("tests left out", None, row_label="test"),
    "per_span": Key("E_s of each span alone", None, row_label="span"),
    "toe_offset_m": Key("toe offset", "length", row_label="record"),
    "reference_kGA_N": Key("shear stiffness k G A from E_s_torsion, 95 % range", "force"),
    "reference_source": Key("reference", None),
    "reference_shear_share": Key("share of the deflection from shear with that k G A", "percent"),
    "local_compliance_m_per_N": Key("local contact compliance predicted, range", "compliance"),
    "nose_bias_ratio": Key("ratio of E_s from nose travel to its true value, range", "1"),
    "rows": Key("rows", "count"),
    "knots": Key("knots", "count"),
    "relative_compliance": Key("contact compliance relative to the beam compliance", "1"),
    "var_log": Key("variance of ln E_s from the model form (added to the fit's)", "1"),
    "rho": Key("lag-1 autocorrelation of the residuals", "1"),
    "n_eff": Key("effective number of independent points", "count"),
    "interval_inflation": Key("interval widening factor", "1"),
    "assessment": Key("assessment of the nose-travel measurement", None),
    "model_form": Key("model-form uncertainty", None),
    "residual_correlation": Key("correlation of the residuals", None),
    "experiment_design": Key("experiment that would determine E_s", None),
    "torsion_check": Key("comparison with torsion", None),
    "measurement": Key("deflection measured as", None),
}

#: Key suffix -> (kind, factor to SI), the fitters' convention: SI values but for _mm, _pct, _MPa.
SUFFIXES: tuple[tuple[str, str, float], ...] = (
    ("_m_per_N", "compliance", 1.0),
    ("_rad_per_m", "curvature", 1.0),
    ("_Nm2", "bending_stiffness", 1.0),
    ("_N_m2", "bending_stiffness", 1.0),
    ("_Nm", "torque", 1.0),
    ("_N_m", "torque", 1.0),
    ("_Ns", "viscosity", 1.0),
    ("_N", "force", 1.0),
    ("_mm", "length", 1e-3),
    ("_m", "length", 1.0),
    ("_s", "time", 1.0),
    ("_pct", "percent", 0.01),
    ("_MPa", "modulus", 1e6),
    ("_Pa", "modulus", 1.0),
)
#: Parameters whose names carry a suffix that is not a unit (E_s_torsion is a force).
PARAMETER = re.compile(r"^(E_[betse]|sls_k[12]|sls_eta)(?:_[A-Za-z0-9]+)*$")


@dataclass(frozen=True)
class Nested:
    """A nested info value as a small table."""

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


Cell = str | Nested


def fmt(x: float | None, digits: int = 4) -> str:
    """A number to ``digits`` significant figures, never ``1e+02`` for a plain hundred."""
    if x is None or not np.isfinite(x):
        return "—"
    text = f"{x:.{digits}g}"
    if "e" in text:
        mantissa, exponent = text.split("e")
        if -3 <= int(exponent) < 6:
            return f"{float(text):.{max(digits - 1 - int(exponent), 0)}f}"
        return f"{mantissa}e{int(exponent)}"
    return text


def kind_of(key: str) -> tuple[str, str | None, float]:
    """(label, kind, factor to SI) of an unknown key, read from its name."""
    text = str(key).strip()
    words = text.split(" ", 1)
    stem, rest = words[0], (" " + words[1] if len(words) > 1 else "")
    if PARAMETER.match(stem) and stem in PARAMETER_KINDS:
        return text, PARAMETER_KINDS[stem], 1.0
    for suffix, kind, factor in SUFFIXES:
        if stem.endswith(suffix) and len(stem) > len(suffix):
            return words_of(stem[: -len(suffix)]) + rest, kind, factor
    if PARAMETER.match(stem):
        base = PARAMETER.match(stem).group(1)
        return text, PARAMETER_KINDS.get(base), 1.0  # a parameter keeps its name (E_s_torsion)
    return words_of(text), None, 1.0


def words_of(name: str) -> str:
    """``"force_change_for_10pct"`` -> ``"force change for 10 %"``; parameter names stay whole."""
    parts = re.split(r"(E_[betse]|sls_k[12]|sls_eta)", str(name))
    out = [
        p if PARAMETER.fullmatch(p or "-") else re.sub(r"(\d)pct\b", r"\1 %", p.replace("_", " "))
        for p in parts
    ]
    return re.sub(r"\s+", " ", "".join(out)).strip()


def unit_of(kind: str | None, units: str, axes: Mapping[str, tuple[str, float]] | None) -> tuple[str, float]:
    """(unit label, factor from SI) of ``kind``; ``x`` / ``y`` are the fit's axis units."""
    if kind in ("x", "y"):
        return (axes or {}).get(kind, ("", 1.0))
    if kind in DISPLAY:
        return DISPLAY[kind][units]
    return "", 1.0


def quantity(value: object, kind: str | None, units: str, axes=None, *, si: float = 1.0) -> str:
    """A scalar or list of numbers with its unit: ``"30, 45, 60 mm"``; other values as text."""
    unit, factor = unit_of(kind, units, axes)
    factor *= si
    if isinstance(value, np.ndarray):
        value = value.ravel().tolist()
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool):
        return "yes" if value else "no"
    unit = unit if kind is not None else UNSTATED  # a number of unknown kind says so
    if isinstance(value, (int, float)):
        text = str(value) if kind == "count" and isinstance(value, int) else fmt(value * factor)
        return f"{text} {unit}".strip()
    if isinstance(value, (list, tuple)) and value and all(_number(v) for v in value):
        items = [fmt(float(v) * factor) for v in value]
        if len(items) > 8:
            items = [*items[:6], "…", items[-1], f"({len(items)} values)"]
        return f"{', '.join(items)} {unit}".strip()
    if value is None:
        return "—"
    return text_of(value, units)


def _number(v: object) -> bool:
    return isinstance(v, (int, float, np.number)) and not isinstance(v, bool)


def text_of(value: object, units: str = "SI") -> str:
    """Any other value, readably on one line: a mapping as ``rows 30; error 0.2 mN`` (each item
    labelled, with its unit), never braces; mappings in a list apart by " / "."""
    if isinstance(value, Mapping):
        items = [f"{label_of(k)} {quantity(v, info_kind(k), units)}" for k, v in value.items()]
        return "; ".join(items) if items else "none"
    if isinstance(value, (list, tuple)):
        joint = " / " if all(isinstance(v, Mapping) for v in value) else ", "
        return joint.join(text_of(v, units) for v in value) if value else "none"
    if _number(value):
        return fmt(float(value))
    return str(value)


#: A file name (``bending_T1_L30.csv``): shown as written, underscores kept.
FILE_NAME = re.compile(r"^[^\s/]+\.[A-Za-z0-9]{1,5}$")


def label_of(key: object) -> str:
    key = str(key)
    if FILE_NAME.match(key):
        return key
    return INFO_KEYS[key].label if key in INFO_KEYS else kind_of(key)[0]


def info_kind(key: object) -> str | None:
    """The quantity kind of an info key: written in :data:`INFO_KEYS`, else read from its name."""
    key = str(key)
    return INFO_KEYS[key].kind if key in INFO_KEYS else kind_of(key)[1]


def info_cell(key: str, value: object, units: str, axes=None) -> tuple[str, Cell]:
    """(label, cell) of one info item: a quantity with its unit, or a small table."""
    spec = INFO_KEYS.get(key)
    label, kind, si = (spec.label, spec.kind, 1e-3 if key.endswith("_mm") else 1.0) if spec else kind_of(key)
    spec = spec or Key(label)
    if isinstance(value, Mapping) and value:
        return label, _mapping_table(value, spec, kind, units, axes)
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, Mapping) for v in value):
        return label, _records_table(list(value), units, axes, row_label=spec.row_label)
    return label, quantity(value, kind, units, axes, si=si)


def _mapping_table(value: Mapping, spec: Key, kind: str | None, units: str, axes) -> Nested:
    row_kind = spec.row_kind
    head = _headed(spec.row_label, unit_of(row_kind, units, axes)[0])
    keys = [
        quantity(float(k), row_kind, units, axes).split(" ")[0] if row_kind else label_of(k) for k in value
    ]
    if all(isinstance(v, Mapping) for v in value.values()):
        table = _records_table(list(value.values()), units, axes, row_label="", kind=kind)
        return Nested(
            (head, *table.header[1:]), tuple((k, *r[1:]) for k, r in zip(keys, table.rows, strict=True))
        )
    if kind is not None or row_kind:  # one quantity per entry: the unit goes in the header
        unit = unit_of(kind, units, axes)[0]
        values = [_bare(quantity(v, kind, units, axes), unit) for v in value.values()]
        return Nested((head, _headed("value", unit)), tuple(zip(keys, values, strict=True)))
    cells = [
        text_of(v) if isinstance(v, Mapping) else quantity(v, info_kind(k), units, axes)
        for k, v in value.items()
    ]
    return Nested(("item", "value"), tuple(zip(map(label_of, value), cells, strict=True)))


def _bare(text: str, unit: str) -> str:
    return text[: -len(unit)].strip() if unit and text.endswith(unit) else text


def _headed(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit else name


def _records_table(
    records: Sequence[Mapping], units: str, axes, *, row_label: str, kind: str | None = None
) -> Nested:
    """A list of mappings as one table: a column per key, each with its unit in the header
    (``kind``: of the columns whose names do not say theirs)."""
    columns = list(dict.fromkeys(k for r in records for k in r))
    kinds = {c: _column_kind(c, columns) or kind for c in columns}
    unit = {c: unit_of(kinds[c], units, axes)[0] for c in columns}
    header = (row_label, *(_headed(COLUMNS.get(c) or kind_of(c)[0], unit[c]) for c in columns))
    rows = tuple(
        (str(i + 1), *(_bare(quantity(r.get(c), kinds[c], units, axes), unit[c]) for c in columns))
        for i, r in enumerate(records)
    )
    return Nested(header, rows)


#: Column labels of nested tables (other columns are read by their names).
COLUMNS = {
    "discretization_error": "discretisation error (relative)",
    "n_points": "points",
    "elements": "elements",
}
COLUMN_KINDS = {"discretization_error": "1", "n_points": "count", "elements": "count", "runtime_s": "time"}


def _column_kind(column: str, columns: Sequence[str]) -> str | None:
    if column in COLUMN_KINDS:
        return COLUMN_KINDS[column]
    if column == "stderr":  # the standard error of the parameter beside it
        return next((kind_of(c)[1] for c in columns if c != "stderr" and PARAMETER.match(c)), None)
    return kind_of(column)[1]
