"""Imports point down (style.md, "The house a newcomer extends"; issue 27): physics and model at the
bottom, then rod, then fits, then io, report, app. Every import counts, those inside functions and
under ``TYPE_CHECKING`` too. Read from the source with :mod:`ast`."""

from __future__ import annotations

import ast
import sys

from tests import ROOT

PACKAGE = ROOT / "matid"
#: The packages these checks cover (rod and bench: issue 27's other items).
CHECKED = ("matid.model", "matid.fits", "matid.io", "matid.report", "matid.app", "matid.example")
MAX_MODULE_LINES, MAX_FUNCTION_LINES = 400, 80


def modules() -> dict[str, ast.Module]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found[name] = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return found


MODULES = modules()


def imported(name: str, tree: ast.Module) -> set[str]:
    """The modules ``name`` imports anywhere in its source (absolute names; ``from a import b`` gives
    ``a.b`` when that is a module, else ``a``)."""
    here = (
        name if name in MODULES and tree is MODULES[name] and _is_package(name) else name.rpartition(".")[0]
    )
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = here.split(".")[: len(here.split(".")) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            out |= {f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names}
    return out


def _is_package(name: str) -> bool:
    return (PACKAGE.parent / name.replace(".", "/") / "__init__.py").exists()


def _under(module: str, packages: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(p + ".") for p in packages)


def test_fits_rod_physics_and_model_import_nothing_from_io_report_or_app():
    found = [
        f"{name} imports {target}"
        for name, tree in MODULES.items()
        if _under(name, ("matid.fits", "matid.rod", "matid.physics", "matid.model"))
        for target in imported(name, tree)
        if _under(target, ("matid.io", "matid.report", "matid.app", "matid.bench", "matid.example"))
    ]
    assert not found, "\n".join(found)


def test_the_model_builds_on_the_standard_library_numpy_pandas_and_physics_only():
    allowed = ("matid.model", "matid.physics", "matid.errors", "matid.units")
    found = [
        f"{name} imports {target}"
        for name, tree in MODULES.items()
        if _under(name, ("matid.model",))
        for target in imported(name, tree)
        if not (
            _under(target, allowed)
            or target.split(".")[0] in {"numpy", "pandas", "__future__"}
            or target.split(".")[0] in sys.stdlib_module_names
        )
    ]
    assert not found, "\n".join(found)


def test_no_import_circle():
    """No module reaches itself through the imports of the checked packages."""
    graph = {n: {t for t in imported(n, tree) if t in MODULES and t != n} for n, tree in MODULES.items()}
    circles = []
    for start in (n for n in graph if _under(n, CHECKED)):
        seen, stack = set(), [(start, (start,))]
        while stack:
            node, path = stack.pop()
            for nxt in graph[node]:
                if nxt == start:
                    circles.append(" -> ".join((*path, start)))
                elif nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, (*path, nxt)))
    assert not circles, "\n".join(sorted(set(circles)))


def test_modules_and_functions_stay_short():
    long = []
    for name, tree in MODULES.items():
        if not _under(name, CHECKED):
            continue
        lines = max((getattr(n, "end_lineno", 0) or 0 for n in ast.walk(tree)), default=0)
        if lines > MAX_MODULE_LINES:
            long.append(f"{name}: {lines} lines")
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long.append(f"{name}.{node.name}: {length} lines")
    assert not long, "\n".join(long)


def test_a_package_init_hides_none_of_its_modules():
    """``from matid.x import y`` must mean the module y when there is one: an ``__init__`` that binds
    the name of one of its modules to something else hides it."""
    hidden = []
    for name, tree in MODULES.items():
        if not _is_package(name):
            continue
        children = {m.rpartition(".")[2] for m in MODULES if m.rpartition(".")[0] == name}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                bound = {a.asname or a.name for a in node.names}
                wrong = {b for b in bound & children if f"{node.module}.{b}" not in MODULES}
                hidden += [f"{name} binds {b} to {node.module}.{b}" for b in wrong]
            elif isinstance(node, ast.FunctionDef | ast.ClassDef | ast.Assign) and node in tree.body:
                names = [node.name] if not isinstance(node, ast.Assign) else [
                    t.id for t in node.targets if isinstance(t, ast.Name)]  # fmt: skip
                hidden += [f"{name} defines {n}" for n in names if n in children]
    hidden = [h for h in hidden if _under(h.split()[0], CHECKED)]
    assert not hidden, "\n".join(hidden)
