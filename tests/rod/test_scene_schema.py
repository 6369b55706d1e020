"""Issue 30: one schema (matid/rod/schema.py) for the scene format; docs/scenes.md and the scene checks
are both made from it, and every example scene uses only keys it has."""

from __future__ import annotations

import copy
import importlib
import tomllib

import pytest

from matid.errors import DataError
from matid.rod import schema
from matid.rod.scene_docs import reference
from matid.rod.scenes import scene_from_dict
from matid.rod.terms import LOADS
from tests import ROOT

EXAMPLES = sorted((ROOT / "examples" / "scenes").glob("*.toml"))
ROD = {"length": "30 mm", "E_b": "6.5e-5 N m^2", "E_t": "4.4e-5 N m^2", "E_s": "21 N", "E_e": "120 N",
       "outer_diameter": "2.4 mm"}  # fmt: skip


def test_docs_scenes_md_is_what_the_schema_writes():
    page = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    assert page == reference(), "run: PYTHONPATH=$PWD python docs/make_scenes.py"


def unknown_keys(doc: dict) -> list[str]:
    """Every key of a scene document that the schema does not have, as table.key."""
    out = [k for k in doc if k not in schema.SCENE_KEYS]
    for name, value in doc.items():
        if name not in schema.TABLE_KEYS:
            continue
        for entry in value if isinstance(value, list) else [value]:
            for key, inner in entry.items():
                if key not in schema.TABLE_KEYS[name]:
                    out.append(f"{name}.{key}")
                elif isinstance(inner, dict):
                    spec = schema.key(name, key)
                    out += [f"{name}.{key}.{k}" for k in inner if k not in spec.fields]
    return out


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_key_of_every_example_scene_is_in_the_schema(path):
    doc = tomllib.loads(path.read_text(encoding="utf-8"))
    assert unknown_keys(doc) == []


def test_no_example_sends_readers_to_a_section_not_in_the_project():
    for path in EXAMPLES:
        text = path.read_text(encoding="utf-8")
        assert "contract section 9" not in text and "physics.md section 8" not in text, path.name


def test_the_keys_the_readme_advertises_are_documented():
    page = reference()
    for needed in ("`direction`", "## [[point_load]]", "## [aim]", "`tip_direction`", "`allow_outside`"):
        assert needed in page


@pytest.mark.parametrize("table", schema.TABLES, ids=lambda t: t.title)
def test_each_tables_example_is_a_valid_table_of_known_keys(table):
    text = table.example or "\n".join(f"{k.name} = {k.example}" for k in table.keys)
    if table.name and not table.example:
        text = (f"[[{table.name}]]\n" if table.array else f"[{table.name}]\n") + text
    doc = tomllib.loads(text)
    assert unknown_keys(doc) == []
    keys = set(doc[table.name][0] if table.array else doc.get(table.name, doc)) if table.name else set(doc)
    # a whole-table example shows one way to write the table (sweep: values or from/to/count): it
    # holds the required keys; the keys' own examples, put together, hold every key
    shown = {k.name for k in table.keys if k.type != "table" and (not table.example or k.default is None)}
    assert keys >= shown


def test_every_load_term_the_schema_names_exists_and_every_load_term_is_named():
    named = set()
    for table in schema.TABLES:
        for term in table.terms:
            module, cls = term.rsplit(".", 1)
            named.add(getattr(importlib.import_module(module), cls))
    assert named == set(LOADS)


def base(table: str) -> dict:
    """A valid scene holding ``table`` (from the schema's examples)."""
    doc = {"rod": dict(ROD)}
    if table == "three_point_bend":
        doc["scene"] = "three_point_bend"
    if table == "aim":
        doc["magnet"] = [{"at": "30 mm", "moment": "0.0125 A m^2"}]
    spec = schema.BY_NAME[table]
    if table not in ("", "rod"):
        entry = {k.name: tomllib.loads(f"x = {k.example}")["x"] for k in spec.keys}
        doc[table] = [entry] if spec.array else entry
    return doc


BOUNDED = [(t.name, k) for t in schema.TABLES if t.name for k in t.keys
           if k.bounds is not None and k.type in ("quantity", "vector")]  # fmt: skip


@pytest.mark.parametrize("table, spec", BOUNDED, ids=lambda x: getattr(x, "name", x))
def test_every_bound_of_the_schema_is_what_validation_refuses(table, spec):
    doc = base(table)
    scene_from_dict(copy.deepcopy(doc))  # the example itself is fine
    low, high = spec.bounds
    past = [high * 1.5, 0.0, 0.0] if spec.type == "vector" else high * 1.5
    target = doc[table][0] if isinstance(doc[table], list) else doc[table]
    target[spec.name] = past
    with pytest.raises(DataError, match=spec.name):
        scene_from_dict(doc)
