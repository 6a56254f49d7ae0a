"""Load scenario files (TOML) into frozen :class:`sim.scenario.Scenario` values.

The loader reads the file's shape (tables, lists, key names, task-type names); every value is
checked by the spec it goes into (``sim.scenario``: type, range, allowed words, the rules between
keys), the same check a scenario built in Python or changed by an override gets; the spatial
layout (starts, sites, reachability) by ``sim.spatial.layout.check_layout``. Any problem raises
:class:`ScenarioError` whose one-line message names the file, the key path and the problem (with
a did-you-mean for unknown keys), before any work.
"""

from __future__ import annotations

import hashlib
import tomllib
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any

from sim.scenario import (
    MAX_ROBOTS,
    MAX_TYPES,
    ExperienceSpec,
    FaultSpec,
    LearningSpec,
    RobotSpec,
    Scenario,
    SpatialSpec,
    StreamSpec,
)
from sim.scenario.maps import MAP_KEY, map_arena, shifted_point, shifted_points
from sim.scenario.schema import (
    ScenarioError,
    check_table,
    did_you_mean,
    fail,
    kind_of,
    tables_of,
)
from sim.spatial.layout import Frame, check_layout

SECTIONS = {
    "stream": StreamSpec,
    "learning": LearningSpec,
    "experience": ExperienceSpec,
    "faults": FaultSpec,
}
TOP_SECTIONS = ("scenario", "robots", *SECTIONS, "spatial")
SCENARIO_KEYS = ("name", "description", "task_types", "exec_time_s")  # [scenario]
ROBOT_KEYS = ("name", "capabilities", "cost", "start", "heading_deg")  # each [[robots]]


def bundled_toml(folder: str = "") -> list[str]:
    """Names (without ``.toml``) of the TOML files shipped in ``scenarios/data/<folder>``."""
    data = _data(folder)
    if not data.is_dir():
        return []
    return sorted(p.name.removesuffix(".toml") for p in data.iterdir() if p.name.endswith(".toml"))


def locate(name_or_path: str | Path, folder: str = "") -> Path | None:
    """An existing file as given; else the bundled file of that name in
    ``scenarios/data/<folder>``; else the path as given if it looks like one (ends in .toml or
    has a '/': reading it then names the problem); None otherwise. A folder named like a
    bundled scenario (``mrta reproduce --out paper``) never shadows it."""
    text = str(name_or_path)
    candidate = Path(text)
    if candidate.is_file():
        return candidate
    bundled = _data(folder) / f"{text}.toml"
    if "/" not in text and bundled.is_file():
        return Path(str(bundled))
    if candidate.suffix == ".toml" or "/" in text or candidate.exists():
        return candidate
    return None


def _data(folder: str):
    data = resources.files("scenarios") / "data"
    return data / folder if folder else data


def bundled_names() -> list[str]:
    """Names of the scenarios shipped with the package (``mrta ... --scenario NAME``)."""
    return bundled_toml()


def resolve(name_or_path: str | Path) -> Path:
    """A bundled scenario by name, or a file by path."""
    path = locate(name_or_path)
    if path is None:
        names = bundled_names()
        hint = did_you_mean(str(name_or_path), names)
        raise ScenarioError(
            f"{name_or_path}: no such scenario file or bundled scenario{hint} "
            f"(bundled: {', '.join(names)})"
        )
    return path


def read_toml(path: Path) -> tuple[dict[str, Any], bytes]:
    """(parsed document, raw bytes) of a TOML file; ScenarioError with one line otherwise."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ScenarioError(f"{path}: file not found") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read ({exc.strerror})") from None
    try:
        return tomllib.loads(raw.decode("utf-8")), raw
    except UnicodeDecodeError:
        raise ScenarioError(f"{path}: not UTF-8 text") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: TOML syntax error: {exc}") from None


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Read, parse and validate a scenario; raise ScenarioError with a one-line message."""
    path = resolve(name_or_path)
    doc, raw = read_toml(path)
    return parse_scenario(doc, source=str(path), sha256=hashlib.sha256(raw).hexdigest())


def parse_scenario(doc: dict[str, Any], source: str = "<scenario>", sha256: str = "") -> Scenario:
    """Validate a parsed TOML document and build the Scenario (layout checked too)."""
    try:
        scenario, frame = _build(doc, source, sha256)
        check_layout(scenario, frame=frame)
    except ScenarioError as err:
        raise err.located(source) from None
    return scenario


def _build(doc: dict[str, Any], source: str, sha256: str) -> tuple[Scenario, Frame]:
    check_table(doc, "", TOP_SECTIONS)
    head = table(doc, "scenario", required=True)
    check_table(head, "scenario", SCENARIO_KEYS)
    name = string(head, "scenario.name")
    string(head, "scenario.description", optional=True)
    types = str_list(head, "scenario.task_types")
    if not 1 <= len(types) <= MAX_TYPES:
        fail("scenario.task_types", f"needs 1 to {MAX_TYPES} entries, got {len(types)}")
    if len(set(types)) != len(types):
        fail("scenario.task_types", "duplicate task type names")
    if "exec_time_s" not in head:
        fail("scenario.exec_time_s", "missing")
    robots, cost_rows = _robots(doc, types)
    sections = {key: section(doc, key, cls) for key, cls in SECTIONS.items() if key != "faults"}
    faults = section(doc, "faults", FaultSpec, mttf_by_robot=_mttf_by_robot)
    spatial, frame = None, Frame()
    if "spatial" in doc:
        spatial, frame = _spatial(doc, types, Path(source).parent)
    if frame.own is not None:  # starts in the map's frame, the world's is its lower-left corner
        robots = [replace(r, start_xy=shifted_point(r.start_xy, frame.origin)) for r in robots]
    scenario = Scenario(
        name=name,
        task_types=tuple(types),
        robots=tuple(robots),
        cost=tuple(cost_rows),
        exec_time_s=head["exec_time_s"],
        spatial=spatial,
        faults=faults,
        source=source,
        source_sha256=sha256,
        **sections,
    )
    return scenario, frame


def _robots(doc: dict, types: list[str]) -> tuple[list[RobotSpec], list[list[Any]]]:
    robot_docs = doc.get("robots")
    if not isinstance(robot_docs, list) or not robot_docs:
        fail("robots", "needs at least one [[robots]] table")
    if len(robot_docs) > MAX_ROBOTS:
        fail("robots", f"{len(robot_docs)} robots, more than the {MAX_ROBOTS} we support")
    robots, cost_rows = [], []
    for j, rd in enumerate(robot_docs):
        where = f"robots[{j}]"
        if not isinstance(rd, dict):
            fail(where, "must be a table")
        check_table(rd, where, ROBOT_KEYS)
        rname = string(rd, f"{where}.name")
        caps = str_list(rd, f"{where}.capabilities")
        for c in caps:
            if c not in types:
                fail(f"{where}.capabilities", f"unknown task type {c!r}{did_you_mean(c, types)}")
        if not 1 <= len(caps) <= len(types):
            fail(f"{where}.capabilities", f"needs 1 to {len(types)} entries, got {len(caps)}")
        if len(set(caps)) != len(caps):
            fail(f"{where}.capabilities", "a task type is listed twice")
        cost = table(rd, "cost", required=True, where=f"{where}.cost")
        row: list[Any] = [float("inf")] * len(types)
        for key, value in cost.items():
            if key not in caps:
                fail(f"{where}.cost.{key}", f"not among this robot's capabilities {caps}")
            row[types.index(key)] = value
        for c in caps:
            if c not in cost:
                fail(f"{where}.cost", f"missing cost for capability {c!r}")
        extra = {"heading_deg": rd["heading_deg"]} if "heading_deg" in rd else {}
        capable = tuple(types.index(c) for c in caps)
        robots.append(RobotSpec(rname, capable, rd.get("start"), **extra))
        cost_rows.append(row)
    return robots, cost_rows


def _mttf_by_robot(value: Any) -> tuple:
    if not isinstance(value, dict):
        fail("faults.mttf_by_robot", f"must be a table, got {kind_of(value)}")
    return tuple(value.items())


def _spatial(doc: dict, types: list[str], folder: Path) -> tuple[SpatialSpec, Frame]:
    """The ``[spatial]`` table: its sub-tables built as specs, its sites in task-type order;
    with ``map``, the arena and obstacles of the map (:func:`map_arena`), the points of the
    file moved from the map's frame to the world's; and the frame messages show them in."""
    raw = dict(table(doc, "spatial"))
    arena = None
    if MAP_KEY in raw:
        for key in ("width_m", "height_m"):
            if key in raw:
                fail(f"spatial.{key}", "not allowed beside spatial.map: the map sets the arena")
        ref = raw.pop(MAP_KEY)
        if not isinstance(ref, str) or not ref:
            fail(f"spatial.{MAP_KEY}", f"must be a file name, got {kind_of(ref)}")
        arena = map_arena(folder / ref)
        raw[MAP_KEY] = str((folder / ref).resolve())  # the spec keeps where its map is
    check_table(raw, "spatial", SpatialSpec)
    for key in ("width_m", "height_m"):
        if key not in raw and arena is None:
            fail(f"spatial.{key}", "missing (or give spatial.map)")
    values = dict(raw)
    for f in tables_of(SpatialSpec):
        values[f.name] = section(raw, f.name, f.default_factory, where=f"spatial.{f.name}")
    values["sites"] = _sites(raw, types)
    if arena is None:
        return SpatialSpec(**values), Frame()
    origin = arena.origin_xy
    values["width_m"], values["height_m"] = arena.width_m, arena.height_m
    values["sites"] = tuple(shifted_points(pts, origin) for pts in values["sites"])
    own = shifted_points(values.get("obstacles", ()), origin, depth=2)
    values["obstacles"] = (*own, *arena.polygons) if isinstance(own, list | tuple) else own
    n_own = len(own) if isinstance(own, list | tuple) else 0
    return SpatialSpec(**values), Frame(origin, n_own)


def _sites(raw: dict, types: list[str]) -> tuple:
    sub = table(raw, "sites", where="spatial.sites")
    for key in sub:
        if key not in types:
            problem = f"unknown key: not one of the scenario's task types ({', '.join(types)})"
            fail(f"spatial.sites.{key}", f"{problem}{did_you_mean(key, types)}")
    out = []
    for name in types:
        if name not in sub:
            fail(
                f"spatial.sites.{name}",
                "missing: every task type needs a list of site points [[x, y], ...]",
            )
        out.append(sub[name])
    return tuple(out)


def section(doc: dict, key: str, cls: type, where: str | None = None, **convert) -> Any:
    """A table whose keys are the fields of a spec class, each optional with its default;
    ``convert`` maps a key to a function that turns its raw value into the field's."""
    where = where or key
    sub = table(doc, key, where=where)
    check_table(sub, where, cls)
    values = {k: convert[k](v) if k in convert else v for k, v in sub.items()}
    return cls(**values)


def table(doc: dict, key: str, required: bool = False, where: str | None = None) -> dict:
    """``doc[key]`` as a table ({} if absent and not required)."""
    where = where or key
    if key not in doc:
        if required:
            fail(where, "missing")
        return {}
    if not isinstance(doc[key], dict):
        fail(where, f"must be a table, got {kind_of(doc[key])}")
    return doc[key]


def string(doc: dict, path: str, optional: bool = False) -> str:
    """A non-empty string at ``path`` (its last part is the key in ``doc``)."""
    key = path.rsplit(".", 1)[-1]
    if key not in doc:
        if optional:
            return ""
        fail(path, "missing")
    val = doc[key]
    if not isinstance(val, str) or not val.strip():
        fail(path, f"must be a non-empty string, got {kind_of(val)}")
    return val


def str_list(doc: dict, path: str) -> list[str]:
    """A list of strings at ``path``."""
    key = path.rsplit(".", 1)[-1]
    if key not in doc:
        fail(path, "missing")
    val = doc[key]
    if not isinstance(val, list) or not all(isinstance(x, str) for x in val):
        fail(path, f"must be a list of strings, got {kind_of(val)}")
    return list(val)


__all__ = [
    "ROBOT_KEYS",
    "SCENARIO_KEYS",
    "SECTIONS",
    "TOP_SECTIONS",
    "ScenarioError",
    "bundled_names",
    "bundled_toml",
    "did_you_mean",
    "load_scenario",
    "locate",
    "parse_scenario",
    "read_toml",
    "resolve",
]
