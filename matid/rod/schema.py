"""The scene format, one entry per table and key: the reader (:mod:`matid.rod.scenes`), its checks
(:mod:`matid.rod.scene_values`) and the reference page docs/scenes.md are all made from :data:`TABLES`.

    python docs/make_scenes.py

writes the page (tests/rod/test_scene_schema.py checks that it is what is committed).

Each :class:`Key` says its type, its unit (a quantity kind of :mod:`matid.units`), its bounds in SI
(a vector's bound is on each component's magnitude), its default and an example; each
:class:`Table` says whether it is one table or an array of tables (and how many entries at most),
which model runs it and which load term of :mod:`matid.rod.terms` carries it into the energy.

**A new table is one entry here** (say contact's ``[[wall]]``, ``[lumen]``, ``[advance]``, or the
designer's ``[[sweep]]``): a ``Table(...)`` appended to :data:`TABLES` with its keys, then read in
:func:`matid.rod.scenes.scene_from_dict` with :func:`matid.rod.scene_values.read` (which takes the
kind, default and bounds from here); unknown keys, types, bounds and entry counts are then checked
and the table is documented, with no other list to edit.

The bounds keep every product the solver forms finite (a force times L^2 over E_b, a curvature
squared, a length cubed) and are far beyond any catheter: see docs/limits.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from matid.rod.accuracy import MAX_ELEMENTS

#: Most entries of one array of tables (``[[segment]]``, ``[[point_load]]``, ...) in a scene.
MAX_SCENE_ENTRIES = 200
#: Most nose displacements a three-point-bend scene may list (each is a continuation solve).
MAX_DEFLECTIONS = 1000
#: Smallest tolerance: the error estimate never claims better than round-off (accuracy.ROUNDOFF).
MIN_TOLERANCE = 1e-12

# Bounds in SI, shared by keys of one kind.
LENGTH = (1e-6, 100.0)  # m: a rod, a span
POSITION = (0.0, 100.0)  # m: a point or range along the rod (also checked against the rod's length)
DIAMETER = (1e-7, 1.0)  # m
BENDING = (1e-15, 1e6)  # N m^2: E_b, E_t
AXIAL = (1e-12, 1e12)  # N: E_s, E_e
CURVATURE = 1e6  # 1/m: a radius of 1 um
FORCE = 1e6  # N
FORCE_PER_LENGTH = 1e8  # N/m
TORQUE = 1e6  # N m
FIELD = 100.0  # T
MOMENT = 1e3  # A m^2
MOMENT_PER_LENGTH = 1e6  # A (A m^2 per m)


@dataclass(frozen=True)
class Key:
    """One key of a scene table.

    ``type``: "quantity" (a number with a unit, or a bare SI number), "vector" (three quantities,
    lab or director frame), "direction" (three plain numbers, normalised; not all zero), "bool",
    "integer", "number" (plain), "text", "lengths" (a list of lengths), "choice", "table" (an inline
    table, ``rod.stiffness``). ``bounds``: (low, high) of the SI value, for a vector the largest
    magnitude of a component (low unused); ``open_low``: the low bound itself is refused.
    ``default``: None when the key is required; :data:`ABSENT` when it has none (a vector of zeros,
    a load not there).
    """

    name: str
    type: str
    doc: str
    example: str
    kind: str | None = None
    bounds: tuple[float, float] | None = None
    default: object = None
    open_low: bool = False
    choices: tuple[str, ...] = ()  # a "choice": the values allowed
    fields: tuple[str, ...] = ()  # a "table": its keys

    @property
    def unit(self) -> str:
        from matid.units import SI_UNITS

        return SI_UNITS[self.kind] if self.kind else ""


#: The default of a key that may be left out with no value in its place (a zero vector, no load).
ABSENT = "absent"


@dataclass(frozen=True)
class Table:
    """One table of a scene (``name`` "" for the top level) and its keys."""

    name: str
    doc: str
    keys: tuple[Key, ...]
    array: bool = False
    max_entries: int = 1
    models: str = "planar, full"
    terms: tuple[str, ...] = ()  # the load terms of matid.rod.terms that carry it, "module.Class"
    required: bool = False
    example: str = ""  # a whole-table example when the keys' own do not make one
    keys_by_name: dict = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        self.keys_by_name.update({k.name: k for k in self.keys})

    @property
    def title(self) -> str:
        if not self.name:
            return "top level"
        return f"[[{self.name}]]" if self.array else f"[{self.name}]"


def _q(name, kind, bounds, doc, example, default=None, open_low=False) -> Key:
    return Key(name, "quantity", doc, example, kind, bounds, default, open_low)


def _v(name, kind, bound, doc, example) -> Key:
    return Key(name, "vector", doc, example, kind, (0.0, bound), ABSENT)


def _stiffness(default=None) -> tuple[Key, ...]:
    return (
        _q("E_b", "bending_stiffness", BENDING, "bending stiffness E I", '"6.5e-5 N m^2"', default),
        _q("E_t", "bending_stiffness", BENDING, "torsional stiffness G J", '"4.4e-5 N m^2"', default),
        _q("E_s", "force", AXIAL, "shear stiffness G A (times the shear factor)", '"21 N"', default),
        _q("E_e", "force", AXIAL, "axial stiffness E A", '"120 N"', default),
    )


_DIAMETER = "outer diameter of the tube (strain warnings; contact)"
_PRECURVATURE = "curvature of the unloaded rod, director frame (kappa1, kappa2, twist)"
_DIRECTION = "magnetisation direction in the director frame (d3 along the rod; default d3)"

TABLES: tuple[Table, ...] = (
    Table(
        "",
        "what is solved, and how finely",
        (
            Key("scene", "choice", "the problem", '"cantilever"', default="cantilever",
                choices=("cantilever", "three_point_bend")),
            Key("elements", "integer", "elements of the mesh; absent: refined until `tolerance` (the "
                "three-point bend's half model needs at least 2)", "32", bounds=(1, MAX_ELEMENTS),
                default=ABSENT),
            Key("tolerance", "number", "discretisation error wanted (relative), when `elements` is absent",
                "1e-6", bounds=(MIN_TOLERANCE, 1.0), default=1e-6),
        ),
        models="planar, full, bend",
    ),
    Table(
        "rod",
        "the clamped rod (cantilever) or the specimen (three-point bend); clamped at s = 0",
        (
            _q("length", "length", LENGTH, "length L of the rod (its free length)", '"30 mm"', open_low=True),
            *_stiffness(),
            _q("outer_diameter", "length", DIAMETER, _DIAMETER, '"2.4 mm"', ABSENT),
            _v("precurvature", "curvature", CURVATURE, _PRECURVATURE, '["0 1/m", "10 1/m", "0 1/m"]'),
            Key("stiffness", "table", "E_* from a matid fit (stiffness.json in SI): `from` (a file inside "
                "the scene's folder unless `allow_outside = true`), `specimen`; a value given beside "
                "it as well is refused", '{ from = "stiffness.json", specimen = "T1" }', default=ABSENT,
                fields=("from", "specimen", "allow_outside")),
        ),
        required=True,
        models="planar, full, bend",
        example='[rod]\nlength = "30 mm"\nE_b = "6.5e-5 N m^2"\nE_t = "4.4e-5 N m^2"\nE_s = "21 N"\nE_e = "120 N"\n'
        'outer_diameter = "2.4 mm"\nprecurvature = ["0 1/m", "10 1/m", "0 1/m"]\n'
        '# or, in place of the E_* above:\n# stiffness = { from = "stiffness.json", specimen = "T1" }',
    ),
    Table(
        "segment",
        "a piece [from, to) of the rod with its own stiffness, diameter or precurvature, or rigid; "
        "pieces may touch but not overlap",
        (
            _q("from", "length", POSITION, "start of the piece along the rod", '"0 mm"'),
            _q("to", "length", POSITION, "end of the piece (from < to <= L)", '"10 mm"'),
            *_stiffness(ABSENT),
            _q("outer_diameter", "length", DIAMETER, _DIAMETER, '"3 mm"', ABSENT),
            Key("rigid", "bool", "a rigid piece (a magnet housing): stiffnesses far above the rod's",
                "false", default=False),
            _v("precurvature", "curvature", CURVATURE, _PRECURVATURE, '["0 1/m", "50 1/m", "0 1/m"]'),
        ),
        array=True,
        max_entries=MAX_SCENE_ENTRIES,
    ),
    Table(
        "field",
        "a uniform magnetic field (lab frame): it turns the magnets and the magnetisation; only stable "
        "equilibria are reported (the solve continues the load from zero)",
        (_v("B", "field", FIELD, "the field", '["20 mT", "0 mT", "0 mT"]'),),
        terms=("matid.rod.terms.magnets.Magnets", "matid.rod.terms.magnetisation.Magnetisation"),
    ),
    Table(
        "load",
        "a dead distributed force (lab frame), per unit length, along the whole rod",
        (_v("distributed_force", "force_per_length", FORCE_PER_LENGTH, "force per length",
            '["0 N/m", "0 N/m", "-0.01 N/m"]'),),
        terms=("matid.rod.terms.distributed.DistributedForce",),
    ),
    Table(
        "tip",
        "a dead force and moment at the tip (lab frame)",
        (
            _v("force", "force", FORCE, "force at s = L", '["1e-3 N", "0 N", "0 N"]'),
            _v("moment", "torque", TORQUE, "moment at s = L (in 3D: virtual work, no potential)",
               '["0 N m", "1e-4 N m", "0 N m"]'),
        ),
        terms=("matid.rod.terms.tip.Tip",),
    ),
    Table(
        "magnet",
        "a lumped magnet (a dipole) fixed on the rod",
        (
            _q("at", "length", POSITION, "where along the rod, 0 < at <= L", '"30 mm"'),
            _q("moment", "moment", (-MOMENT, MOMENT), "dipole moment |m| (its sign flips it)",
               '"0.0125 A m^2"'),
            Key("direction", "direction", _DIRECTION, "[1, 0, 0]", default=ABSENT),
        ),
        array=True,
        max_entries=MAX_SCENE_ENTRIES,
        terms=("matid.rod.terms.magnets.Magnets",),
    ),
    Table(
        "magnetization",
        "a magnetised piece [from, to) of the rod (a magnetic polymer), moment per unit length",
        (
            _q("from", "length", POSITION, "start of the piece", '"20 mm"'),
            _q("to", "length", POSITION, "end of the piece (from < to <= L)", '"30 mm"'),
            _q("per_length", "moment_per_length", (-MOMENT_PER_LENGTH, MOMENT_PER_LENGTH),
               "moment per length (A m^2 / m = A)", '"0.4 A"'),
            Key("direction", "direction", _DIRECTION, "[0, 1, 0]", default=ABSENT),
        ),
        array=True,
        max_entries=MAX_SCENE_ENTRIES,
        terms=("matid.rod.terms.magnetisation.Magnetisation",),
    ),
    Table(
        "point_load",
        "a dead force and moment at an interior point (a pull-wire anchor); give a force, a moment "
        "or both",
        (
            _q("at", "length", POSITION, "where along the rod, 0 < at <= L", '"12 mm"'),
            _v("force", "force", FORCE, "force (lab frame)", '["0 N", "0 N", "-1e-3 N"]'),
            _v("moment", "torque", TORQUE, "moment (lab frame); in 3D a dead moment has no potential: "
               "stability is then tested on the symmetrised tangent",
               '["8e-4 N m", "0 N m", "4e-4 N m"]'),
        ),
        array=True,
        max_entries=MAX_SCENE_ENTRIES,
        terms=("matid.rod.terms.point_loads.PointLoads",),
    ),
    Table(
        "aim",
        "the inverse problem: the field direction, at a given |B|, that turns the tip's d3 to a target; "
        "the solve stops after AIM_SECONDS (matid.rod.aim) with the closest direction reached",
        (
            Key("tip_direction", "direction", "d3 wanted at the tip (lab frame; normalised)",
                "[0.5, 0, 0.866]"),
            _q("field_magnitude", "field", (0.0, FIELD), "|B| held", '"160 mT"', open_low=True),
        ),
        models="full",
        terms=("matid.rod.terms.magnets.Magnets", "matid.rod.terms.magnetisation.Magnetisation"),
    ),
    Table(
        "three_point_bend",
        "the three-point bend of a straight uniform tube (scene = \"three_point_bend\"): supports at "
        "+-span/2, a nose at the middle; each radius under half the span, the tube's diameter under "
        "the span, the specimen longer than the span",
        (
            _q("span", "length", LENGTH, "distance between the supports' centres (< length)", '"10 mm"',
               open_low=True),
            _q("support_radius", "length", (0.0, 100.0), "radius of each support (< span/2)", '"2 mm"'),
            _q("nose_radius", "length", (0.0, 100.0), "radius of the nose (< span/2)", '"2 mm"'),
            Key("deflection", "lengths", f"nose displacements, increasing, each in [0, span] (at most "
                f"{MAX_DEFLECTIONS})", '["0.1 mm", "0.5 mm", "1 mm"]', "length", (0.0, 100.0)),
        ),
        models="bend",
    ),
    Table(
        "wall",
        "a rigid plane the tube's outer surface stays on one side of (frictionless, unilateral contact; "
        "contract section 12); any number of walls (a tip pressed on a wall by a field: "
        "examples/scenes/wall_tip.toml)",
        (
            Key("point", "vector", "a point on the wall's surface (lab frame)", '["5 mm", "0 mm", "0 mm"]',
                "length", (0.0, POSITION[1])),  # required: a wall has no default place
            Key("normal", "direction", "points to the side the tube stays on (normalised)", "[-1, 0, 0]"),
        ),
        array=True,
        max_entries=MAX_SCENE_ENTRIES,
        models="planar (a wall containing the bending plane's normal), full",
        terms=("matid.rod.terms.contact.Contact",),
    ),
    Table(
        "lumen",
        "a rigid vessel the tube stays inside: a polyline centreline whose corners are rounded with "
        "corner_radius, and its inner radius (at most one; a vessel bend: "
        "examples/scenes/advance_lumen.toml)",
        (
            Key("centreline", "points", "the centreline's corners [x, y, z] (lab frame), at least two",
                '[["0 mm", "0 mm", "-10 mm"], ["0 mm", "0 mm", "40 mm"]]', "length", (0.0, POSITION[1])),
            _q("radius", "length", DIAMETER,
               "inner radius (wider than the tube: its clearance above the contact tolerance)", '"3 mm"',
               open_low=True),
            _q("corner_radius", "length", DIAMETER, "radius the corners are rounded with", '"15 mm"',
               default="5 x radius", open_low=True),
        ),
        terms=("matid.rod.terms.contact.Contact",),
    ),
    Table(
        "advance",
        "quasi-static insertion out of a sheath at the clamp: [rod] length is the whole tube, each step "
        "models its distal free length, solved in order, each from the last (its shape kept, the new "
        "length continued along the tip and kept inside the walls and lumen); a step that does not "
        "solve from there is reached through intermediate free lengths (the failed increment halved, "
        "down to 1/64 of the free length), counted in its `substeps` in solution.json "
        "(examples/scenes/advance_channel.toml, advance_lumen.toml)",
        (
            Key("free_lengths", "lengths", "free lengths, each in (0, length], in the order pushed",
                '["10 mm", "20 mm", "30 mm"]', "length", LENGTH),
        ),
    ),
    Table(
        "sweep",
        "many scenes at once (contract section 13; `matid solve` and matid.rod.sweep, not load_scene): "
        "one entry per swept key, values or from/to/count; several entries make every combination "
        "(last fastest)",
        (
            Key("key", "text", "a dotted key of this scene (field.B, tip.force, rod.E_b, magnet.1.moment, "
                "...: matid.rod.sweeps.KEYS)", '"rod.E_b"'),
            Key("values", "list", "the values (quantities or vectors), or from/to/count instead",
                '["5e-5 N m^2", "9e-5 N m^2"]', default=ABSENT),
            Key("from", "quantity", "first value of an evenly spaced scalar sweep", '"5e-5 N m^2"',
                default=ABSENT),
            Key("to", "quantity", "last value", '"9e-5 N m^2"', default=ABSENT),
            Key("count", "integer", "number of values from `from` to `to`", "5", default=ABSENT),
        ),
        array=True,
        max_entries=MAX_SCENE_ENTRIES,
        example='[[sweep]]\nkey = "rod.E_b"\nfrom = "5e-5 N m^2"\nto = "9e-5 N m^2"\ncount = 5',
    ),
)

#: The tables by name ("" the top level).
BY_NAME: dict[str, Table] = {t.name: t for t in TABLES}
#: Keys of each table, the top level's included (the reader's list of what is known).
TABLE_KEYS: dict[str, set[str]] = {t.name: set(t.keys_by_name) for t in TABLES if t.name}
#: Top-level keys of a scene file: the top level's own keys and every table.
SCENE_KEYS: set[str] = set(BY_NAME[""].keys_by_name) | set(TABLE_KEYS)


def key(table: str, name: str) -> Key:
    return BY_NAME[table].keys_by_name[name]


def check(table: str, name: str, value, where: str) -> None:
    """A DataError naming ``where.name`` unless the SI ``value`` (a number or 3 components) is inside
    the key's bounds."""
    from matid.errors import DataError

    spec = key(table, name)
    if spec.bounds is None:
        return
    low, high = spec.bounds
    unit = f" {spec.unit}" if spec.unit else ""
    if spec.type in ("vector", "points"):  # a vector, or one point of a list
        big = max(abs(c) for c in value)
        if not big <= high:
            raise DataError(f"{where}.{name}: each component must be at most {high:g}{unit} in magnitude, "
                            f"got {big:.6g}{unit}")
        return
    too_low = not value > low if spec.open_low else not value >= low
    if too_low or not value <= high or not math.isfinite(value):
        left = "(" if spec.open_low else "["
        raise DataError(f"{where}.{name}: must be in {left}{low:g}, {high:g}]{unit}, got {value:.6g}{unit}")
