"""The registry of test kinds (issue 27): each kind declared once, by its own fits module, and read
by the study loader, ingest, the pipeline, the CLI and the report."""

from __future__ import annotations

import ast
import sys

import pytest

from matid.fits.kinds import BY_NAME, KINDS
from matid.model.kind import Kind
from matid.model.study import PARAMETERS
from tests import ROOT

#: Where a kind's name may stand as a literal besides its declaring module: the demo's generator,
#: and the rod and its bench, whose *scene* kind ``three_point_bend`` is not the test kind.
ELSEWHERE = ("matid/example/", "matid/rod/", "matid/bench/")
#: A word that is also a kind's name: a test machine's header word for the elongation column.
HEADER_WORDS = {("matid/io/ingest/spaced.py", "extension")}


def test_each_kind_is_listed_once_and_the_bend_comes_after_the_stiffnesses_it_holds():
    names = [k.name for k in KINDS]
    assert len(set(names)) == len(names) == len(BY_NAME)
    position = {p: names.index(k.name) for k in KINDS for p in k.parameters}
    assert position["E_e"] < position["E_s"] and position["E_b"] < position["E_s"]


def test_every_parameter_a_study_may_fix_is_given_by_a_kind():
    assert set(PARAMETERS) <= {p for k in KINDS for p in k.parameters}


def test_a_kind_requires_only_its_own_columns_and_gives_only_known_parameters():
    with pytest.raises(ValueError, match="column 'strain' is not one of its columns"):
        Kind("x", "X", {"force": "force"}, (("strain",),), {}, ("E_e",), fit=print)
    with pytest.raises(ValueError, match="unknown parameter 'E_z'"):
        Kind("x", "X", {"force": "force"}, (("force",),), {}, ("E_z",), fit=print)
    kind = Kind("x", "X", {"force": "force"}, (("force",),), {"span": "length"}, ("E_s",), fit=print,
                options=("deflection_at",))  # fmt: skip
    assert kind.gives == ("E_s",) and kind.test_keys == ("span", "deflection_at")
    with pytest.raises(TypeError):
        kind.columns["time"] = "time"  # a declaration is read-only


def test_extension_needs_elongation_or_strain():
    assert BY_NAME["extension"].required[2] == ("elongation", "strain")


def test_no_module_names_a_kind_but_the_one_that_declares_it():
    """The CLI, the pipeline, the study loader, ingest and the report read the registry."""
    owner = {k.name: sys.modules[k.fit.__module__].__file__ for k in KINDS}
    found = []
    for path in sorted((ROOT / "matid").rglob("*.py")):
        relative = path.relative_to(ROOT).as_posix()
        if relative.startswith(ELSEWHERE):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (
                not (isinstance(node, ast.Constant) and node.value in owner)
                or (relative, node.value) in HEADER_WORDS
            ):
                continue
            if str(path) != owner[node.value]:
                found.append(f"{relative}:{node.lineno} names {node.value!r}")
    assert not found, "\n".join(found)
