"""Families of scenes (contract section 13): ``[[sweep]]`` entries and the states they make.

One place reads a sweep: :func:`parse_sweep` (the scene file's ``[[sweep]]`` array, or the
mapping of :func:`matid.rod.sweep`), :data:`KEYS` says which dotted keys may be swept and their
unit kind, :func:`with_value` sets one on a :class:`~matid.rod.scenes.Scene` (its checks run
again), :func:`states` makes every combination (last entry fastest) and :func:`rows` the table of
their solutions. pandas is imported only by :func:`sweep` (``matid solve`` of a scene without a
sweep never loads it).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, replace

from matid.errors import DataError
from matid.rod import schema
from matid.rod.scene_values import read_small_file
from matid.rod.scenes import Scene, scene_from_dict
from matid.toml import parse_toml
from matid.units import SI_UNITS, UnitError, to_si, vector_to_si

#: Sweepable keys: (unit kind, vector?). Indexed tables: ``magnet.1.moment`` (1-based).
KEYS = {
    "rod.length": ("length", False),
    "rod.E_b": ("bending_stiffness", False),
    "rod.E_t": ("bending_stiffness", False),
    "rod.E_s": ("force", False),
    "rod.E_e": ("force", False),
    "rod.outer_diameter": ("length", False),
    "rod.precurvature": ("curvature", True),
    "field.B": ("field", True),
    "tip.force": ("force", True),
    "tip.moment": ("torque", True),
    "load.distributed_force": ("force_per_length", True),
    "magnet.N.at": ("length", False),
    "magnet.N.moment": ("moment", False),
    "magnetization.N.per_length": ("moment_per_length", False),
    "point_load.N.force": ("force", True),
    "point_load.N.moment": ("torque", True),
}
#: At most this many states in one sweep (the product of the entries' counts).
MAX_STATES = 100_000


@dataclass(frozen=True)
class Axis:
    """One sweep entry: the key, its unit kind, and its values in SI (floats or 3-tuples)."""

    key: str
    kind: str
    vector: bool
    values: tuple

    def columns(self) -> list[str]:
        unit = SI_UNITS[self.kind]
        if self.vector:
            return [f"{self.key}_{c} [{unit}]" for c in "xyz"]
        return [f"{self.key} [{unit}]"]


def key_kind(key: str) -> tuple[str, bool]:
    """(unit kind, vector?) of a sweepable key; DataError for any other."""
    pattern = re.sub(r"\.[1-9][0-9]*\.", ".N.", key) if isinstance(key, str) else ""
    if pattern not in KEYS:
        raise DataError(f"sweep.key {key!r}: not a sweepable key (known: {', '.join(KEYS)}; N from 1)")
    return KEYS[pattern]


def parse_sweep(entries) -> list[Axis]:
    """Axes from ``[[sweep]]`` tables (key + values, or key + from/to/count) or a {key: values} mapping."""
    if isinstance(entries, dict):
        entries = [{"key": k, "values": list(v)} for k, v in entries.items()]
    if not isinstance(entries, list) or not entries:
        raise DataError("[[sweep]]: give one table per swept key")
    axes, total = [], 1
    for i, entry in enumerate(entries, 1):
        where = f"sweep[{i}]"
        if not isinstance(entry, dict) or "key" not in entry:
            raise DataError(f"{where}: needs a key")
        unknown = sorted(set(entry) - {"key", "values", "from", "to", "count"})
        if unknown:
            raise DataError(f"{where}: unknown key {unknown[0]!r} (key, values, or from/to/count)")
        kind, vector = key_kind(entry["key"])
        try:
            values = _values(entry, kind, vector, where)
        except UnitError as exc:
            raise DataError(f"{where}: {exc}") from exc
        if any(a.key == entry["key"] for a in axes):
            raise DataError(f"{where}: {entry['key']} is swept twice")
        total *= len(values)
        if total > MAX_STATES:
            raise DataError(f"[[sweep]]: more than {MAX_STATES} states")
        axes.append(Axis(entry["key"], kind, vector, tuple(values)))
    return axes


def _values(entry: dict, kind: str, vector: bool, where: str) -> list:
    if "values" in entry:
        if any(k in entry for k in ("from", "to", "count")):
            raise DataError(f"{where}: give values or from/to/count, not both")
        values = entry["values"]
        if not isinstance(values, list) or not values:
            raise DataError(f"{where}.values: a non-empty list")
        return [vector_to_si(v, kind) if vector else to_si(v, kind) for v in values]
    if vector:
        raise DataError(f"{where}: {entry['key']} is a vector: list its values")
    if not all(k in entry for k in ("from", "to", "count")):
        raise DataError(f"{where}: needs values, or from, to and count")
    count = entry["count"]
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_STATES:
        raise DataError(f"{where}.count: a whole number from 1 to {MAX_STATES}")
    a, b = to_si(entry["from"], kind), to_si(entry["to"], kind)
    return [a + (b - a) * k / max(count - 1, 1) for k in range(count)]


def with_value(scene: Scene, key: str, value) -> Scene:
    """The scene with ``key`` set to ``value`` (SI); the bounds a scene file's value has
    (:mod:`matid.rod.schema`) and the scene's checks run again (DataError)."""
    parts = key.split(".")
    schema.check(parts[0], parts[-1], value, key.rpartition(".")[0])
    rod, loads = scene.rod, scene.loads
    if parts[0] == "rod":
        return replace(scene, rod=replace(rod, **{parts[1]: value}))
    simple = {"field.B": "B", "tip.force": "tip_force", "tip.moment": "tip_moment"}
    simple["load.distributed_force"] = "distributed_force"
    if key in simple:
        return replace(scene, loads=replace(loads, **{simple[key]: tuple(value)}))
    name, index, field = parts[0], int(parts[1]) - 1, parts[2]
    attr = {"magnet": "magnets", "magnetization": "magnetization", "point_load": "point_loads"}[name]
    items = list(getattr(loads, attr))
    if index >= len(items):
        raise DataError(f"sweep.key {key}: the scene has {len(items)} [[{name}]]")
    slot = {"at": 0, "moment": 1 if name == "magnet" else 2, "per_length": 2, "force": 1}[field]
    item = list(items[index])
    item[slot] = tuple(value) if isinstance(value, tuple) else value
    items[index] = tuple(item)
    return replace(scene, loads=replace(loads, **{attr: tuple(items)}))


def states(scene: Scene, axes: list[Axis]) -> list[tuple[tuple, Scene | DataError]]:
    """Every combination (last axis fastest): (values, scene), or the DataError of a bad state."""
    out = []
    for combo in itertools.product(*(a.values for a in axes)):
        try:
            state = scene
            for axis, value in zip(axes, combo, strict=True):
                state = with_value(state, axis.key, value)
        except DataError as exc:
            state = exc
        out.append((combo, state))
    return out


def load_sweep(path) -> tuple[Scene, list[Axis] | None]:
    """A scene file and its ``[[sweep]]`` axes (None without one), read as :func:`load_scene` does."""
    from pathlib import Path

    path = Path(path)
    raw = parse_toml(read_small_file(path, "scene file"), path)
    entries = raw.pop("sweep", None)
    try:
        scene = scene_from_dict(raw, root=path.parent)
        axes = None if entries is None else parse_sweep(entries)
    except DataError as exc:
        raise exc if exc.file else DataError(exc.detail, file=path) from exc
    return scene, axes


def rows(axes: list[Axis], done: list[tuple[tuple, object]]) -> list[dict]:
    """One row per state (contract section 13): swept values (SI), converged, stable, tip, d3, ..."""
    out = []
    for combo, sol in done:
        row: dict = {}
        for axis, value in zip(axes, combo, strict=True):
            row.update(zip(axis.columns(), value if axis.vector else (value,), strict=True))
        ok = getattr(sol, "converged", False)
        reason = "" if ok else getattr(sol, "reason", str(sol))
        row["converged"] = ok
        row["stable"] = True if ok else (False if "unstable" in reason else None)
        tip = sol.tip if ok else {"position": [math.nan] * 3, "d3": [math.nan] * 3}
        row.update({f"tip_{c} [m]": v for c, v in zip("xyz", tip["position"], strict=True)})
        row.update({f"d3_{c}": v for c, v in zip("xyz", tip["d3"], strict=True)})
        row["discretization_error"] = sol.discretization_error if ok else math.nan
        row["newton_iterations"] = sol.newton_iterations if ok else 0
        row["warnings"] = "; ".join(sol.extra.get("warnings", [])) if ok else ""
        row["reason"] = reason
        out.append(row)
    return out


def solve_states(scene: Scene, axes: list[Axis], **options) -> list[tuple[tuple, object]]:
    """(values, Solution or Failure) of every state of the sweep, solved together."""
    from matid.rod.many import Failure, solve_many

    made = states(scene, axes)
    good = [s for _, s in made if isinstance(s, Scene)]
    solved = iter(solve_many(good, **options))
    return [(c, next(solved) if isinstance(s, Scene) else Failure(scene, str(s))) for c, s in made]


def sweep(scene: Scene, sweeps: dict, **options):
    """The table of a sweep as a pandas DataFrame, one row per state (contract section 13).

    ``sweeps``: {dotted key: values} (SI numbers or quantities with units; vectors as 3-lists),
    every combination, last key fastest; ``options``: those of :func:`matid.rod.many.solve_many`.
    """
    import pandas as pd

    axes = parse_sweep(sweeps)
    return pd.DataFrame(rows(axes, solve_states(scene, axes, **options)))
