"""Load and validate scenario files (TOML) into frozen :class:`sim.scenario.Scenario` values.

Validation is strict and happens before any work: an unknown key, a wrong type, a count out of
range, a NaN, a task type no robot can do or an impossible spatial layout raises
:class:`ScenarioError` whose one-line message names the file, the key path and the problem
(with a did-you-mean for unknown keys).
"""

from __future__ import annotations

import difflib
import hashlib
import math
import tomllib
from dataclasses import fields
from importlib import resources
from pathlib import Path
from typing import Any

from sim.scenario import (
    FAULT_POLICIES,
    REFUSAL_RULES,
    REPAIR_KINDS,
    DriveSpec,
    ExperienceSpec,
    FaultSpec,
    LearningSpec,
    RobotSpec,
    Scenario,
    StreamSpec,
)

MAX_ROBOTS = 5000
MAX_TYPES = 200
MAX_TASKS = 5_000_000  # sets x rounds x batch_max: beyond this a stream would not fit in memory
MAX_HISTORY_SPACE = 50_000_000  # largest per-robot Q-table (entries) we agree to allocate
MAX_HISTORY = 1000  # the state pads a history list to h entries: h itself must stay small


class ScenarioError(ValueError):
    """A scenario that cannot be used; ``str(err)`` is one line: 'file: key.path: problem'."""


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
    """Validate a parsed TOML document and build the Scenario."""
    v = Validator(source)
    sections = {"scenario", "robots", "stream", "learning", "experience", "spatial", "faults"}
    v.keys(doc, "", sections)
    head = v.table(doc, "scenario", required=True)
    v.keys(head, "scenario", {"name", "description", "task_types", "exec_time_s"})
    name = v.string(head, "scenario.name")
    v.string(head, "scenario.description", optional=True)
    types = v.str_list(head, "scenario.task_types", min_len=1, max_len=MAX_TYPES)
    if len(set(types)) != len(types):
        v.fail("scenario.task_types", "duplicate task type names")
    exec_time = v.num_list(head, "scenario.exec_time_s", len(types), lo=0.0, lo_open=False)

    robot_docs = doc.get("robots")
    if not isinstance(robot_docs, list) or not robot_docs:
        v.fail("robots", "needs at least one [[robots]] table")
    if len(robot_docs) > MAX_ROBOTS:
        v.fail("robots", f"{len(robot_docs)} robots, more than the {MAX_ROBOTS} we support")
    robots, cost_rows, seen = [], [], set()
    for j, rd in enumerate(robot_docs):
        where = f"robots[{j}]"
        if not isinstance(rd, dict):
            v.fail(where, "must be a table")
        v.keys(rd, where, {"name", "capabilities", "cost", "start", "heading_deg"})
        rname = v.string(rd, f"{where}.name")
        if rname in seen:
            v.fail(f"{where}.name", f"duplicate robot name {rname!r}")
        seen.add(rname)
        caps = v.str_list(rd, f"{where}.capabilities", min_len=1, max_len=len(types))
        for c in caps:
            if c not in types:
                v.fail(f"{where}.capabilities", f"unknown task type {c!r}{did_you_mean(c, types)}")
        if len(set(caps)) != len(caps):
            v.fail(f"{where}.capabilities", "a task type is listed twice")
        cost = v.table(rd, "cost", required=True, where=f"{where}.cost")
        row = [math.inf] * len(types)
        for key in cost:
            if key not in caps:
                v.fail(f"{where}.cost.{key}", f"not among this robot's capabilities {caps}")
            row[types.index(key)] = v.number(cost, key, where=f"{where}.cost.{key}", lo=0.0)
        for c in caps:
            if c not in cost:
                v.fail(f"{where}.cost", f"missing cost for capability {c!r}")
        start = None
        if "start" in rd:
            start = tuple(v.num_list(rd, f"{where}.start", 2))
        heading = 0.0
        if "heading_deg" in rd:
            heading = v.number(rd, "heading_deg", f"{where}.heading_deg", lo=-360.0)
            v.check(heading <= 360.0, f"{where}.heading_deg", "must be within [-360, 360] degrees")
        capable = tuple(sorted(types.index(c) for c in caps))
        robots.append(RobotSpec(rname, capable, start, float(heading)))
        cost_rows.append(tuple(row))
    covered = {i for r in robots for i in r.capabilities}
    for i, t in enumerate(types):
        if i not in covered:
            v.fail("scenario.task_types", f"task type {t!r} cannot be done by any robot")

    stream = v.section(doc, "stream", StreamSpec)
    s = stream
    v.check(s.batch_min >= 1, "stream.batch_min", "must be at least 1")
    v.check(s.batch_max >= s.batch_min, "stream.batch_max", "must be >= stream.batch_min")
    v.check(0.0 <= s.p_high <= 1.0, "stream.p_high", f"probability {s.p_high} outside [0, 1]")
    v.check(s.n_sets >= 1, "stream.n_sets", "must be at least 1")
    v.check(s.rounds_per_set >= 1, "stream.rounds_per_set", "must be at least 1")
    v.check(
        1 <= s.learn_sets <= s.n_sets, "stream.learn_sets", f"must be in 1..n_sets ({s.n_sets})"
    )
    v.check(1 <= s.test_sets <= s.n_sets, "stream.test_sets", f"must be in 1..n_sets ({s.n_sets})")
    v.check(s.announce_interval_s > 0, "stream.announce_interval_s", "must be > 0")
    n_tasks = s.n_sets * s.rounds_per_set * s.batch_max
    v.check(n_tasks <= MAX_TASKS, "stream", f"up to {n_tasks:,} tasks: more than {MAX_TASKS:,}")

    learning = v.section(doc, "learning", LearningSpec)
    lp = learning
    v.check(0.0 < lp.alpha <= 1.0, "learning.alpha", "must be in (0, 1]")
    v.check(0.0 <= lp.gamma < 1.0, "learning.gamma", "must be in [0, 1)")
    for key in ("epsilon_start", "epsilon_end", "epsilon_decay"):
        val = getattr(lp, key)
        v.check(0.0 <= val <= 1.0, f"learning.{key}", f"{val} outside [0, 1]")
    v.check(lp.history >= 1, "learning.history", "must be at least 1")
    v.check(lp.history <= MAX_HISTORY, "learning.history", f"must be at most {MAX_HISTORY:,}")
    widest = max(len(r.capabilities) for r in robots)
    if lp.history * math.log(widest) > math.log(MAX_HISTORY_SPACE):  # no huge int powers
        digits = lp.history * math.log10(widest) + math.log10(2)
        v.fail(
            "learning.history",
            f"a robot's Q-table would have about 10^{digits:.0f} entries "
            f"(limit {MAX_HISTORY_SPACE:,})",
        )
    for key in ("reward_high", "reward_low", "penalty_lost_high"):
        v.check(getattr(lp, key) >= 0, f"learning.{key}", "must be >= 0")

    experience = v.section(doc, "experience", ExperienceSpec)
    e = experience
    v.check(0.0 <= e.delta_v <= 1.0, "experience.delta_v", "must be in [0, 1]")
    v.check(0.0 <= e.delta_u <= 2.0, "experience.delta_u", "must be in [0, 2] (TEM lies in (0, 2))")
    v.check(e.n_min >= 1, "experience.n_min", "must be at least 1")
    v.check(e.coverage_k >= 1, "experience.coverage_k", "must be at least 1")
    if e.refusal not in REFUSAL_RULES:
        hint = did_you_mean(e.refusal, REFUSAL_RULES)
        v.fail(
            "experience.refusal", f"unknown rule {e.refusal!r}{hint}; one of {list(REFUSAL_RULES)}"
        )

    faults = parse_faults(v, doc, [r.name for r in robots])

    spatial = None
    if "spatial" in doc:
        from scenarios.spatial_schema import parse_spatial

        spatial = parse_spatial(v, doc, types, robots)
    return Scenario(
        name=name,
        task_types=tuple(types),
        robots=tuple(robots),
        cost=tuple(cost_rows),
        exec_time_s=tuple(exec_time),
        stream=stream,
        learning=learning,
        experience=experience,
        spatial=spatial,
        faults=faults,
        source=source,
        source_sha256=sha256,
    )


FAULT_KEYS = {"mttf_s", "mttf_by_robot", "repair_s", "repair", "p_permanent", "policy"}


def parse_faults(v: Validator, doc: dict, names: list[str]) -> FaultSpec:
    """The ``[faults]`` table (every key optional; absent or empty: no robot breaks)."""
    table = v.table(doc, "faults")
    v.keys(table, "faults", FAULT_KEYS)
    values: dict[str, Any] = {}
    if "mttf_s" in table:
        values["mttf_s"] = _mttf(v, table, "mttf_s", "faults.mttf_s")
    if "mttf_by_robot" in table:
        own = v.table(table, "mttf_by_robot", where="faults.mttf_by_robot")
        pairs = []
        for name in own:
            where = f"faults.mttf_by_robot.{name}"
            if name not in names:
                v.fail(where, f"no robot named {name!r}{did_you_mean(name, names)}")
            pairs.append((name, _mttf(v, own, name, where)))
        values["mttf_by_robot"] = tuple(pairs)
    if "repair_s" in table:
        values["repair_s"] = v.number(table, "repair_s", "faults.repair_s", lo=0.0)
    if "p_permanent" in table:
        p = v.number(table, "p_permanent", "faults.p_permanent", lo=0.0)
        v.check(p <= 1.0, "faults.p_permanent", f"probability {p} outside [0, 1]")
        values["p_permanent"] = p
    for key, options in (("repair", REPAIR_KINDS), ("policy", FAULT_POLICIES)):
        if key in table:
            word = table[key]
            if not isinstance(word, str):
                v.fail(f"faults.{key}", f"must be a string, got {_kind(word)}")
            if word not in options:
                hint = did_you_mean(word, options)
                v.fail(f"faults.{key}", f"unknown {key} {word!r}{hint}; one of {list(options)}")
            values[key] = word
    return FaultSpec(**values)


def _mttf(v: Validator, table: dict, key: str, where: str) -> float:
    """A mean time to failure: a number > 0, or inf / "inf" (never breaks)."""
    val = table[key]
    if val == "inf" or (isinstance(val, float) and val == math.inf):
        return math.inf
    return v.number(table, key, where, lo=0.0, lo_open=True)


def did_you_mean(word: str, options) -> str:
    """' (did you mean 'x'?)' for the closest option, ignoring case; '' if none is close."""
    lower = {str(o).lower(): o for o in options}
    close = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return f" (did you mean {lower[close[0]]!r}?)" if close else ""


class Validator:
    """Small helpers that raise ScenarioError('source: path: problem')."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, problem: str):
        raise ScenarioError(f"{self.source}: {path or '<top level>'}: {problem}")

    def check(self, ok: bool, path: str, problem: str) -> None:
        if not ok:
            self.fail(path, problem)

    def keys(self, table: dict, path: str, allowed: set[str], problem: str = "unknown key") -> None:
        """Fail on the first key not in ``allowed``: ``problem`` and a did-you-mean."""
        for key in table:
            if key not in allowed:
                where = f"{path}.{key}" if path else key
                self.fail(where, f"{problem}{did_you_mean(key, sorted(allowed))}")

    def table(self, doc: dict, key: str, required: bool = False, where: str | None = None) -> dict:
        where = where or key
        if key not in doc:
            if required:
                self.fail(where, "missing")
            return {}
        if not isinstance(doc[key], dict):
            self.fail(where, f"must be a table, got {_kind(doc[key])}")
        return doc[key]

    def string(self, table: dict, path: str, optional: bool = False) -> str:
        key = path.rsplit(".", 1)[-1]
        if key not in table:
            if optional:
                return ""
            self.fail(path, "missing")
        val = table[key]
        if not isinstance(val, str) or not val.strip():
            self.fail(path, f"must be a non-empty string, got {_kind(val)}")
        return val

    def str_list(self, table: dict, path: str, min_len: int, max_len: int) -> list[str]:
        key = path.rsplit(".", 1)[-1]
        if key not in table:
            self.fail(path, "missing")
        val = table[key]
        if not isinstance(val, list) or not all(isinstance(x, str) for x in val):
            self.fail(path, f"must be a list of strings, got {_kind(val)}")
        if not min_len <= len(val) <= max_len:
            self.fail(path, f"needs {min_len} to {max_len} entries, got {len(val)}")
        return list(val)

    def number(
        self,
        table: dict,
        key: str,
        where: str,
        lo: float | None = None,
        lo_open: bool = False,
        integer: bool = False,
    ) -> float:
        val = table[key]
        if isinstance(val, bool) or not isinstance(val, int | float):
            self.fail(where, f"must be a number, got {_kind(val)}")
        if integer and not isinstance(val, int):
            self.fail(where, f"must be an integer, got {val!r}")
        if not math.isfinite(val):
            self.fail(where, f"must be finite, got {val}")
        if lo is not None and (val < lo or (lo_open and val == lo)):
            self.fail(where, f"must be {'>' if lo_open else '>='} {lo:g}, got {val}")
        return val if integer else float(val)

    def num_list(
        self, table: dict, path: str, length: int, lo: float | None = None, lo_open: bool = False
    ) -> list[float]:
        key = path.rsplit(".", 1)[-1]
        if key not in table:
            self.fail(path, "missing")
        val = table[key]
        if not isinstance(val, list):
            self.fail(path, f"must be a list of {length} numbers, got {_kind(val)}")
        if len(val) != length:
            self.fail(path, f"must have {length} entries, got {len(val)}")
        return [self.number(val, i, f"{path}[{i}]", lo=lo, lo_open=lo_open) for i in range(length)]

    def section(self, doc: dict, key: str, cls):
        """A table whose keys are the fields of a dataclass, each optional with its default."""
        table = self.table(doc, key)
        names = {f.name: f for f in fields(cls)}
        self.keys(table, key, set(names))
        values = {}
        for name, val in table.items():
            default = getattr(cls(), name)
            where = f"{key}.{name}"
            if isinstance(default, bool):
                if not isinstance(val, bool):
                    self.fail(where, f"must be true or false, got {_kind(val)}")
                values[name] = val
            elif isinstance(default, str):
                if not isinstance(val, str):
                    self.fail(where, f"must be a string, got {_kind(val)}")
                values[name] = val
            elif isinstance(default, int):
                values[name] = self.number(table, name, where, integer=True)
            else:
                values[name] = self.number(table, name, where)
        return cls(**values)


def _kind(val: Any) -> str:
    if isinstance(val, bool):
        return f"boolean {str(val).lower()}"
    if isinstance(val, str):
        return f"string {val!r}"
    if isinstance(val, int | float):
        return f"number {val}"
    if isinstance(val, list):
        return "a list"
    if isinstance(val, dict):
        return "a table"
    return type(val).__name__


__all__ = [
    "DriveSpec",
    "ScenarioError",
    "Validator",
    "bundled_names",
    "bundled_toml",
    "did_you_mean",
    "load_scenario",
    "locate",
    "parse_scenario",
    "resolve",
]
