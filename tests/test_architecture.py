"""The architecture, read from the code: imports point down, nothing goes round in circles.

Every module of the four packages is parsed with ``ast``; every import counts, function-local
ones included (a lazy import hides a dependency from the reader, not from the design). The rules:

- layers: scenarios -> learning -> allocation -> sim; a package imports only its own layer and
  the ones below it;
- no cycles, neither between modules nor between rooms (a subpackage such as
  ``scenarios.sweep`` counts as one room, a flat module as its own);
- no private names across modules: ``from x import _name`` and ``x._name`` are allowed only
  inside ``x`` itself (what another module needs is public and named);
- ``sim`` imports no matplotlib at module level (drawing is an adapter, loaded on demand) and
  ``allocation`` imports neither pymunk nor matplotlib anywhere.

The self-tests at the end feed the checker small synthetic packages, so it is seen to fail.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("sim", "allocation", "learning", "scenarios")  # bottom to top
FORBIDDEN = (  # (package, imported top-level name, module level only?)
    ("sim", "matplotlib", True),
    ("allocation", "matplotlib", False),
    ("allocation", "pymunk", False),
)
KNOWN_PRIVATE: frozenset[tuple[str, str]] = frozenset()  # (user, private name): none left


@dataclass(frozen=True, slots=True)
class Edge:
    """One import: ``importer`` depends on module ``target``."""

    importer: str
    target: str
    line: int


@dataclass(frozen=True, slots=True)
class Private:
    """A private name of ``owner`` used in ``user``: ``owner._name``."""

    user: str
    name: str  # "owner._name"
    line: int


def package_sources(root: Path = ROOT) -> dict[str, str]:
    """{module name: source} of every module of the four packages."""
    out = {}
    for package in LAYERS:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path.read_text()
    return out


class _Reader(ast.NodeVisitor):
    """Collects a module's imports (with where they run) and its uses of module attributes."""

    def __init__(self, module: str, is_package: bool, modules: set[str]) -> None:
        self.module, self.modules = module, modules
        self.package = module if is_package else module.rpartition(".")[0]
        self.edges: list[Edge] = []
        self.privates: list[Private] = []
        self.external: list[tuple[str, int, bool]] = []  # (top-level name, line, module level)
        self.aliases: dict[str, str] = {}  # local name -> first-party module it is bound to
        self.depth = 0  # inside functions
        self.type_only = 0  # inside `if TYPE_CHECKING:`

    @property
    def module_level(self) -> bool:
        return self.depth == 0 and self.type_only == 0

    def visit_FunctionDef(self, node) -> None:
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_AsyncFunctionDef = visit_Lambda = visit_FunctionDef

    def visit_If(self, node: ast.If) -> None:
        test = node.test
        name = test.id if isinstance(test, ast.Name) else getattr(test, "attr", "")
        if name == "TYPE_CHECKING":
            self.type_only += 1
            for child in node.body:
                self.visit(child)
            self.type_only -= 1
            for child in node.orelse:
                self.visit(child)
        else:
            self.generic_visit(node)

    def _depend(self, target: str, line: int) -> None:
        self.edges.append(Edge(self.module, target, line))

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            top = alias.name.split(".")[0]
            if top not in LAYERS:
                self.external.append((top, node.lineno, self.module_level))
                continue
            self._depend(alias.name, node.lineno)
            if alias.asname:
                self.aliases[alias.asname] = alias.name
            else:
                self.aliases[top] = top

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        if node.level:
            base = self.package.split(".")
            base = base[: len(base) - node.level + 1]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        top = source.split(".")[0]
        if top not in LAYERS:
            self.external.append((top, node.lineno, self.module_level))
            return
        for alias in node.names:
            sub = f"{source}.{alias.name}"
            if sub in self.modules:  # `from package import module`
                self._depend(sub, node.lineno)
                self.aliases[alias.asname or alias.name] = sub
                continue
            self._depend(source, node.lineno)
            if _private(alias.name) and source != self.module:
                self.privates.append(Private(self.module, f"{source}.{alias.name}", node.lineno))

    def visit_Attribute(self, node: ast.Attribute) -> None:
        base = _dotted(node.value)
        if base is not None and _private(node.attr):
            head, _, rest = base.partition(".")
            if head in self.aliases:
                owner = ".".join(filter(None, (self.aliases[head], rest)))
                if owner in self.modules and owner != self.module:
                    self.privates.append(Private(self.module, f"{owner}.{node.attr}", node.lineno))
        self.generic_visit(node)


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _dotted(node: ast.expr) -> str | None:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        base = _dotted(node.value)
        return None if base is None else f"{base}.{node.attr}"
    return None


@dataclass
class Report:
    upward: list[str]
    cycles: list[str]
    privates: list[Private]
    forbidden: list[str]


def read_imports(sources: Mapping[str, str], packages: Iterable[str] = ()):
    """(edges, privates, readers) of modules given as {name: source}; ``packages`` lists the
    names that are packages (``__init__``), detected from the sources when not given."""
    modules = set(sources)
    packages = set(packages) | {m for m in modules if any(o.startswith(m + ".") for o in modules)}
    readers = {}
    for name, text in sources.items():
        reader = _Reader(name, name in packages, modules)
        reader.visit(ast.parse(text, filename=name))
        readers[name] = reader
    edges = [e for r in readers.values() for e in r.edges if e.target != e.importer]
    privates = [p for r in readers.values() for p in r.privates]
    return edges, privates, readers


def check(sources: Mapping[str, str], packages: Iterable[str] = ()) -> Report:
    """Every rule of the module docstring applied to ``sources``."""
    edges, privates, readers = read_imports(sources, packages)
    rank = {p: k for k, p in enumerate(LAYERS)}
    upward = [
        f"{e.importer}:{e.line} imports {e.target} (upward: {_top(e.importer)} is below "
        f"{_top(e.target)})"
        for e in edges
        if rank[_top(e.importer)] < rank[_top(e.target)]
    ]
    module_cycles = _cycles(edges, lambda m: m)
    room_edges = [e for e in edges if _room(e.importer) != _room(e.target)]
    room_cycles = [c for c in _cycles(room_edges, _room) if c not in module_cycles]
    cycles = [f"modules: {' <-> '.join(c)}" for c in module_cycles]
    cycles += [f"rooms: {' <-> '.join(c)}" for c in room_cycles]
    forbidden = [
        f"{name}:{line} imports {top}" + (" at module level" if level_only else "")
        for package, top_name, level_only in FORBIDDEN
        for name, reader in readers.items()
        if _top(name) == package
        for top, line, module_level in reader.external
        if top == top_name and (module_level or not level_only)
    ]
    return Report(upward, cycles, privates, forbidden)


def _top(module: str) -> str:
    return module.split(".")[0]


def _room(module: str) -> str:
    """A package's subpackage (``scenarios.sweep``) or a flat module (``learning.qlmrta``)."""
    return ".".join(module.split(".")[:2])


def _cycles(edges: list[Edge], node) -> list[list[str]]:
    """Strongly connected components with more than one member (Tarjan), each sorted."""
    graph: dict[str, set[str]] = {}
    for e in edges:
        graph.setdefault(node(e.importer), set()).add(node(e.target))
        graph.setdefault(node(e.target), set())
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


# -- the real code -----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def report() -> Report:
    return check(package_sources())


def test_packages_import_only_downward(report):
    assert report.upward == []


def test_no_import_cycles_between_modules_or_rooms(report):
    assert report.cycles == []


def test_no_private_names_across_modules(report):
    unknown = [p for p in report.privates if (p.user, p.name) not in KNOWN_PRIVATE]
    assert unknown == [], "make what another module needs public and named"


def test_no_drawing_in_physics_and_no_physics_in_allocation(report):
    assert report.forbidden == []


def reaches_outside(edges: list[Edge], package: str, allowed: Iterable[str]) -> list[str]:
    """Imports of ``package``'s modules that leave it for a module not in ``allowed``."""

    def inside(module: str) -> bool:
        return module == package or module.startswith(package + ".")

    return [
        f"{e.importer}:{e.line} imports {e.target}"
        for e in edges
        if inside(e.importer) and not inside(e.target) and e.target not in set(allowed)
    ]


def test_navigation_knows_only_the_arena():
    """``sim.spatial.navigation`` (planning, distance fields, path following) reads the arena from
    ``sim.scenario`` and nothing else of the world: no robots' state, no pymunk world."""
    edges, _, readers = read_imports(package_sources())
    assert (
        "sim.spatial.navigation.planning" in readers and "sim.spatial.navigation.paths" in readers
    )
    assert reaches_outside(edges, "sim.spatial.navigation", {"sim.scenario"}) == []
    assert any(
        e.importer.startswith("sim.spatial.navigation.") for e in edges
    )  # its own imports read


def test_every_package_is_read():
    sources = package_sources()
    assert {_top(m) for m in sources} == set(LAYERS)
    assert "scenarios.cli" in sources and "learning.rounds" in sources


# -- the checker fails when it should ----------------------------------------------------------
CLEAN = {
    "sim": "",
    "sim.world": "import numpy as np\n",
    "allocation": "",
    "allocation.auction": "from sim.world import np\n",
    "learning": "",
    "learning.loop": "import allocation.auction\nfrom sim import world\n",
    "scenarios": "",
    "scenarios.cli": "",
    "scenarios.cli.main": "def main():\n    from learning.loop import run\n",
}


def _with(**changes: str) -> dict[str, str]:
    return {**CLEAN, **{k.replace("__", "."): v for k, v in changes.items()}}


def test_checker_passes_a_clean_package():
    assert check(CLEAN) == Report([], [], [], [])


def test_checker_fails_on_an_upward_import():
    sources = _with(sim__world="import numpy as np\n\ndef f():\n    from learning.loop import x\n")
    upward = check(sources).upward
    assert len(upward) == 1 and "sim.world:4 imports learning.loop" in upward[0]


def test_checker_fails_on_a_cycle_hidden_in_a_function():
    sources = _with(learning__rounds="def f():\n    from learning.loop import run\n")
    sources["learning.loop"] += "from learning.rounds import play\n"
    assert check(sources).cycles == ["modules: learning.loop <-> learning.rounds"]


def test_checker_fails_on_a_cycle_between_rooms():
    sources = _with(
        scenarios__sweep="",
        scenarios__sweep__runner="from scenarios.cli.main import main\n",
        scenarios__cli__parser="from scenarios.sweep.runner import run\n",
    )
    assert check(sources).cycles == ["rooms: scenarios.cli <-> scenarios.sweep"]


def test_checker_fails_on_private_names_across_modules():
    sources = _with(
        scenarios__cli__main="from learning.loop import _run\nimport sim.world as w\nw._x = 1\n",
        learning__loop="_mine = 1\nimport learning.loop\nlearning.loop._mine\n",
    )
    found = [(p.user, p.name) for p in check(sources).privates]
    assert found == [
        ("scenarios.cli.main", "learning.loop._run"),
        ("scenarios.cli.main", "sim.world._x"),
    ]


def test_checker_fails_on_matplotlib_in_physics_at_import_time():
    lazy = "def draw():\n    import matplotlib.pyplot\n"
    typed = (
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from matplotlib import figure\n"
    )
    assert check(_with(sim__world=lazy)).forbidden == []
    assert check(_with(sim__world=typed)).forbidden == []
    eager = check(_with(sim__world="from matplotlib import pyplot\n")).forbidden
    assert eager == ["sim.world:1 imports matplotlib at module level"]
    assert check(_with(allocation__auction=lazy.replace("matplotlib", "pymunk"))).forbidden


def test_checker_fails_on_a_package_reaching_outside_what_it_may_know():
    sources = _with(
        sim__nav="",
        sim__nav__plan="from sim.world import np\nfrom sim.nav import walk\n",
        sim__nav__walk="def f():\n    from allocation.auction import x\n",
    )
    edges, _, _ = read_imports(sources)
    assert reaches_outside(edges, "sim.nav", {"sim.world"}) == [
        "sim.nav.walk:2 imports allocation.auction"
    ]
    assert reaches_outside(edges, "sim.nav", ()) == [
        "sim.nav.plan:1 imports sim.world",
        "sim.nav.walk:2 imports allocation.auction",
    ]


def test_no_environment_variable_changes_behaviour():
    """A run depends on its spec only: no package module reads the environment (an experiment
    switch left in ``sim/spatial/law/orca.py`` once did)."""
    offenders = []
    for pkg in ("sim", "allocation", "learning"):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            text = path.read_text()
            if "os.environ" in text or "getenv(" in text:
                offenders.append(str(path.relative_to(ROOT)))
    assert offenders == []
