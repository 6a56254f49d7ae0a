"""Sweep files: strict validation and expansion into run specs (run by
:mod:`scenarios.sweep.runner`).

Every problem raises :class:`scenarios.loader.ScenarioError` with one line
``file: key.path: problem`` (unknown keys get a did-you-mean), before anything runs. Parameter
values are checked by the scenario loader itself: each combination is applied to the raw
scenario document and validated like a scenario file, so a sweep can never run a scenario that
``mrta validate`` would refuse.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from allocation.costs import COST_MODELS
from learning.registry import AllocatorError, allocator_class
from scenarios.experiments.budget import MAX_RUNS, MAX_SEEDS
from scenarios.experiments.protocol import RunSpec
from scenarios.loader import (
    ScenarioError,
    bundled_toml,
    did_you_mean,
    locate,
    parse_scenario,
    read_toml,
    resolve,
)
from scenarios.sweep.columns import METRIC_COLUMNS
from sim.scenario import Scenario
from sim.scenario.overrides import TOP_TABLES, apply_overrides, setting_paths
from sim.spatial.layout import check_layout

# every setting a sweep may set, by key path, and its default (which gives its type)
PARAMETERS = {
    path: cls.__dataclass_fields__[name].default for path, (cls, name, _) in setting_paths().items()
}
INFINITE_OK = {path for path, (_, _, meta) in setting_paths().items() if meta.inf_ok}
SECTIONS = (*TOP_TABLES, "spatial")
TOP_KEYS = {"sweep", "fixed", "grid", "points"}
SWEEP_KEYS = {"name", "description", "scenarios", "allocators", "costs", "seeds"}

Value = bool | int | float | str


@dataclass(frozen=True, slots=True)
class SweepRun:
    """One run of a sweep: the protocol's spec plus the labels its CSV row carries."""

    spec: RunSpec
    scenario: str  # as written in the sweep file
    values: tuple[Value, ...]  # one per swept parameter


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: what to run, in spec order."""

    name: str
    source: str
    sha256: str
    scenarios: tuple[str, ...]
    allocators: tuple[str, ...]
    costs: tuple[str, ...]
    seeds: tuple[int, ...]
    fixed: tuple[tuple[str, Value], ...]
    parameters: tuple[str, ...]
    combos: tuple[tuple[Value, ...], ...]
    runs: tuple[SweepRun, ...]
    description: str = ""

    def key_columns(self) -> list[str]:
        """Columns that identify a run: scenario, allocator, cost, seed, swept parameters."""
        return ["scenario", "allocator", "cost", "seed", *self.parameters]

    def columns(self) -> list[str]:
        """Every runs.csv column: the key columns, then the metric columns."""
        return self.key_columns() + list(METRIC_COLUMNS)

    @property
    def metric_columns(self) -> tuple[str, ...]:
        """The metric columns of runs.csv (:data:`scenarios.sweep.columns.METRIC_COLUMNS`)."""
        return METRIC_COLUMNS

    def key_row(self, run: SweepRun) -> list[str]:
        """The key columns of a run as CSV text."""
        s = run.spec
        return [run.scenario, s.allocator, s.cost, str(s.seed), *map(fmt_value, run.values)]

    def key(self, run: SweepRun) -> tuple[str, ...]:
        """The run's identity in runs.csv (what resume matches on)."""
        return tuple(self.key_row(run))


def _pairs(parameters: tuple[str, ...], combo: tuple[Value, ...]) -> tuple[tuple[str, Value], ...]:
    return tuple(zip(parameters, combo, strict=True))


def fmt_value(value: Value) -> str:
    """CSV text of a parameter value: true/false, integers as such, floats round-trip exact."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value
    if isinstance(value, int):
        return str(value)
    return repr(float(value))


def bundled_sweeps() -> list[str]:
    """Names of the example sweeps shipped in ``scenarios/data/sweeps``."""
    return bundled_toml("sweeps")


def _resolve_sweep(name_or_path: str | Path) -> Path:
    path = locate(name_or_path, "sweeps")
    if path is None:
        hint = did_you_mean(str(name_or_path), bundled_sweeps())
        raise ScenarioError(f"{name_or_path}: no such sweep file or bundled sweep{hint}")
    return path


def load_sweep(name_or_path: str | Path) -> SweepSpec:
    """Read and validate a sweep file (a path, or a bundled sweep name)."""
    path = _resolve_sweep(name_or_path)
    doc, raw = read_toml(path)
    return _Parser(path).parse(doc, hashlib.sha256(raw).hexdigest())


class _Parser:
    """Validation helpers raising ScenarioError('file: key.path: problem')."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def fail(self, where: str, problem: str):
        raise ScenarioError(f"{self.path}: {where}: {problem}")

    def keys(self, table: dict, where: str, allowed: set[str]) -> None:
        for key in table:
            if key not in allowed:
                full = f"{where}.{key}" if where else key
                self.fail(full, f"unknown key{did_you_mean(key, sorted(allowed))}")

    def names(
        self, table: dict, key: str, choices, default=None, where: str = "sweep"
    ) -> tuple[str, ...]:
        where = f"{where}.{key}"
        val = table.get(key, default)
        if val is None:
            self.fail(where, "missing")
        if isinstance(val, str):
            val = [val]
        if not isinstance(val, list) or not val or not all(isinstance(v, str) for v in val):
            self.fail(where, "must be a non-empty list of strings")
        if len(set(val)) != len(val):
            self.fail(where, "lists a name twice")
        for i, v in enumerate(val):
            if choices is not None and v not in choices:
                hint = did_you_mean(v, choices)
                self.fail(
                    f"{where}[{i}]", f"unknown {key[:-1]} {v!r}{hint}; one of {sorted(choices)}"
                )
        return tuple(val)

    def seeds(self, table: dict) -> tuple[int, ...]:
        val = table.get("seeds")
        if val is None:
            self.fail("sweep.seeds", "missing (a count N for seeds 0..N-1, or a list)")
        if isinstance(val, int) and not isinstance(val, bool):
            if val < 1:
                self.fail("sweep.seeds", f"need at least one seed, got {val}")
            if val > MAX_SEEDS:
                self.fail("sweep.seeds", f"{val:,} seeds: at most {MAX_SEEDS:,} in one sweep")
            return tuple(range(val))
        ok = (
            isinstance(val, list)
            and val
            and all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in val)
        )
        if not ok:
            self.fail("sweep.seeds", "must be a count >= 1 or a non-empty list of integers >= 0")
        if len(set(val)) != len(val):
            self.fail("sweep.seeds", "lists a seed twice")
        if len(val) > MAX_SEEDS:
            self.fail("sweep.seeds", f"{len(val):,} seeds: at most {MAX_SEEDS:,} in one sweep")
        return tuple(val)

    def value(self, where: str, param: str, val: Any) -> Value:
        default = PARAMETERS[param]
        if isinstance(default, str):
            if not isinstance(val, str):
                self.fail(where, f"must be a string, got {val!r}")
            return val
        if isinstance(default, bool):
            if not isinstance(val, bool):
                self.fail(where, f"must be true or false, got {val!r}")
            return val
        if isinstance(val, bool) or not isinstance(val, int | float):
            self.fail(where, f"must be a number, got {val!r}")
        if isinstance(default, int) and not isinstance(val, int):
            self.fail(where, f"must be an integer, got {val!r}")
        if not math.isfinite(val) and not (param in INFINITE_OK and val == math.inf):
            self.fail(where, f"must be finite, got {val}")
        return val if isinstance(default, int) else float(val)

    def params(self, table: Any, where: str) -> dict[str, Any]:
        """Flatten ``{"experience.delta_u": v}``, ``{"experience": {"delta_u": v}}`` or
        ``{"spatial": {"orca": {"tau_s": v}}}``."""
        if not isinstance(table, dict):
            self.fail(where, "must be a table of parameter = value(s)")
        flat: dict[str, Any] = {}

        def walk(prefix: str, sub: dict) -> None:
            for key, val in sub.items():
                if isinstance(val, dict):
                    walk(f"{prefix}{key}.", val)
                else:
                    flat[f"{prefix}{key}"] = val

        walk("", table)
        for key in flat:
            if key not in PARAMETERS:
                section = key.partition(".")[0]
                if section not in SECTIONS:
                    hint = did_you_mean(key, list(PARAMETERS))
                    hint = hint or f" (sections: {', '.join(SECTIONS)})"
                else:
                    hint = did_you_mean(key, list(PARAMETERS))
                self.fail(f"{where}.{key}", f"unknown parameter{hint}")
        return flat

    def parse(self, doc: dict, sha256: str) -> SweepSpec:
        self.keys(doc, "", TOP_KEYS)
        head = doc.get("sweep")
        if not isinstance(head, dict):
            self.fail("sweep", "missing [sweep] table")
        self.keys(head, "sweep", SWEEP_KEYS)
        name = head.get("name", self.path.stem)
        if not isinstance(name, str) or not name.strip() or "/" in name:
            self.fail("sweep.name", "must be a non-empty string without '/'")
        description = head.get("description", "")
        if not isinstance(description, str):
            self.fail("sweep.description", "must be a string")
        scenarios = self.names(head, "scenarios", None)
        allocators = self.names(head, "allocators", None)
        for i, a in enumerate(allocators):
            try:
                allocator_class(a)
            except AllocatorError as exc:
                self.fail(f"sweep.allocators[{i}]", str(exc))
        costs = self.names(head, "costs", set(COST_MODELS), default=["abstract"])
        seeds = self.seeds(head)
        fixed_raw = self.params(doc.get("fixed", {}), "fixed")
        fixed = tuple((p, self.value(f"fixed.{p}", p, v)) for p, v in fixed_raw.items())
        parameters, combos, origin, only = self.combos(doc, fixed_raw, allocators)
        refs = [self.scenario_ref(i, s) for i, s in enumerate(scenarios)]
        for label, (_, scenario) in zip(scenarios, refs, strict=True):
            self.check_costs(label, scenario, costs)
            self.check_values(label, scenario, fixed, (), (), "fixed")
            for combo, where in zip(combos, origin, strict=True):
                self.check_values(label, scenario, fixed, parameters, combo, where)
        n_runs = (
            len(scenarios)
            * len(costs)
            * len(seeds)
            * sum(len(allocators if o is None else o) for o in only)
        )
        if n_runs > MAX_RUNS:
            self.fail("sweep", f"{n_runs:,} runs, more than the {MAX_RUNS:,} we accept")
        runs = tuple(
            SweepRun(RunSpec(ref, a, c, s, fixed + _pairs(parameters, combo)), label, combo)
            for label, (ref, _) in zip(scenarios, refs, strict=True)
            for a in allocators
            for c in costs
            for combo, o in zip(combos, only, strict=True)
            if o is None or a in o
            for s in seeds
        )
        return SweepSpec(
            name, str(self.path), sha256, scenarios, allocators, costs, seeds, fixed,
            parameters, combos, runs, description,
        )  # fmt: skip

    def combos(self, doc: dict, fixed: dict, allocators: tuple[str, ...]):
        """(parameters, value combinations, where each came from, allocators of each or None)
        of [grid] or [[points]]; a point may name the allocators it applies to."""
        if "grid" in doc and "points" in doc:
            self.fail("points", "use either [grid] or [[points]], not both")
        only: list[tuple[str, ...] | None] = []
        if "points" in doc:
            points = doc["points"]
            if not isinstance(points, list) or not points:
                self.fail("points", "must be a non-empty array of tables [[points]]")
            stripped = []
            for i, p in enumerate(points):
                if isinstance(p, dict) and "allocators" in p:
                    p = dict(p)
                    only.append(self.names(p, "allocators", set(allocators), where=f"points[{i}]"))
                    del p["allocators"]
                else:
                    only.append(None)
                stripped.append(p)
            points = stripped
            flat = [self.params(p, f"points[{i}]") for i, p in enumerate(points)]
            parameters = tuple(flat[0])
            for i, p in enumerate(flat):
                if set(p) != set(parameters):
                    self.fail(
                        f"points[{i}]", f"must set the same parameters as points[0]: {parameters}"
                    )
            combos = [
                tuple(self.value(f"points[{i}].{k}", k, p[k]) for k in parameters)
                for i, p in enumerate(flat)
            ]
            if len(set(zip(combos, only, strict=True))) != len(combos):
                self.fail("points", "two points are equal")
            origin = [f"points[{i}]" for i in range(len(combos))]
        else:
            grid = self.params(doc.get("grid", {}), "grid")
            parameters = tuple(grid)
            axes = []
            for p, vals in grid.items():
                if not isinstance(vals, list) or not vals:
                    self.fail(f"grid.{p}", "must be a non-empty list of values")
                vals = [self.value(f"grid.{p}[{i}]", p, v) for i, v in enumerate(vals)]
                if len(set(vals)) != len(vals):
                    self.fail(f"grid.{p}", "lists a value twice")
                axes.append(vals)
            combos = list(itertools.product(*axes))
            origin = ["grid"] * len(combos)
            only = [None] * len(combos)
        for p in parameters:
            if p in fixed:
                self.fail(f"fixed.{p}", "is also swept; set it in one place only")
        return parameters, tuple(combos), origin, only

    def scenario_ref(self, i: int, label: str) -> tuple[str, Scenario]:
        """(what RunSpec.scenario should hold, the scenario)."""
        candidate = Path(label)
        if not candidate.is_absolute() and (self.path.parent / candidate).is_file():
            candidate = self.path.parent / candidate
        try:
            path = resolve(candidate if candidate.is_file() else label)
            raw = tomllib.loads(path.read_text())
            scenario = parse_scenario(raw, source=str(path))
        except ScenarioError as exc:
            self.fail(f"sweep.scenarios[{i}]", str(exc))
        except (OSError, tomllib.TOMLDecodeError) as exc:
            self.fail(f"sweep.scenarios[{i}]", f"cannot read scenario {label!r}: {exc}")
        ref = str(path.resolve()) if candidate.is_file() else label
        return ref, scenario

    def check_costs(self, label: str, scenario: Scenario, costs: tuple[str, ...]) -> None:
        for i, c in enumerate(costs):
            if c != "abstract" and scenario.spatial is None:
                self.fail(
                    f"sweep.costs[{i}]",
                    f"cost model {c!r} needs a spatial scenario; {label!r} has no [spatial] table",
                )

    def check_values(self, label, scenario, fixed, parameters, combo, where) -> None:
        """Validate one combination as a run applies it (``apply_overrides``: each spec checks
        its settings; the layout again where a spatial setting changed)."""
        pairs = list(fixed) + list(zip(parameters, combo, strict=True))
        origin = {p: "fixed" for p, _ in fixed} | dict.fromkeys(parameters, where)
        try:
            changed = apply_overrides(scenario, pairs)
            if any(p.startswith("spatial.") for p, _ in pairs):
                check_layout(changed)
        except ScenarioError as exc:
            bad, problem = exc.path, exc.problem
            if bad in origin:
                self.fail(f"{origin[bad]}.{bad}", f"{problem} (scenario {label!r})")
            values = [f"{p} = {fmt_value(v)}" for p, v in zip(parameters, combo, strict=True)]
            at = f" at {', '.join(values)}" if values else ""
            self.fail(
                where if values else "fixed",
                f"makes scenario {label!r} invalid{at}: {bad}: {problem}",
            )
