"""The house a newcomer extends (style.md): imports point down, no circles, small rooms.

Every import counts, the ones inside functions included: a deferred import is still a
dependency, and only hides a circle from the interpreter, not from the reader.
"""

import ast
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "matid"

# Lower floors first. A module may import only from a floor strictly below its own (or its own
# package). The package's own __init__ (its version; the API is imported lazily, by name) and
# errors and units are the ground; the data model and the paper's physics sit on them.
FLOORS = ["__init__", "errors", "limits", "units", "toml", "physics", "model", "rod", "fits", "io", "example",
          "report", "bench", "app", "__main__"]
MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 80


def _modules() -> dict[str, Path]:
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """The matid modules that ``name`` imports, resolved to a module file where one exists."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([node.module] if node.module else []))
            for alias in node.names:
                full = f"{base}.{alias.name}"
                targets.add(full if full in MODULES else base)
    resolved = set()
    for target in targets:
        while target and target not in MODULES:  # `import matid.rod.x.y` names a module's attribute
            target = target.rpartition(".")[0]
        if target and target != name:
            resolved.add(target)
    return resolved


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _floor(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_top_level_room_has_a_floor():
    rooms = {_floor(m) for m in MODULES}
    assert rooms <= set(FLOORS), f"rooms without a floor in tests/test_house.py: {rooms - set(FLOORS)}"


def test_imports_point_down():
    upward = [
        f"{module} imports {target}"
        for module, targets in GRAPH.items()
        for target in targets
        if _floor(target) != _floor(module) and FLOORS.index(_floor(target)) > FLOORS.index(_floor(module))
    ]
    assert upward == []


def test_physics_rod_and_fits_never_reach_io_report_or_app():
    above = {"io", "report", "app"}
    low = {"physics", "rod", "fits", "model"}
    reaching = [f"{m} imports {t}" for m, ts in GRAPH.items() if _floor(m) in low
                for t in ts if _floor(t) in above]
    assert reaching == []


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, on_stack, stack, found, counter = {}, {}, set(), [], [], [0]

    def visit(root):
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
            elif child not in index:
                index[child] = low[child] = counter[0]
                counter[0] += 1
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph[child]))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return found


def test_no_import_circle_even_inside_functions():
    assert _cycles(GRAPH) == []


def test_the_circle_finder_finds_a_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]


def test_no_package_init_hides_one_of_its_modules():
    hidden = [
        f"{name}.{alias.asname or alias.name} (from {node.module})"
        for name, path in MODULES.items() if path.name == "__init__.py"
        for node in ast.parse(path.read_text(encoding="utf-8")).body if isinstance(node, ast.ImportFrom)
        for alias in node.names
        if f"{name}.{alias.asname or alias.name}" in MODULES  # the name is also a module of the package
        and not (node.module == name and alias.asname in {None, alias.name})  # ... and is not that module
    ]
    assert hidden == []


@pytest.mark.parametrize("module", sorted(MODULES))
def test_modules_and_functions_are_small(module):
    path = MODULES[module]
    lines = path.read_text(encoding="utf-8").count("\n")
    assert lines <= MAX_MODULE_LINES, f"{path.name}: {lines} lines"
    long = [f"{node.name}: {node.end_lineno - node.lineno + 1} lines"
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert long == []


def _third_party(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names.add((node.module or "").split(".")[0])
    return names - {"matid", "__future__"} - set(sys.stdlib_module_names)


def test_physics_and_the_model_build_on_numpy_and_pandas_only():
    """physics: numpy only (scipy for special functions); model: numpy and pandas (its tables)."""
    allowed = {"physics": {"numpy", "scipy"}, "model": {"numpy", "pandas"}}
    found = [f"{m} imports {n}" for m, path in MODULES.items() if _floor(m) in allowed
             for n in _third_party(path) - allowed[_floor(m)]]
    assert found == []
