"""The solver fuzz's contact, advance and sweep cases (issue 30 item 7), used by tests/fuzzkit.py.

:func:`contact_mutation` changes a scene document the way the solver fuzz's other mutations do,
for the keys of contract sections 12 and 13: it adds a ``[[wall]]`` (points on and off the tube,
normals of any length, zero or not finite), a ``[lumen]`` (straight, bent, 3D, degenerate
centrelines; radii from inside the tube to far outside it; corner radii), an ``[advance]``
(free lengths in order, reversed, repeated, zero, past the tube) or a ``[[sweep]]`` (any sweepable
key, values or from/to/count), or changes one component of a list (a normal's x, a point's z, a
free length, one swept value). :func:`solve_sweep` runs a scene with ``[[sweep]]`` the way
``matid solve`` does (matid.rod.sweeps: every state, the table, sweep.csv, sweep.json and
workspace.png) and checks every state it returns.
"""

from __future__ import annotations

import copy
import math

from hypothesis import strategies as st

#: Keys whose presence makes a case a contact/advance/sweep case (counted apart by benchmarks/fuzz.py).
CONTACT_KEYS = ("wall", "lumen", "advance", "sweep")
#: Factors one component is multiplied by (fuzzkit.SCALES plus the mild ones, twice as likely).
COMPONENT_SCALES = [2, 0.5, 10, 0.1, -1, 0, 1e-300, 1e-8, 1e8, 1e300, -1e300, 1.0000001]

#: Distances from the clamp's centre to an added wall (most beyond the examples' tube radii, 0.5 to
#: 1.2 mm, so the wall clears the clamp; a few cut it, touch it, or are absurd).
WALL_DISTANCES = ["1.3 mm", "2 mm", "2 mm", "5 mm", "5 mm", "12.5 mm", "40 mm", "1.2 mm", "0.5 mm",
                  "0 mm", "-3 mm", "1e-9 mm", "1e3 mm", "1e300 mm"]  # fmt: skip
#: Offsets of a wall's point along the tube (z), for a wall whose normal has no z component.
WALL_Z = ["0 mm", "0 mm", "10 mm", "-5 mm", "30 mm", "1e-9 mm", "-1e3 mm"]
NORMALS = [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 0, -1], [-1, 0, -1], [-1, 0, 1], [-0.7, 0.7, 0],
           [0, 0, 0], [1e-300, 0, 0], [-1e300, 0, 0], [-1, 1e-9, 0], [-0.984808, 0, -0.173648]]  # fmt: skip
CENTRELINES = [
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "200 mm"]],  # straight along the tube
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "200 mm"]],
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "20 mm"], ["10 mm", "0 mm", "40 mm"]],  # bent in x-z
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "20 mm"], ["10 mm", "0 mm", "40 mm"]],
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "10 mm"], ["-8 mm", "0 mm", "25 mm"],
     ["-8 mm", "0 mm", "80 mm"]],
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "15 mm"], ["5 mm", "5 mm", "30 mm"],
     ["5 mm", "5 mm", "90 mm"]],  # 3D
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "20 mm"], ["0 mm", "0 mm", "20 mm"],
     ["0 mm", "0 mm", "50 mm"]],  # two corners coincide
    [["0 mm", "0 mm", "0 mm"], ["0 mm", "0 mm", "0 mm"]],  # a point
    [["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "20 mm"], ["0 mm", "0 mm", "-30 mm"]],  # turns back
    [["1 mm", "0 mm", "-10 mm"], ["1 mm", "0 mm", "60 mm"]],  # off the clamp's axis
    [["0 mm", "0 mm", "-1e300 mm"], ["0 mm", "0 mm", "1e300 mm"]],
]
#: Lumen radii: the examples' tubes are 1 to 2.4 mm wide, so most are wider, a few narrower or absurd.
RADII = ["0.5 mm", "0.5000001 mm", "0.6 mm", "1.2 mm", "1.2000001 mm", "1.3 mm", "1.5 mm", "2 mm", "2 mm",
         "3 mm", "3 mm", "5 mm", "10 mm", "1e-6 mm", "1e3 mm", "1e300 mm", "0 mm"]  # fmt: skip
CORNERS = [None, None, None, "1e-3 mm", "0.5 mm", "3 mm", "15 mm", "1e6 mm", "0 mm"]
FREE = ["1e-9 mm", "0.1 mm", "2 mm", "10 mm", "20 mm", "29.999 mm", "30 mm", "45 mm", "50 mm", "100 mm",
        "0 mm", "-5 mm", "1e3 mm"]  # fmt: skip
#: (key, values or from/to/count) of an added [[sweep]]; counts stay small (a sweep of 10^5 states
#: is a long solve by request, not a hang).
SWEEPS = [
    {"key": "rod.E_b", "from": "1e-5 N m^2", "to": "1e-4 N m^2", "count": 3},
    {"key": "rod.E_b", "values": ["0 N m^2", "1e-300 N m^2", "1e300 N m^2"]},
    {"key": "rod.length", "values": ["10 mm", "30 mm", "1e-6 mm"]},
    {"key": "rod.outer_diameter", "values": ["0.1 mm", "1 mm", "5 mm"]},
    {"key": "field.B",
     "values": [["20 mT", "0 mT", "0 mT"], ["0 mT", "0 mT", "-20 mT"], ["1e300 mT", "0 mT", "0 mT"]]},
    {"key": "field.B", "values": [["0 mT", "20 mT", "0 mT"], ["10 mT", "10 mT", "10 mT"]]},
    {"key": "tip.force", "values": [["1e-3 N", "0 N", "0 N"], ["0 N", "0 N", "-1 N"], ["0 N", "0 N", "0 N"]]},
    {"key": "tip.moment", "values": [["0 N m", "1e-4 N m", "0 N m"], ["0 N m", "0 N m", "1e-3 N m"]]},
    {"key": "magnet.1.moment", "from": "0 A m^2", "to": "0.05 A m^2", "count": 4},
    {"key": "magnet.1.at", "values": ["1 mm", "25 mm", "50 mm", "100 mm"]},
    {"key": "magnetization.1.per_length", "from": "-20 A", "to": "1e8 A", "count": 2},
    {"key": "point_load.1.force", "values": [["1e-3 N", "0 N", "0 N"]]},
    {"key": "load.distributed_force",
     "values": [["0.1 N/m", "0 N/m", "0 N/m"], ["0 N/m", "0 N/m", "-1 N/m"]]},
    {"key": "rod.precurvature", "values": [["10 1/m", "0 1/m", "0 1/m"], ["0 1/m", "5 1/m", "1e300 1/m"]]},
    {"key": "rod.E_s", "values": ["1 N", "1e6 N"], "count": 2},
    {"key": "magnet.2.moment", "values": ["0.01 A m^2"]},
    {"key": "rod.nope", "values": ["1 mm"]},
    {"key": "rod.E_b", "from": "1e-5 N m^2", "to": "1e-4 N m^2", "count": 0},
    {"key": "rod.E_b", "from": "1e-5 N m^2", "to": "1e-4 N m^2", "count": 100_001},
    {"key": "rod.E_b", "from": "1e-5 N m^2", "to": "1 mm", "count": 2},
    {"key": "rod.E_b", "values": []},
]
#: Whole replacements for a sweep entry's count (an integer the reader takes, or one it refuses).
COUNTS = [1, 2, 3, 5, 0, -1, 1.5, True, "3", 100_001, 10**30]


def _length_mm(doc: dict) -> float | None:
    """The scene's rod length in mm when it is written "<number> mm", else None."""
    rod = doc.get("rod")
    text = rod.get("length") if isinstance(rod, dict) else None
    try:
        number, unit = str(text).split()
        return float(number) if unit == "mm" else None
    except ValueError:
        return None


def has_contact_keys(doc: dict) -> bool:
    return any(k in doc for k in CONTACT_KEYS)


@st.composite
def contact_mutation(draw, doc: dict) -> str:
    """Change ``doc`` in place (a cantilever scene's dict); returns a label of what was done."""
    what = draw(st.sampled_from(["wall", "wall", "lumen", "lumen", "advance", "advance", "sweep", "sweep",
                                 "component", "component", "component", "count"]))  # fmt: skip
    if what == "wall":  # at a drawn distance d from the clamp's centre, on the far side of its normal n
        normal = copy.deepcopy(draw(st.sampled_from(NORMALS)))
        d, unit = draw(st.sampled_from(WALL_DISTANCES)).split()
        size = math.hypot(*map(float, normal)) or 1.0
        point = [-float(d) * float(c) / size for c in normal]
        if normal[2] == 0:
            point[2] = float(draw(st.sampled_from(WALL_Z)).split()[0])
        entry = {"point": [f"{c:.9g} {unit}" for c in point], "normal": normal}
        walls = doc.setdefault("wall", [])
        if isinstance(walls, list):
            walls.append(entry)
        return f"wall: add point={entry['point']} normal={entry['normal']}"
    if what == "lumen":
        lumen = {"centreline": copy.deepcopy(draw(st.sampled_from(CENTRELINES))),
                 "radius": draw(st.sampled_from(RADII))}  # fmt: skip
        corner = draw(st.sampled_from(CORNERS))
        if corner is not None:
            lumen["corner_radius"] = corner
        doc["lumen"] = lumen
        return f"lumen: {lumen}"
    if what == "advance":  # mostly fractions of the tube's length, a few absolute lengths
        n = draw(st.integers(1, 6))
        length = _length_mm(doc)
        fraction = st.sampled_from([0.1, 0.25, 0.33, 0.5, 0.7, 0.9, 0.999, 1.0])
        fractions = fraction.map(lambda f: f"{f * length:.9g} mm")
        free = [draw(fractions if length and draw(st.integers(0, 3)) else st.sampled_from(FREE))
                for _ in range(n)]  # fmt: skip
        order = draw(st.sampled_from(["drawn", "sorted", "reversed"]))
        if order != "drawn":
            free.sort(key=lambda q: float(q.split()[0]), reverse=order == "reversed")
        doc["advance"] = {"free_lengths": free}
        return f"advance: {free}"
    if what == "sweep":
        entry = copy.deepcopy(draw(st.sampled_from(SWEEPS)))
        sweeps = doc.setdefault("sweep", [])
        if isinstance(sweeps, list) and len(sweeps) < 2:
            sweeps.append(entry)
        return f"sweep: add {entry}"
    if what == "count":
        entries = [t for t in doc.get("sweep", []) if isinstance(t, dict) and "count" in t]
        if not entries:
            return "count: none"
        count = draw(st.sampled_from(COUNTS))
        draw(st.sampled_from(entries))["count"] = count
        return f"sweep.count = {count!r}"
    return draw(component_mutation(doc))


@st.composite
def component_mutation(draw, doc: dict) -> str:
    """One component of a list in a contact, advance or sweep table scaled (or set to a quantity
    the reader refuses): a normal's x, a point's z, a centreline corner's y, a free length, a value."""
    from tests.fuzzkit import scaled

    slots = []  # (label, the list, index)

    def collect(label, value):
        if isinstance(value, list):
            for i, v in enumerate(value):
                if isinstance(v, list):
                    collect(f"{label}[{i}]", v)
                else:
                    slots.append((f"{label}[{i}]", value, i))

    for key in CONTACT_KEYS:
        tables = doc.get(key)
        for n, table in enumerate(tables if isinstance(tables, list) else [tables]):
            if isinstance(table, dict):
                for name, value in table.items():
                    collect(f"{key}[{n}].{name}", value)
    if not slots:
        return "component: none"
    label, where, i = draw(st.sampled_from(slots))
    if draw(st.integers(0, 4)) == 0:
        where[i] = draw(st.sampled_from(["nan mm", "inf mm", "1e400 mm", "", "3 N", 1e309, float("nan")]))
    else:
        where[i] = scaled(where[i], draw(st.sampled_from(COMPONENT_SCALES)))
    return f"{label} = {where[i]!r}"


def solve_sweep(scene_path, elements: int | None) -> tuple[int, str]:
    """``matid solve`` of a scene with [[sweep]] (matid.app.solve_cli._solve_sweep's steps, in this
    process): (0 every state converged / 1 some failed / "absurd", message). Every Solution goes
    through fuzzkit.absurdity; every row of the table must hold finite numbers below fuzzkit.ABSURD
    when converged, and a reason when not; the three files are made as the command makes them."""
    import json

    from matid.rod.sweep_output import sweep_csv, sweep_json, workspace_png
    from matid.rod.sweeps import load_sweep, rows, solve_states
    from tests.fuzzkit import ABSURD, absurdity

    scene, axes = load_sweep(scene_path)
    done = solve_states(scene, axes, elements=elements)
    for combo, result in done:
        if getattr(result, "converged", False):
            wrong = absurdity(result)
            if wrong:
                return "absurd", f"state {combo}: {wrong}"
        elif not str(getattr(result, "reason", "")).strip():
            return "absurd", f"state {combo}: failed without a reason"
    table = rows(axes, done)
    inputs = {c for a in axes for c in a.columns()}  # the swept values: echoed input, not results
    for row in table:
        if row["converged"]:
            bad = [(k, v) for k, v in row.items() if k not in inputs and not isinstance(v, (bool, str))
                   and not abs(v) <= ABSURD]  # fmt: skip
            if bad:
                return "absurd", f"row {row}: {bad[0][0]} = {bad[0][1]!r}"
    json.dumps(sweep_json(axes, table))
    sweep_csv(table)
    workspace_png(axes, table, name="fuzz", dpi=40)
    failed = [r for r in table if not r["converged"]]
    return (1, f"{len(failed)} of {len(table)} states failed: {failed[0]['reason']}") if failed else (0, "")
