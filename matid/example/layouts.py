"""The two SYNTHETIC studies the generator writes: ``demo`` and ``alt``.

``demo`` is the committed study in ``data/example``: specimens T1 and T2,
every test kind, its files spelled so that together they exercise the CSV
contract (docs/contract.md section 2). ``alt`` is a study matid was not
written against: other specimen names, lengths, rates, units and CSV
dialects, files in a subfolder with spaces in their names, a cyclic
extension run, an excluded run (grip slip), two spans on one specimen; its
dialects and units are drawn from the seed.

Each layout is a dict: ``name``, ``specimens`` (study.toml entries),
``truth`` (parameters per specimen, SI), ``torsion_law`` and ``specs``.
"""

from __future__ import annotations

import math

import numpy as np

from .files import Dialect, TestSpec
from .forward import cycles, ramp

DEG = math.pi / 180.0
MT = 1e-3
MM = 1e-3


def _truth(E_b: float, E_t: float, E_e: float, E_s: float, k2: float, eta: float) -> dict[str, float]:
    """One specimen's parameters; the SLS's k1 is E_e (physics.md section 1)."""
    return {"E_b": E_b, "E_t": E_t, "E_e": E_e, "E_s": E_s, "sls_k1": E_e, "sls_k2": k2, "sls_eta": eta}


#: Ground truth of the demo (SI): E_b = EI and E_t = GJ [N m^2], E_e = EA and E_s = kGA [N],
#: SLS k1, k2 [N], eta [N s]. E_s = k(nu) A E_t / J with Hutchinson's k (physics.md section 7):
#: T1 at its stated poisson_ratio 0.42, T2 at nu = 0.4 (its study entry states none).
DEMO_TRUTH = {
    "T1": _truth(6.5e-5, 4.4e-5, 120.0, 26.31, k2=90.0, eta=450.0),  # tau = 5 s
    "T2": _truth(9.0e-5, 6.5e-5, 190.0, 47.9, k2=114.0, eta=1368.0),  # tau = 12 s
}
ALT_TRUTH = {
    "P-01": _truth(8.0e-5, 5.4e-5, 150.0, 16.0, k2=135.0, eta=405.0),  # tau = 3 s
    "P-02": _truth(5.2e-5, 3.8e-5, 105.0, 12.0, k2=58.0, eta=1044.0),  # tau = 18 s
}

#: Torsion beyond the linear range (forward.torsion_torque): onset and scale in rad/m.
DEMO_TORSION = {"form": "softening", "sign": -1.0, "onset": 60.0, "scale": 150.0}
ALT_TORSION = {"form": "stiffening", "sign": 1.0, "onset": 70.0, "scale": 150.0}

MOMENT = 0.0125  # A m^2, tip magnet of the demo
UNITS_ROW = Dialect(units="row")
PARENS = Dialect(units="parens")
SEMICOLON = Dialect(delimiter=";", decimal=",")


def _extension(sid, run, history, description, columns, dialect, *, preamble="short", note=""):
    return TestSpec(
        kind="extension", specimen=sid, file=f"extension_{sid}_{run}.csv",
        setup={"gauge_length": 50 * MM, "history": history, "samples": 201},
        toml={"gauge_length": "50 mm"}, columns=columns, description=description,
        dialect=dialect, preamble=preamble, note=note,
    )  # fmt: skip


def _bending(sid, mm, field, psi, columns, dialect, *, torque_column=False):
    steps = "field_angle stepped" if np.ptp(psi) > 0 else "field stepped"
    toml = {"free_length": f"{mm} mm"}
    if not torque_column:
        toml["magnet_moment"] = "0.0125 A m^2"
    return TestSpec(
        kind="magnetic_bending", specimen=sid, file=f"bending_{sid}_L{mm}.csv",
        setup={"free_length": mm * MM, "moment": MOMENT, "field": field, "field_angle": psi},
        toml=toml, columns=columns, dialect=dialect,
        description=f"tip magnet 0.0125 A m^2, free length {mm} mm, {steps}",
    )  # fmt: skip


def _torsion(sid, mm, columns, dialect):
    return TestSpec(
        kind="torsion", specimen=sid, file=f"torsion_{sid}_L{mm}.csv",
        setup={"length": mm * MM, "twist_angle": np.linspace(0.0, 180.0, 25) * DEG},
        toml={"length": f"{mm} mm"}, columns=columns, dialect=dialect,
        description=f"tube length {mm} mm, twisted 0..180 deg in 7.5 deg steps",
    )  # fmt: skip


#: The demo's three-point-bend rig: set-up (SI) and its study.toml keys.
BEND_RIG = {"span": 10 * MM, "specimen_length": 30 * MM, "support_radius": 2 * MM, "nose_radius": 2 * MM}
BEND_TOML = {"span": "10 mm", "specimen_length": "30 mm", "support_radius": "2 mm", "nose_radius": "2 mm"}


def _three_point(sid, columns, dialect, *, preamble="short"):
    return TestSpec(
        kind="three_point_bend", specimen=sid, file=f"3pb_{sid}_S10.csv",
        setup={**BEND_RIG, "d_max": 1 * MM, "n_load": 30, "n_unload": 8, "rate": 0.02 * MM},
        toml=BEND_TOML, columns=columns, dialect=dialect, preamble=preamble,
        description="span 10 mm, nose 0..1 mm at 0.02 mm/s (30 loading rows), 8 unloading rows",
    )  # fmt: skip


def _centreline(sid, columns, dialect):
    """A bend whose deflection is the tube's mid-span centreline relative to the supports (video/DIC)."""
    return TestSpec(
        kind="three_point_bend", specimen=sid, file=f"3pb_{sid}_S10_centreline.csv",
        setup={**BEND_RIG, "d_max": 0.3 * MM, "n_load": 30, "n_unload": 0, "rate": 0.01 * MM,
               "deflection_at": "centreline"},
        toml={**BEND_TOML, "deflection_at": "centreline"}, columns=columns, dialect=dialect,
        description="span 10 mm, centreline deflection by side camera 0..0.3 mm (30 rows), loading only",
    )  # fmt: skip


def demo_layout() -> dict:
    """The committed demo study; every choice here is fixed (the seed only sets the noise)."""
    t_f_e = (("time", "s"), ("force", "N"), ("elongation", "mm"))
    field = np.linspace(0.0, 40.0, 17) * MT
    psi90 = np.full(17, 90.0 * DEG)
    deg_field = (("tip_angle", "deg"), ("field", "mT"), ("field_angle", "deg"))
    specs = [
        _extension("T1", "r1", ramp(0.001, 0.05), "ramp 0.1 %/s to 5 % strain", t_f_e,
                   Dialect(), preamble="full"),
        _extension("T1", "r2", ramp(0.01, 0.05, hold=45.0),
                   "ramp 1 %/s to 5 % strain, hold 45 s", t_f_e, UNITS_ROW, preamble="none",
                   note="ramp-hold run: 1 %/s to 5 % strain, then held 45 s (stress relaxation)"),
        _extension("T1", "r3", ramp(0.1, 0.05), "ramp 10 %/s to 5 % strain",
                   (("time", "s"), ("force", "N"), ("strain", "%")), PARENS),
        _bending("T1", 30, field, psi90, deg_field, Dialect()),
        _bending("T1", 45, field, psi90, deg_field, PARENS),
        _bending("T1", 60, field, psi90, (("tip_angle", "deg"), ("torque", "mN m")), Dialect(),
                 torque_column=True),
        _torsion("T1", 60, (("twist_angle", "deg"), ("torque", "mN mm")), Dialect()),
        _torsion("T1", 26, (("twist_angle", "rad"), ("torque", "dyn cm")), Dialect()),
        _three_point("T1", (("deflection", "mm"), ("force", "N")), Dialect(), preamble="full"),
        _centreline("T1", (("time", "s"), ("deflection", "um"), ("force", "mN")), Dialect()),
        _extension("T2", "r1", ramp(0.001, 0.05), "ramp 0.1 %/s to 5 % strain", t_f_e, SEMICOLON),
        _extension("T2", "r2", ramp(0.01, 0.05), "ramp 1 %/s to 5 % strain",
                   (("time", "s"), ("force", "dyn"), ("strain", "%")), Dialect()),
        _extension("T2", "r3", ramp(0.1, 0.05), "ramp 10 %/s to 5 % strain", t_f_e,
                   Dialect(units="row_parens"), preamble="none"),
        _bending("T2", 30, field, psi90, (("tip_angle", "rad"), ("field", "G"),
                                          ("field_angle", "deg")), Dialect()),
        _bending("T2", 45, np.full(16, 30.0 * MT), np.linspace(0.0, 150.0, 16) * DEG,
                 deg_field, PARENS),
        _bending("T2", 60, field, psi90, deg_field[::-1], Dialect()),
        _torsion("T2", 60, (("twist_angle", "deg"), ("torque", "N mm")), PARENS),
        _torsion("T2", 26, (("twist_angle", "deg"), ("torque", "mN m")), Dialect()),
        _three_point("T2", (("index", ""), ("time", "s"), ("deflection", "mm"), ("force", "N")),
                     Dialect()),
    ]  # fmt: skip
    return {
        "name": "SYNTHETIC demo: Pebax-like catheter tubes T1, T2 (matid example)",
        "specimens": [
            {"id": "T1", "outer_diameter": "2.4 mm", "inner_diameter": "1.6 mm", "poisson_ratio": 0.42},
            {"id": "T2", "outer_diameter": "2.2 mm", "inner_diameter": "1.4 mm"},
        ],
        "truth": DEMO_TRUTH,
        "torsion_law": DEMO_TORSION,
        "specs": specs,
    }


#: CSV dialects of the alt study, dealt to its files in a seeded order.
ALT_DIALECTS = (
    Dialect(delimiter="\t"),
    Dialect(delimiter=";", decimal=",", units="row", names="title", encoding="utf-8-sig",
            newline="\r\n"),
    Dialect(units="parens", names="spaced", encoding="latin-1", newline="\r\n",
            trailing_blank_lines=2, degree_sign=True),
    Dialect(delimiter="\t", units="row_parens", names="upper", micro_sign=True),
    Dialect(delimiter=";", decimal=",", names="upper", encoding="latin-1", degree_sign=True,
            micro_sign=True),
    Dialect(names="title", encoding="utf-8-sig", trailing_blank_lines=1),
)  # fmt: skip

#: Units the alt study draws from, per quantity (and per kind for force).
ALT_UNITS = {
    "time": ("s", "ms", "min"),
    "force": ("N", "mN", "kN", "gf", "dyn"),
    "bend_force": ("N", "mN", "gf"),
    "elongation": ("mm", "um", "cm"),
    "strain": ("%", "1"),
    "tip_angle": ("deg", "rad"),
    "field_angle": ("deg", "rad"),
    "twist_angle": ("deg", "rad"),
    "field": ("mT", "T", "G"),
    "torque": ("N m", "mN m", "N mm", "mN mm", "dyn cm"),
    "deflection": ("mm", "um"),
}


def _alt_columns(kind: str, rng: np.random.Generator, *, cycle=False, torque=False) -> tuple:
    """Columns of an alt file with units drawn from ALT_UNITS (in a fixed draw order)."""
    pick = {q: str(rng.choice(ALT_UNITS[q])) for q in ALT_UNITS}
    if kind == "extension":
        stretch = "strain" if rng.random() < 0.5 else "elongation"
        cols = [("time", pick["time"]), (stretch, pick[stretch]), ("force", pick["force"])]
        return tuple(([("cycle", "")] if cycle else []) + cols)
    if kind == "magnetic_bending":
        if torque:
            return (("torque", pick["torque"]), ("tip_angle", pick["tip_angle"]))
        return (("field", pick["field"]), ("field_angle", pick["field_angle"]),
                ("tip_angle", pick["tip_angle"]))  # fmt: skip
    if kind == "torsion":
        return (("time", pick["time"]), ("torque", pick["torque"]),
                ("twist_angle", pick["twist_angle"]))  # fmt: skip
    return (("deflection", pick["deflection"]), ("force", pick["bend_force"]))


def _alt_tests(sid: str) -> list[dict]:
    """The alt tests of one specimen, before dialects and units are dealt."""
    ext = {"gauge_length": 40 * MM}
    gauge = {"P-01": "4 cm", "P-02": 0.04}[sid]
    tests = [
        dict(kind="extension", file=f"raw/{sid} pull slow.csv", toml={"gauge_length": gauge},
             setup={**ext, "history": ramp(0.0005, 0.04), "samples": 161},
             description="ramp 0.05 %/s to 4 % strain"),
        dict(kind="extension", file=f"raw/{sid} pull cycles.csv", toml={"gauge_length": gauge},
             setup={**ext, "history": cycles(0.005, 0.03, 2, eps_min=0.015),
                    "samples": 181},
             description="ramp 0 -> 3 %, then 3 -> 1.5 -> 3 -> 1.5 % strain, all at 0.5 %/s",
             cycle=True),
        dict(kind="extension", file=f"raw/{sid} pull fast.csv", toml={"gauge_length": gauge},
             setup={**ext, "history": ramp(0.05, 0.04), "samples": 161},
             description="ramp 5 %/s to 4 % strain"),
    ]  # fmt: skip
    if sid == "P-01":
        # The grip slips at 2.5 % strain: the specimen loses 1 % strain in 0.1 s while
        # the crosshead (the elongation column) keeps moving.
        slip = (np.array([0.0, 5.0, 5.1, 8.0]), np.array([0.0, 0.025, 0.015, 0.0295]))
        tests.append(dict(
            kind="extension", file=f"raw/{sid} pull slipped.csv", toml={"gauge_length": gauge},
            setup={**ext, "history": ramp(0.005, 0.04), "specimen_history": slip, "samples": 161},
            description="ramp 0.5 %/s to 4 % strain; grip slipped at 2.5 %", exclude=True,
            note="grip slipped at about 2.5 % strain (force drop); kept for the record",
        ))  # fmt: skip
    field = np.linspace(0.0, 30.0, 16) * MT
    moments = [(25, "2.5 cm", "20 emu"), (40, "40 mm", 0.02), (55, 0.055, "0.02 A m^2")]
    for mm, length, moment in moments:
        torque = sid == "P-02" and mm == 40
        stepped = sid == "P-01" and mm == 40
        psi = np.linspace(-150.0, 150.0, 16) * DEG if stepped else np.full(16, 120.0 * DEG)
        tests.append(dict(
            kind="magnetic_bending", file=f"raw/{sid}_magbend_{mm}mm.csv", torque=torque,
            toml={"free_length": length} | ({} if torque else {"magnet_moment": moment}),
            setup={"free_length": mm * MM, "moment": 0.02,
                   "field": np.full(16, 25.0 * MT) if stepped else field, "field_angle": psi},
            description=f"tip magnet 0.02 A m^2, free length {mm} mm"))  # fmt: skip
    for mm, length in [(80, "8 cm"), (20, "20 mm")]:
        tests.append(dict(
            kind="torsion", file=f"raw/{sid}_twist_{mm}mm.csv", toml={"length": length},
            setup={"length": mm * MM, "twist_angle": np.linspace(-180.0, 180.0, 25) * DEG},
            description=f"tube length {mm} mm, twisted -180..180 deg"))  # fmt: skip
    for span in [12, 8] if sid == "P-01" else [12]:
        tests.append(dict(
            kind="three_point_bend", file=f"raw/{sid}_3pt_span{span}.csv",
            toml={"span": f"{span} mm", "specimen_length": "4 cm", "support_radius": "3 mm",
                  "nose_radius": "5 mm"},
            setup={"span": span * MM, "specimen_length": 40 * MM, "support_radius": 3 * MM,
                   "nose_radius": 5 * MM, "d_max": span * 0.1 * MM, "n_load": 24, "n_unload": 6,
                   "rate": 0.05 * MM},
            description=f"span {span} mm, nose to 10 % of span, then unloading"))  # fmt: skip
    return tests


def alt_layout(rng: np.random.Generator) -> dict:
    """The alt study: dialects dealt round-robin in a seeded order, units drawn per file."""
    raw = [dict(t, specimen=sid) for sid in ALT_TRUTH for t in _alt_tests(sid)]
    order = rng.permutation(len(ALT_DIALECTS))
    specs = []
    for i, t in enumerate(raw):
        columns = _alt_columns(t["kind"], rng, cycle=t.get("cycle", False),
                               torque=t.get("torque", False))  # fmt: skip
        specs.append(TestSpec(
            kind=t["kind"], specimen=t["specimen"], file=t["file"], setup=t["setup"],
            toml=t["toml"], columns=columns, description=t["description"],
            dialect=ALT_DIALECTS[order[i % len(ALT_DIALECTS)]],
            preamble=str(rng.choice(["none", "short", "full"])),
            note=t.get("note", ""), exclude=t.get("exclude", False)))  # fmt: skip
    return {
        "name": "SYNTHETIC alt study: braided tubes P-01, P-02 (matid test fixture)",
        "specimens": [
            {"id": "P-01", "outer_diameter": "0.28 cm", "inner_diameter": "2.0 mm"},
            {"id": "P-02", "outer_diameter": 0.002, "inner_diameter": "1200 um"},
        ],
        "truth": ALT_TRUTH,
        "torsion_law": ALT_TORSION,
        "specs": specs,
    }
