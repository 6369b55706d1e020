"""Generate the SYNTHETIC demo study of matid (``matid.example``).

    python -m matid.example.generate [--out DIR] [--seed N] [--variant demo|alt]

writes ``study.toml``, one CSV per test and ``ground_truth.json`` into DIR
(default: this folder, i.e. it regenerates the committed demo). The data are
made from known stiffnesses by the forward models of
:mod:`matid.example.forward` plus seeded Gaussian noise:

- extension force: sd 0.3 % of the run's largest force; elongation: sd 1 um;
- magnetic bending tip angle: sd 0.15 deg (field and field angle are set
  points, exact; a torque column is computed from the measured tip angle,
  ``m B sin(psi - theta)``, as a lab would);
- torsion torque: sd 0.5 % of the largest torque (twist angle exact);
- three-point-bend force: sd 0.3 % of the largest force (deflection exact);
  unloading rows follow a curve up to 8 % lower (hysteresis). Nose travel
  includes the local contact travel of a real tube (``forward.contact_travel``,
  the 3D continuum's law), so a rod fit to it returns E_s too low, as on a real
  tube; centreline data are the rod's own.

Each file draws its noise from ``numpy.random.default_rng([seed, crc32(file)])``,
so editing one test leaves the others' noise unchanged; the alt variant draws
its dialects and units from ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import zlib
from pathlib import Path

import numpy as np

from .files import UNIT_SI, TestSpec, render_csv, render_toml
from .forward import (
    CONTACT_C,
    CONTACT_N,
    bend_centreline,
    bend_force_nose,
    sls_force,
    tip_angle,
    torsion_torque,
    unloading_force,
)
from .layouts import alt_layout, demo_layout

PARAMETER_UNITS = {
    "E_b": "N m^2", "E_t": "N m^2", "E_e": "N", "E_s": "N",
    "sls_k1": "N", "sls_k2": "N", "sls_eta": "N s",
}  # fmt: skip

NOISE = {
    "extension_force_rel_sd": 0.003,
    "elongation_sd_m": 1e-6,
    "tip_angle_sd_rad": 0.15 * math.pi / 180.0,
    "torsion_torque_rel_sd": 0.005,
    "bend_force_rel_sd": 0.003,
    "bend_unloading_hysteresis": 0.08,
}

GENERATOR = "data/example/generate.py"
VARIANTS = ("demo", "alt")


def simulate_extension(spec: TestSpec, p: dict, rng: np.random.Generator) -> dict:
    """SLS force for the crosshead history (or a separate specimen history, e.g. a slip)."""
    s = spec.setup
    knots_t, knots_eps = s["history"]
    t = np.linspace(0.0, knots_t[-1], s["samples"])
    spec_t, spec_eps = s.get("specimen_history", s["history"])
    force = sls_force(t, spec_t, spec_eps, k1=p["sls_k1"], k2=p["sls_k2"], eta=p["sls_eta"])
    force = force + rng.normal(0.0, NOISE["extension_force_rel_sd"] * np.max(np.abs(force)), t.size)
    elongation = np.interp(t, knots_t, knots_eps) * s["gauge_length"]
    elongation = elongation + rng.normal(0.0, NOISE["elongation_sd_m"], t.size)
    # forward.cycles: each valley knot (2, 4, ...; not the last) starts a new cycle
    cycle = 1 + np.searchsorted(knots_t[2:-1:2], t, side="right")
    return {"time": t, "force": force, "elongation": elongation,
            "strain": elongation / s["gauge_length"], "cycle": cycle}  # fmt: skip


def simulate_bending(spec: TestSpec, p: dict, rng: np.random.Generator) -> dict:
    s = spec.setup
    field, psi = s["field"], s["field_angle"]
    theta = tip_angle(field, psi, moment=s["moment"], length=s["free_length"], E_b=p["E_b"])
    theta = theta + rng.normal(0.0, NOISE["tip_angle_sd_rad"], theta.size)
    torque = s["moment"] * field * np.sin(psi - theta)
    return {"tip_angle": theta, "field": field, "field_angle": psi, "torque": torque}


def simulate_torsion(spec: TestSpec, p: dict, law: dict, rng: np.random.Generator) -> dict:
    s = spec.setup
    phi = s["twist_angle"]
    torque = torsion_torque(
        phi, length=s["length"], E_t=p["E_t"], onset=law["onset"], scale=law["scale"],
        sign=law["sign"],
    )  # fmt: skip
    torque = torque + rng.normal(0.0, NOISE["torsion_torque_rel_sd"] * np.max(np.abs(torque)),
                                 phi.size)  # fmt: skip
    return {"twist_angle": phi, "torque": torque, "time": 2.0 * np.arange(phi.size)}


def simulate_three_point(
    spec: TestSpec, p: dict, tube: tuple[float, float], rng: np.random.Generator
) -> dict:
    """Nose travel of a real tube: the rod model plus the local contact travel at the three
    contacts (``forward.bend_force_nose``; wall E = E_e / A); centreline data: the rod alone."""
    s = spec.setup
    d_max = s["d_max"]
    load = np.linspace(0.0, d_max, s["n_load"])
    unload = np.linspace(d_max, 0.2 * d_max, s["n_unload"] + 1)[1:]
    geometry = {k: s[k] for k in ("span", "specimen_length", "support_radius", "nose_radius")}
    outer, inner = tube
    stiff = {"E_b": p["E_b"], "E_s": p["E_s"], "E_e": p["E_e"], "outer_diameter": outer}

    if s.get("deflection_at") == "centreline":  # the tube's centreline, loading only
        centre, force = bend_centreline(load, **stiff, **geometry)
        force = force + rng.normal(0.0, NOISE["bend_force_rel_sd"] * np.max(force), force.size)
        return {"time": load / s["rate"], "deflection": centre, "force": force}

    E = p["E_e"] / (math.pi / 4 * (outer**2 - inner**2))

    def model(d: np.ndarray) -> np.ndarray:
        return bend_force_nose(d, inner_diameter=inner, E=E, **stiff, **geometry)

    force = np.concatenate([
        model(load),
        unloading_force(unload, model(unload), d_max=d_max,
                        hysteresis=NOISE["bend_unloading_hysteresis"]),
    ])  # fmt: skip
    force = force + rng.normal(0.0, NOISE["bend_force_rel_sd"] * np.max(force), force.size)
    deflection = np.concatenate([load, unload])
    path = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(deflection)))])
    return {"deflection": deflection, "force": force, "time": path / s["rate"],
            "index": np.arange(1, deflection.size + 1)}  # fmt: skip


def file_rng(seed: int, name: str) -> np.random.Generator:
    """The noise stream of one file: independent of the other files' set-ups."""
    return np.random.default_rng([seed, zlib.crc32(name.encode("utf-8"))])


def preamble(spec: TestSpec, variant: str, seed: int) -> list[str]:
    if spec.preamble == "none":
        return []
    lines = [
        f"synthetic: SYNTHETIC data, generated by {GENERATOR} "
        f"(variant {variant}, seed {seed}); not a measurement"
    ]
    if spec.preamble == "full":
        lines += [
            f"machine: virtual {spec.kind.replace('_', ' ')} rig (synthetic)",
            "operator: matid generator",
            "date: 2024-06-11",
            "temperature: 37 degC",
        ]
    return lines + [f"specimen: {spec.specimen}", f"test: {spec.description}"]


def merge_truth(defaults: dict, override: dict | None) -> dict:
    """Per-specimen parameters, with ``override["specimens"][id][param]`` replacing defaults.

    ``sls_k1`` is ``E_e`` (physics.md section 1): overriding one sets the other.
    """
    truth = copy.deepcopy(defaults)
    if not override:
        return truth
    unknown = set(override) - {"specimens"}
    if unknown:
        raise ValueError(f"truth: unknown key {sorted(unknown)[0]!r} (expected 'specimens')")
    for sid, params in override["specimens"].items():
        if sid not in truth:
            raise ValueError(f"truth: unknown specimen {sid!r} (one of {', '.join(truth)})")
        for name, value in params.items():
            if name not in PARAMETER_UNITS:
                raise ValueError(f"truth: unknown parameter {name!r} for specimen {sid!r}")
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"truth: {sid}.{name} must be positive, got {value!r}")
            truth[sid][name] = float(value)
        for a, b in (("E_e", "sls_k1"), ("sls_k1", "E_e")):
            if a in params and b not in params:
                truth[sid][b] = truth[sid][a]
        if truth[sid]["E_e"] != truth[sid]["sls_k1"]:
            raise ValueError(f"truth: {sid}: sls_k1 must equal E_e")
    return truth


def _simulate(spec: TestSpec, params: dict, layout: dict, tube: tuple[float, float], seed: int) -> dict:
    rng = file_rng(seed, spec.file)
    if spec.kind == "extension":
        return simulate_extension(spec, params, rng)
    if spec.kind == "magnetic_bending":
        return simulate_bending(spec, params, rng)
    if spec.kind == "torsion":
        return simulate_torsion(spec, params, layout["torsion_law"], rng)
    return simulate_three_point(spec, params, tube, rng)


def _jsonable(value: object) -> object:
    """``value`` as ground_truth.json holds it: numpy arrays and tuples as lists, numpy scalars as numbers."""
    return json.loads(json.dumps(value, default=lambda array: array.tolist()))


def _test_record(spec: TestSpec, law: dict) -> dict:
    record = {"file": spec.file, "kind": spec.kind, "specimen": spec.specimen,
              "description": spec.description, "exclude": spec.exclude,
              "columns": [f"{q} [{u}]" if u else q for q, u in spec.columns],
              "setup_si": _jsonable(spec.setup)}  # fmt: skip
    if spec.kind == "torsion":
        # Points with |twist_angle| <= this are in the linear range (torsion_law.onset * length).
        record["linear_range_max_twist_rad"] = law["onset"] * spec.setup["length"]
    return record


def _ground_truth(layout: dict, truth: dict, variant: str, seed: int) -> dict:
    law = layout["torsion_law"]
    return {
        "synthetic": True,
        "study": layout["name"],
        "generator": GENERATOR,
        "variant": variant,
        "seed": seed,
        "units": PARAMETER_UNITS,
        "specimens": truth,
        "relaxation_time_s": {sid: p["sls_eta"] / p["sls_k2"] for sid, p in truth.items()},
        "torsion_law": {**law, "unit": "rad/m", "formula":
                        "tau = E_t (k + sign sgn(k) max(|k| - onset, 0)^2 / (2 scale)), k = phi/L"},
        "three_point_bend_model": "strong-form shooting of the planar Reissner rod with shear and "
                                  "extension, sliding contact (matid.example.bend_shooting; "
                                  "not the model the fit uses)",
        "three_point_bend_contact": "nose travel = rod deflection + local contact travel "
                                    f"{1e3 * CONTACT_C:g} mm (F/N * 50 MPa/E)^{CONTACT_N:g} "
                                    "* (R_m/1 mm)^1.5 (0.4 mm/t)^2.5 (forward.contact_travel)",
        "noise": NOISE,
        "tests": [_test_record(spec, law) for spec in layout["specs"]],
    }  # fmt: skip


def generate(out: Path, *, seed: int = 2611, variant: str = "demo", truth: dict | None = None) -> dict:
    """Write the SYNTHETIC study ``variant`` into ``out``; return its ground truth.

    ``truth`` optionally overrides stiffnesses, shaped like the returned dict:
    ``{"specimens": {"T1": {"E_b": 7e-5}}}``. Writes ``study.toml``, the CSV files
    and ``ground_truth.json``; other files in ``out`` are left alone.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {', '.join(VARIANTS)}, got {variant!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"out must be a folder, got the file {out}")
    layout = demo_layout() if variant == "demo" else alt_layout(np.random.default_rng(seed))
    params = merge_truth(layout["truth"], truth)
    tube = {
        s["id"]: (_diameter(s["outer_diameter"]), _diameter(s["inner_diameter"])) for s in layout["specimens"]
    }
    files: dict[str, bytes] = {}
    for spec in layout["specs"]:
        data = _simulate(spec, params[spec.specimen], layout, tube[spec.specimen], seed)
        files[spec.file] = render_csv(spec, data, preamble(spec, variant, seed))
    comment = (f"SYNTHETIC study written by {GENERATOR} (variant {variant}, seed {seed}).\n"
               "Do not edit by hand: regenerate. Ground truth: ground_truth.json.")  # fmt: skip
    head = {"name": layout["name"], "temperature": "37 degC"}
    files["study.toml"] = render_toml(head, layout["specimens"], layout["specs"], comment).encode()
    result = _ground_truth(layout, params, variant, int(seed))
    files["ground_truth.json"] = (json.dumps(result, indent=2) + "\n").encode()
    for name, content in files.items():
        path = out / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content)
    return result


def _diameter(value: object) -> float:
    """A diameter in m from a layout entry ("2.4 mm", "0.28 cm" or a bare SI number)."""
    if isinstance(value, (int, float)):
        return float(value)
    number, unit = str(value).split()
    return float(number) * UNIT_SI[unit]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m matid.example.generate",
        description="Write the SYNTHETIC matid demo study (study.toml, CSVs, ground_truth.json).",
    )
    parser.add_argument(
        "--out", type=Path, help="output folder (default: the package folder, demo variant only)"
    )
    parser.add_argument("--seed", type=int, default=2611, help="noise seed (default 2611)")
    parser.add_argument("--variant", choices=VARIANTS, default="demo")
    args = parser.parse_args(argv)
    if args.out is None:
        if args.variant != "demo":
            parser.error("--out is required for --variant alt")
        args.out = Path(__file__).resolve().parent
    if args.seed < 0:
        parser.error("--seed must be non-negative")
    truth = generate(args.out, seed=args.seed, variant=args.variant)
    print(f"wrote {len(truth['tests'])} tests of {truth['study']!r} to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
