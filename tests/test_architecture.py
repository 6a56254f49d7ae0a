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
  ``allocation`` imports neither pymunk nor matplotlib anywhere;
- ``sim`` keeps at most :data:`SIM_FLAT_MAX` modules directly in it (packages are rooms and do
  not count);
- the bottom of the pymunk world stays the bottom: ``sim.spatial.law`` reaches outside itself
  only for ``sim.scenario``, ``sim.spatial.navigation`` likewise, and ``sim.maps`` for nothing
  of the project at all;
- the rest of ``sim`` does not know the pymunk world: no module of ``sim`` outside
  ``sim.spatial`` imports it, but ``sim/__init__.py`` (``make_world``); ``sim.render`` never;
- no cycles between the rooms of ``sim.spatial`` (its subpackages and flat modules:
  ``sim.spatial.law``, ``sim.spatial.jobs``, ...);
- no package module reads the environment.

And of the tests (``tests/``, every file): no test patches a module constant (a setting is a
scenario's, passed in, not a global swapped under a running world), and no test module
imports from another test module (small worlds are in ``tests/worlds.py``, fixtures in
``conftest.py`` files).

The self-tests at the end feed the checker small synthetic packages, so it is seen to fail.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("sim", "allocation", "learning", "scenarios")  # bottom to top
SIM_FLAT_MAX = 10  # modules directly in sim/, __init__ included
FORBIDDEN = (  # (package, imported top-level name, module level only?)
    ("sim", "matplotlib", True),
    ("allocation", "matplotlib", False),
    ("allocation", "pymunk", False),
)
KNOWN_PRIVATE: frozenset[tuple[str, str]] = frozenset()  # (user, private name): none left
# test files that still patch a module constant (tests/docs patches scenarios.docgen's ROOT,
# SECTIONS and TOP_SECTIONS): to go once docgen takes its root and sections as arguments
KNOWN_CONSTANT_PATCHES: frozenset[str] = frozenset({"docs/test_reference_pages.py"})


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


def inside(module: str, package: str) -> bool:
    """``module`` is ``package`` or one of its submodules."""
    return module == package or module.startswith(package + ".")


def reaches_outside(edges: list[Edge], package: str, allowed: Iterable[str]) -> list[str]:
    """Imports of ``package``'s modules that leave it for a module not in ``allowed`` (an
    allowed package allows its submodules too)."""
    allowed = tuple(allowed)
    return [
        f"{e.importer}:{e.line} imports {e.target}"
        for e in edges
        if inside(e.importer, package)
        and not inside(e.target, package)
        and not any(inside(e.target, a) for a in allowed)
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


def flat_modules(sources: Mapping[str, str], package: str, packages: Iterable[str] = ()):
    """The modules directly in ``package``, its ``__init__`` (``package`` itself) included and
    its subpackages left out; ``packages`` as in :func:`read_imports`."""
    names = set(sources)
    packages = set(packages) | {m for m in names if any(o.startswith(m + ".") for o in names)}
    return sorted(
        m for m in names if m == package or (m.rpartition(".")[0] == package and m not in packages)
    )


def world_users(edges: list[Edge], package: str, world: str, doors: Iterable[str]) -> list[str]:
    """Imports of ``world`` (a subpackage of ``package``) by modules of ``package`` outside it,
    but the modules in ``doors``."""
    return [
        f"{e.importer}:{e.line} imports {e.target}"
        for e in edges
        if inside(e.importer, package)
        and not inside(e.importer, world)
        and inside(e.target, world)
        and e.importer not in set(doors)
    ]


def room_cycles(edges: list[Edge], package: str) -> list[list[str]]:
    """Cycles between the rooms of ``package``: its subpackages and flat modules one level
    down (``sim.spatial.law``, ``sim.spatial.jobs``), its ``__init__`` a node of its own."""
    depth = package.count(".") + 2

    def room(module: str) -> str:
        return ".".join(module.split(".")[:depth])

    within = [
        e
        for e in edges
        if inside(e.importer, package)
        and inside(e.target, package)
        and room(e.importer) != room(e.target)
    ]
    return _cycles(within, room)


def test_sim_keeps_few_modules_directly_in_it():
    """A new part of the simulation goes into a room (``sim.spatial``, ``sim.maps``, ...), not
    beside ``world``, ``tasks`` and ``faults``."""
    flat = flat_modules(package_sources(), "sim")
    assert "sim.world" in flat and "sim.spatial" not in flat and "sim.spatial.world" not in flat
    assert len(flat) <= SIM_FLAT_MAX, f"{len(flat)} modules directly in sim/: {flat}"


def test_the_laws_know_only_the_scenario_and_the_maps_nothing():
    """``sim.spatial.law`` (the drive law's formulas, ORCA) is the bottom of the pymunk world:
    it reads its settings from ``sim.scenario`` and nothing else of the project. ``sim.maps``
    (ROS maps turned into obstacles) knows nothing of the project at all."""
    edges, _, readers = read_imports(package_sources())
    assert "sim.spatial.law.orca" in readers and "sim.spatial.law.drive" in readers
    assert "sim.maps.mapyaml" in readers and "sim.maps.occupancy" in readers
    assert reaches_outside(edges, "sim.spatial.law", {"sim.scenario"}) == []
    assert reaches_outside(edges, "sim.maps", ()) == []
    assert any(e.importer.startswith("sim.spatial.law.") for e in edges)  # its imports read
    assert any(e.importer.startswith("sim.maps.") for e in edges)


def test_the_rest_of_sim_does_not_know_the_pymunk_world():
    """Only ``sim/__init__.py`` (``make_world``) opens the pymunk world to the rest of ``sim``;
    the abstract world, tasks, faults, recording and rendering never import ``sim.spatial``."""
    edges, _, readers = read_imports(package_sources())
    assert "sim.render.frames" in readers and "sim.recording" in readers
    assert world_users(edges, "sim", "sim.spatial", doors={"sim"}) == []
    render = [e for e in edges if inside(e.importer, "sim.render")]
    assert render and not [e for e in render if inside(e.target, "sim.spatial")]


def test_no_cycles_between_the_rooms_of_the_pymunk_world():
    edges, _, readers = read_imports(package_sources())
    assert "sim.spatial.jobs" in readers and "sim.spatial.control.array" in readers
    assert room_cycles(edges, "sim.spatial") == []


def suite_files() -> dict[str, str]:
    """{path under tests/: source} of every Python file of the tests."""
    return {
        str(path.relative_to(ROOT / "tests")): path.read_text()
        for path in sorted((ROOT / "tests").rglob("*.py"))
    }


def _upper(name: str) -> bool:
    return re.fullmatch(r"_*[A-Z][A-Z0-9_]*", name) is not None


def _string(node: ast.expr) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def constant_patches(files: Mapping[str, str]) -> list[str]:
    """Where test files (``{path: source}``) patch an UPPER_CASE module constant:
    ``monkeypatch.setattr(x, "NAME", v)``, ``monkeypatch.setattr("a.b.NAME", v)`` (any
    ``<name>.setattr``: a ``monkeypatch.context()`` too) and ``x.NAME = v``."""
    out = []
    for path, text in files.items():
        for node in ast.walk(ast.parse(text, filename=path)):
            names = []
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr == "setattr"
                and isinstance(node.func.value, ast.Name)
            ):
                if len(node.args) >= 3 and _string(node.args[1]) is not None:
                    names.append(_string(node.args[1]))
                elif len(node.args) == 2 and _string(node.args[0]) is not None:
                    names.append(_string(node.args[0]).rpartition(".")[2])
            elif isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                for target in targets:
                    for part in ast.walk(target):
                        if isinstance(part, ast.Attribute) and isinstance(part.ctx, ast.Store):
                            names.append(part.attr)
            out += [(path, node.lineno, n) for n in names if _upper(n)]
    return [f"{path}:{line} patches {name}" for path, line, name in sorted(out)]


def cross_test_imports(files: Mapping[str, str]) -> list[str]:
    """Imports of a test module or a ``conftest`` by a test file (``{path: source}``): what
    tests share is in ``tests/worlds.py`` (and the golden cases' modules) or a fixture."""
    out = []
    for path, text in files.items():
        for node in ast.walk(ast.parse(text, filename=path)):
            if isinstance(node, ast.Import):
                dotted = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                dotted = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for name in dotted:
                parts = name.split(".")
                if parts[0] == "tests" and any(
                    p.startswith("test_") or p == "conftest" for p in parts[1:]
                ):
                    out.append(f"{path}:{node.lineno} imports {name}")
                    break
    return out


def test_no_test_patches_a_module_constant():
    """A setting a test needs is passed in (a scenario's ``[spatial.*]`` table, an argument),
    not swapped in a module under a running world: the module's other readers, and the code
    that read the constant at import, would not see it."""
    files = suite_files()
    assert "sim/spatial/test_jobs.py" in files and "worlds.py" in files
    found = constant_patches(files)
    assert [p for p in found if p.partition(":")[0] not in KNOWN_CONSTANT_PATCHES] == []


def test_no_test_module_imports_another():
    files = suite_files()
    assert cross_test_imports(files) == []
    assert any("from tests.worlds import" in text for text in files.values())


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


def test_checker_counts_only_the_modules_directly_in_a_package():
    sources = {
        "sim": "",
        "sim.world": "",
        "sim.tasks": "",
        "sim.room": "",
        "sim.room.inner": "",
        "sim.lone": "",  # a package with no module yet is told by ``packages``
    }
    assert flat_modules(sources, "sim") == ["sim", "sim.lone", "sim.tasks", "sim.world"]
    assert flat_modules(sources, "sim", packages={"sim.lone"}) == ["sim", "sim.tasks", "sim.world"]
    crowded = {**sources, **{f"sim.m{k}": "" for k in range(SIM_FLAT_MAX)}}
    assert len(flat_modules(crowded, "sim")) > SIM_FLAT_MAX


def test_checker_fails_on_a_law_or_a_map_reaching_outside():
    rooms = ["sim.scenario", "sim.scenario.spatial", "sim.spatial", "sim.spatial.fleet"]
    sources = {**CLEAN, **dict.fromkeys([*rooms, "sim.spatial.law", "sim.maps.cache"], "")}
    sources["sim.spatial.law.orca"] = "from sim.scenario.spatial import OrcaSpec\n"
    sources["sim.spatial.law.drive"] = "def f():\n    from sim.spatial.fleet import FleetState\n"
    sources["sim.maps"] = "from sim.maps import cache\nfrom sim.scenario import x\n"
    edges, _, _ = read_imports(sources)
    assert reaches_outside(edges, "sim.spatial.law", {"sim.scenario"}) == [
        "sim.spatial.law.drive:2 imports sim.spatial.fleet"
    ]
    assert reaches_outside(edges, "sim.maps", ()) == ["sim.maps:2 imports sim.scenario"]


def test_checker_fails_on_sim_importing_the_pymunk_world_past_its_door():
    sources = dict(CLEAN, sim="from sim.spatial.world import PymunkWorld\n")
    sources.update(dict.fromkeys(["sim.spatial", "sim.spatial.world", "sim.render"], ""))
    sources["sim.recording"] = "import sim.spatial.world\n"
    sources["sim.render.frames"] = "def draw():\n    from sim.spatial import world\n"
    edges, _, _ = read_imports(sources)
    assert world_users(edges, "sim", "sim.spatial", doors={"sim"}) == [
        "sim.recording:1 imports sim.spatial.world",
        "sim.render.frames:2 imports sim.spatial.world",
    ]


def test_checker_fails_on_a_cycle_between_rooms_of_a_subpackage():
    sources = _with(
        sim__spatial="",
        sim__spatial__jobs="from sim.spatial.law.orca import solve\n",
        sim__spatial__law="",
        sim__spatial__law__orca="",
        sim__spatial__law__drive="def f():\n    from sim.spatial.jobs import Jobs\n",
    )
    edges, _, _ = read_imports(sources)
    assert check(sources).cycles == []  # no cycle between modules, nor between sim's rooms
    assert room_cycles(edges, "sim.spatial") == [["sim.spatial.jobs", "sim.spatial.law"]]


def test_checker_finds_every_way_a_test_patches_a_module_constant():
    files = {
        "a.py": 'def test(monkeypatch):\n    monkeypatch.setattr(orca, "TAU_S", 2.0)\n',
        "b.py": 'def test(monkeypatch):\n    monkeypatch.setattr("sim.spatial.jams.PASS_S", 9)\n',
        "c.py": "import sim.spatial.jobs as jobs\n\njobs.DETOUR_M = 2.0\n",
        "d.py": "def test(monkeypatch):\n    with monkeypatch.context() as mp:\n"
        '        mp.setattr(world, "GC_ROBOTS", 1)\n    x.y.LIMIT += 1\n',
        "fine.py": 'def test(monkeypatch):\n    monkeypatch.setattr(orca, "solve", None)\n'
        '    monkeypatch.setattr("a.b.run", None)\n    w.schedule.resting = True\n'
        "    LOCAL = 3\n",
    }
    assert constant_patches(files) == [
        "a.py:2 patches TAU_S",
        "b.py:2 patches PASS_S",
        "c.py:3 patches DETOUR_M",
        "d.py:3 patches GC_ROBOTS",
        "d.py:4 patches LIMIT",
    ]


def test_checker_fails_on_a_test_module_imported_by_another():
    files = {
        "sim/test_a.py": "from tests.sim.test_b import make_world\n",
        "sim/test_c.py": "def f():\n    import tests.sim.conftest\n",
        "sim/test_d.py": "from tests.sim import test_b\n",
        "fine.py": "from tests.worlds import give\nfrom tests.golden.cases import CASES\n",
    }
    assert cross_test_imports(files) == [
        "sim/test_a.py:1 imports tests.sim.test_b",
        "sim/test_c.py:2 imports tests.sim.conftest",
        "sim/test_d.py:1 imports tests.sim.test_b",
    ]
