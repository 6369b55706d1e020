"""Standard parts, one code path (issue 19): what matid's source may not contain.

Read from the source with :mod:`ast`, so each check fails on the first offending line and names it.
"""

from __future__ import annotations

import ast
import sys

import pytest

from tests import ROOT

PACKAGE = ROOT / "matid"
SOURCES = sorted(PACKAGE.rglob("*.py"))
#: Dependencies whose private names matid must not use (style.md: public APIs only).
DEPENDENCIES = {
    "numpy", "scipy", "pandas", "matplotlib", "skfem", "lmfit", "pint", "jinja2", "reportlab",
    "openpyxl", "charset_normalizer", "tqdm", "PIL", "dask", "distributed",
}  # fmt: skip
#: A second code path or a process trick (issue 19: no numba twin, no hand-made fork or gc freezing).
FORBIDDEN_CALLS = {("os", "fork"), ("gc", "freeze"), ("gc", "unfreeze")}


def parsed():
    for path in SOURCES:
        yield path.relative_to(ROOT), ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def dependency_aliases(tree: ast.AST) -> dict[str, str]:
    """Local names bound to a dependency's module (``import numpy as np`` -> {'np': 'numpy'})."""
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] in DEPENDENCIES:
                    names[alias.asname or alias.name.split(".")[0]] = alias.name
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] in DEPENDENCIES:
                for alias in node.names:
                    names[alias.asname or alias.name] = f"{node.module}.{alias.name}"
    return names


def test_sources_are_found():
    assert len(SOURCES) > 50


def test_no_private_name_of_a_dependency_is_imported_or_used():
    found = []
    for path, tree in parsed():
        aliases = dependency_aliases(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                top = node.module.split(".")[0]
                parts = node.module.split(".") + [a.name for a in node.names]
                if top in DEPENDENCIES and any(private(p) for p in parts):
                    found.append(f"{path}:{node.lineno} from {node.module} import ...")
            elif isinstance(node, ast.Import):
                names = [a.name.split(".") for a in node.names]
                if any(n[0] in DEPENDENCIES and any(map(private, n)) for n in names):
                    found.append(f"{path}:{node.lineno} import of a private module")
            elif isinstance(node, ast.Attribute) and private(node.attr):
                base = node.value
                while isinstance(base, ast.Attribute):
                    base = base.value
                if isinstance(base, ast.Name) and base.id in aliases:
                    found.append(f"{path}:{node.lineno} {base.id}...{node.attr} ({aliases[base.id]})")
    assert not found, "private names of dependencies:\n" + "\n".join(found)


def test_no_numba_and_no_process_tricks():
    found = []
    for path, tree in parsed():
        for node in ast.walk(tree):
            if isinstance(node, ast.Import | ast.ImportFrom):
                modules = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module]
                if any((m or "").split(".")[0] == "numba" for m in modules):
                    found.append(f"{path}:{node.lineno} imports numba")
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                base = node.func.value
                if isinstance(base, ast.Name) and (base.id, node.func.attr) in FORBIDDEN_CALLS:
                    found.append(f"{path}:{node.lineno} {base.id}.{node.func.attr}()")
    assert not found, "\n".join(found)


def test_the_layout_keeps_at_most_eight_top_level_modules():
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(top) <= 8, top
    layers = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert {"physics", "rod", "fits", "io", "report", "app", "bench", "example"} <= layers


def test_physics_imports_numpy_only():
    """The bottom layer (style.md): the paper's equations in numpy, nothing of matid above it."""
    found = []
    for path, tree in parsed():
        if path.parts[:2] != ("matid", "physics"):
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                module = node.module
            elif isinstance(node, ast.Import):
                module = node.names[0].name
            else:
                continue
            top = module.split(".")[0]
            allowed = top in {"numpy", "__future__"} or top in sys.stdlib_module_names
            allowed |= module.startswith(("matid.physics", "matid.errors"))
            if not allowed:
                found.append(f"{path}:{node.lineno} imports {module}")
    assert not found, "\n".join(found)


@pytest.mark.parametrize("name", ["lmfit", "reportlab", "skfem"])
def test_the_named_stack_is_used(name):
    """The user's stack is used, not only listed: some matid module imports it."""
    imported = {p: {v.split(".")[0] for v in dependency_aliases(tree).values()} for p, tree in parsed()}
    users = [p for p, tops in imported.items() if name in tops]
    assert users, f"no matid module imports {name}"
