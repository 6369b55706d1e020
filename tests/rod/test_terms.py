"""The rod's loads as terms (matid.rod.terms): a scene builds only the terms it has, and the system
sums exactly those."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matid.rod.bend import BendGeometry, BendModel
from matid.rod.cantilever import mesh, prepare_scene
from matid.rod.models import PLANAR
from matid.rod.scenes import load_scene, scene_from_dict
from matid.rod.system import RodSystem
from matid.rod.terms import (
    LOADS,
    Contact,
    DistributedForce,
    Magnetisation,
    Magnets,
    Nose,
    PointLoads,
    Support,
    Tip,
    UnityGauge,
)

SCENES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
ROD = {"length": "30 mm", "E_b": 1e-4, "E_t": 1e-4, "E_s": 10, "E_e": 10}


def _system(scene) -> RodSystem:
    chosen, _, rod, loads, at = prepare_scene(scene, "auto")
    disc = mesh(4, at, 3 if chosen == PLANAR else 7, "P2", 2)
    return RodSystem(disc, rod, loads, model=chosen)


def _types(system: RodSystem) -> list[type]:
    return [type(term) for term, _ in system.distributed + system.nodal + system.constraints]


def test_a_scene_without_magnets_builds_no_magnetic_term() -> None:
    system = _system(load_scene(SCENES / "tip_force.toml"))
    assert _types(system) == [Tip]
    assert "magnetic" not in system.terms


def test_a_magnetised_scene_builds_its_magnetic_term() -> None:
    system = _system(load_scene(SCENES / "magnetic_cantilever.toml"))
    assert _types(system) == [Magnetisation]
    assert "magnetic" in system.terms


def test_magnets_without_a_field_build_no_term() -> None:
    scene = scene_from_dict({"rod": ROD, "magnet": [{"at": "30 mm", "moment": "0.01 A m^2"}]})
    assert _types(_system(scene)) == []


def test_every_load_and_the_gauge_of_the_full_model() -> None:
    raw = {
        "rod": ROD,
        "field": {"B": ["10 mT", "0 mT", "5 mT"]},
        "magnet": [{"at": "30 mm", "moment": "0.01 A m^2"}],
        "magnetization": [{"from": "0 mm", "to": "10 mm", "per_length": "1 A"}],
        "load": {"distributed_force": ["0 N/m", "1 N/m", "0 N/m"]},  # out of the field's plane: 3D
        "tip": {"force": ["0.01 N", "0 N", "0 N"]},
        "point_load": [{"at": "15 mm", "force": ["0.01 N", "0 N", "0 N"]}],
        "wall": [{"point": ["-20 mm", "0 mm", "0 mm"], "normal": [1, 0, 0]}],
    }
    system = _system(scene_from_dict(raw))
    assert system.model != PLANAR
    assert _types(system) == [Magnetisation, DistributedForce, Tip, Magnets, PointLoads, Contact, UnityGauge]
    assert set(LOADS) <= set(_types(system))
    assert system.terms == [
        "bending", "shear", "extension", "twist", "unity penalty", "magnetic", "point loads", "contact"
    ]  # fmt: skip


@pytest.mark.parametrize(
    "name", ["tip_force", "magnetic_cantilever", "point_load", "magnet_direction", "magnetization_direction"]
)
def test_the_residual_is_the_sum_of_the_terms(name: str) -> None:
    """R(U) of the system = R of the strain energy alone + each term's share, summed separately."""
    scene = load_scene(SCENES / f"{name}.toml")
    system = _system(scene)
    rng = np.random.default_rng(5)
    X = system.reduce(system.reference() + 0.05 * rng.standard_normal(system.disc.n))
    R = system.evaluate(X, 0.8, tangent=False)[0]
    bare = RodSystem(system.disc, system.rod, (), model=system.model)
    R0 = bare.evaluate(X, 0.8, tangent=False)[0]
    assert system.loads
    shares = []
    for term in system.loads:
        alone = RodSystem(system.disc, system.rod, (term,), model=system.model)
        shares.append(alone.evaluate(X, 0.8, tangent=False)[0] - R0)
        assert np.max(np.abs(shares[-1])) > 0, type(term).__name__  # each term does something
    assert np.allclose(R, R0 + sum(shares), rtol=0, atol=1e-9 * max(1.0, np.max(np.abs(R))))


def _bend_system(scene):
    """The bend system of a three-point-bend scene, as matid.rod.api.solve_bend builds its model."""
    rod, bend = scene.rod, scene.bend
    geometry = BendGeometry(bend.span, rod.length, bend.support_radius, bend.nose_radius, rod.outer_diameter)
    return BendModel(geometry, elements=8).system(rod.E_b, rod.E_s, rod.E_e, max(bend.deflections))


def test_a_bend_scene_has_the_rigs_support_and_nose_terms_and_a_cantilever_has_not() -> None:
    system = _bend_system(load_scene(SCENES / "three_point_bend.toml"))
    assert [type(term) for term in system.loads] == [Support, Nose]
    assert all(term.kind == "multiplier" for term in system.loads)
    # the bend system sums them: each gap row of its residual is its term's -g at that state
    X = system.initial()
    U = system.rod.expand(X[: system.nu])
    R = system.evaluate(X, 0.5, tangent=False)[0]
    gaps = [term.gap(U, 0.5)[0] for term in system.loads]
    assert R[system.nu : system.nu + 2].tolist() == [-g for g in gaps]
    support, nose = system.loads  # the nose moves with the load factor, the support does not
    assert nose.gap(U, 0.0)[0] != gaps[1] and support.gap(U, 0.0)[0] == gaps[0]
    for name in ("tip_force", "magnetic_cantilever", "point_load"):
        cantilever = _system(load_scene(SCENES / f"{name}.toml"))
        assert not {Support, Nose} & {type(term) for term in cantilever.loads}
        assert not {Support, Nose} & set(_types(cantilever))
