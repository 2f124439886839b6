"""The tree is the design: imports point one way, at module and at package level.

Every import counts, those inside functions too (a function-level import is a dependency that
only waits longer to break). The graph is read from the sources with ``ast``, so the test
needs nothing installed beyond the package itself.
"""

from __future__ import annotations

import ast
import itertools
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("mobile_envs", "agents")

#: The layers of ``mobile_envs`` and the layers each builds on directly: data flows down this
#: table, and a layer may import what its layers may (:data:`MOBILE_ENVS_LAYERS`). A
#: subpackage not named here is a failure of its own (every new one takes a row).
BUILDS_ON: dict[str, set[str]] = {
    "_kernels": set(),
    "validation": set(),
    "catalogue": set(),
    "robots": {"_kernels", "validation", "catalogue"},
    "world": {"_kernels", "validation"},
    "tracks": {"world", "catalogue"},
    "sensing": {"robots", "tracks"},
    "sim": {"sensing"},
    "rendering": {"sim"},
    "envs": {"rendering"},
}


def _reachable(layer: str) -> set[str]:
    reached = set()
    for lower in BUILDS_ON[layer]:
        reached |= {lower} | _reachable(lower)
    return reached


#: What each layer may import of the package (itself aside).
MOBILE_ENVS_LAYERS = {
    f"mobile_envs.{layer}": {f"mobile_envs.{lower}" for lower in _reachable(layer)}
    for layer in BUILDS_ON
}
#: Modules that only re-export from where things moved, for the import paths users rely on.
#: Nothing in the project may import them.
COMPATIBILITY_MODULES = {
    "mobile_envs.env",
    "mobile_envs.vector",
    "mobile_envs.sb3",
    "mobile_envs.kinematics",
    "mobile_envs.config",
    "mobile_envs.paths",
    "mobile_envs.odometry",
    "mobile_envs.beacons",
    "agents.pure_pursuit",
}
#: Libraries the physics, geometry and simulation must not know (they are the envs' faces).
FACE_LIBRARIES = ("gymnasium", "stable_baselines3", "torch")


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def source_modules() -> dict[str, Path]:
    modules = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            modules[module_name(path)] = path
    return modules


MODULES = source_modules()


def imported_names(name: str, path: Path) -> Iterator[str]:
    """Every module ``name`` imports, at any depth of its code, as absolute names."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                base = ".".join(anchor[: len(anchor) - node.level + 1] + ([base] if base else []))
            yield base
            # ``from package import module`` imports the module.
            yield from (f"{base}.{alias.name}" for alias in node.names)


def project_imports(name: str) -> set[str]:
    """The project's modules that module ``name`` imports."""
    found = set()
    for imported in imported_names(name, MODULES[name]):
        if imported in MODULES and imported != name:
            found.add(imported)
    return found


GRAPH = {name: project_imports(name) for name in MODULES}


def package_of(module: str) -> str:
    """The unit of the design a module belongs to: its subpackage, or itself at the top."""
    parts = module.split(".")
    if len(parts) == 1:
        return module
    top = ".".join(parts[:2])
    return top if top in MODULES else module


def strongly_connected(graph: dict[str, set[str]]) -> list[set[str]]:
    """Tarjan's strongly connected components with more than one node (the cycles)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []
    counter = itertools.count()

    def visit(node: str) -> None:
        index[node] = low[node] = next(counter)
        stack.append(node)
        on_stack.add(node)
        for successor in sorted(graph.get(node, ())):
            if successor not in index:
                visit(successor)
                low[node] = min(low[node], low[successor])
            elif successor in on_stack:
                low[node] = min(low[node], index[successor])
        if low[node] == index[node]:
            component = set()
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.add(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(component)

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return components


def package_graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for module, imports in GRAPH.items():
        source = package_of(module)
        targets = {package_of(target) for target in imports} - {source}
        graph.setdefault(source, set()).update(targets)
    return graph


def test_the_graph_is_read_from_the_sources():
    # The graph sees what it must: the env imports the core, a function-level import counts.
    assert "mobile_envs.sim.core" in GRAPH["mobile_envs.envs.path_following"]
    assert strongly_connected({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [{"a", "b", "c"}]
    assert strongly_connected({"a": {"b"}, "b": set()}) == []


def test_no_module_imports_itself_back():
    assert strongly_connected(GRAPH) == []


def test_no_package_imports_itself_back():
    assert strongly_connected(package_graph()) == []


def test_every_subpackage_has_a_layer():
    subpackages = {
        package_of(module)
        for module in MODULES
        if module.startswith("mobile_envs.") and module not in COMPATIBILITY_MODULES
    }
    subpackages.discard("mobile_envs")
    assert subpackages == set(MOBILE_ENVS_LAYERS)


@pytest.mark.parametrize("layer", sorted(MOBILE_ENVS_LAYERS))
def test_data_flows_down_the_layers(layer):
    allowed = MOBILE_ENVS_LAYERS[layer] | {layer}
    for module, imports in GRAPH.items():
        if package_of(module) != layer:
            continue
        reached = {package_of(target) for target in imports}
        assert reached <= allowed, f"{module} imports {sorted(reached - allowed)}"


def test_the_package_imports_no_agent():
    for module, imports in GRAPH.items():
        if module.startswith("mobile_envs"):
            assert not any(target.startswith("agents") for target in imports), module


def test_nothing_imports_the_compatibility_modules():
    for module, imports in GRAPH.items():
        if module == "agents" or module in COMPATIBILITY_MODULES:
            continue
        assert not imports & COMPATIBILITY_MODULES, module
    for path in [ROOT / "train.py", *sorted((ROOT / "benchmarks").glob("*.py"))]:
        reached = set(imported_names(path.stem, path))
        assert not reached & COMPATIBILITY_MODULES, path.name


@pytest.mark.parametrize(
    "layer",
    [
        "mobile_envs._kernels",
        "mobile_envs.robots",
        "mobile_envs.world",
        "mobile_envs.tracks",
        "mobile_envs.sensing",
        "mobile_envs.sim",
    ],
)
def test_physics_geometry_and_simulation_know_nothing_of_gymnasium(layer):
    for module, path in MODULES.items():
        if package_of(module) != layer:
            continue
        for imported in imported_names(module, path):
            assert not imported.startswith(FACE_LIBRARIES), f"{module} imports {imported}"
