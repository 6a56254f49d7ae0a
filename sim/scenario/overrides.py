"""Changing a scenario's settings by key path: the door runs, sweeps and environments use.

``apply_overrides(scenario, [("experience.delta_u", 0.1), ("spatial.orca.tau_s", 2.0)])``
returns the scenario with those settings replaced. The new values go through the same checks as
a scenario file's (each spec checks itself when it is built), so a value a file could not hold
is refused here too, with the same one-line message (``override: key.path: problem``). Every
override of one table is applied at once: ``stream.n_sets = 3`` with ``stream.learn_sets = 2``
is one change, not a scenario with 30 learning sets of 3.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from typing import Any

from sim.scenario.core import Scenario
from sim.scenario.schema import (
    ScenarioError,
    Setting,
    did_you_mean,
    fail,
    settings_of,
    tables_of,
)
from sim.scenario.spatial import SpatialSpec

TOP_TABLES = ("stream", "learning", "experience", "faults")


def setting_paths(spatial: bool = True) -> dict[str, tuple[type, str, Setting]]:
    """Every setting a run may override, by key path: (spec class, field name, declaration).

    Args:
        spatial: include the ``[spatial]`` table and its sub-tables.
    """
    from sim.scenario.core import ExperienceSpec, FaultSpec, LearningSpec, StreamSpec

    out: dict[str, tuple[type, str, Setting]] = {}
    tables: list[tuple[str, type]] = [
        ("stream", StreamSpec),
        ("learning", LearningSpec),
        ("experience", ExperienceSpec),
        ("faults", FaultSpec),
    ]
    if spatial:
        tables.append(("spatial", SpatialSpec))
        tables += [(f"spatial.{f.name}", f.default_factory) for f in tables_of(SpatialSpec)]
    for prefix, cls in tables:
        for f, meta in settings_of(cls):
            if prefix == "spatial" and f.name in ("width_m", "height_m"):
                continue  # the arena's size goes with its obstacles and sites: not overridable
            out[f"{prefix}.{f.name}"] = (cls, f.name, meta)
    return out


def apply_overrides(scenario: Scenario, overrides: Sequence[tuple[str, Any]]) -> Scenario:
    """The scenario with ``section.key`` (or ``spatial.table.key``) settings replaced.

    Raises:
        ScenarioError: an unknown path, or a value its setting refuses (one line, prefixed
            ``override:``).
    """
    if not overrides:
        return scenario
    try:
        return _apply(scenario, overrides)
    except ScenarioError as err:
        raise err.located("override") from None


def _apply(scenario: Scenario, overrides: Iterable[tuple[str, Any]]) -> Scenario:
    known = setting_paths()
    changes: dict[str, dict[str, Any]] = {}
    spatial_paths = [str(p) for p, _ in overrides if str(p).startswith("spatial.")]
    for path, value in overrides:
        if path not in known:
            fail(path, f"not a setting that can be overridden{did_you_mean(path, known)}")
        table, _, key = str(path).rpartition(".")
        changes.setdefault(table, {})[key] = value
    top: dict[str, Any] = {}
    for name in TOP_TABLES:
        if name in changes:
            top[name] = dataclasses.replace(getattr(scenario, name), **changes[name])
    if any(t == "spatial" or t.startswith("spatial.") for t in changes):
        if scenario.spatial is None:
            fail(spatial_paths[0], f"{scenario.name!r} has no [spatial] table")
        sp = scenario.spatial
        inner = {
            t.removeprefix("spatial."): dataclasses.replace(getattr(sp, t[8:]), **kv)
            for t, kv in changes.items()
            if t.startswith("spatial.")
        }
        top["spatial"] = dataclasses.replace(sp, **changes.get("spatial", {}), **inner)
    return dataclasses.replace(scenario, **top)


__all__ = ["TOP_TABLES", "apply_overrides", "setting_paths"]
