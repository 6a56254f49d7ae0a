"""Run manifests: everything needed to repeat a run and check that it was repeated.

Every output folder gets ``run_manifest.json``: package and library versions, Python, the
command line, the scenario (name, file, SHA-256 and its full TOML text) and the run specs
(allocator, cost model, seed, overrides), and the numerics a run's last bits depend on
(:func:`numerics`). ``mrta run --replay MANIFEST`` re-runs the spec on the scenario text stored
in the manifest and must give an identical ``metrics.json`` on a machine with the same numerics;
where they differ it says so on one line (:func:`numerics_note`) and runs anyway. A scenario on a
ROS map (``[spatial] map``) records the map by its resolved path and content digest, not its
polygons: the replay reads that file again and refuses one whose content has changed.
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import re
import sys
import tomllib
from dataclasses import asdict, fields
from importlib import metadata
from pathlib import Path

from scenarios.experiments.output import write_json_atomic
from scenarios.experiments.protocol import RunSpec, UserError
from sim.maps import MapError, load_map
from sim.scenario import Scenario

MANIFEST_FORMAT = "expt-mrta-manifest/1"
LIBRARIES = ("numpy", "scipy", "pymunk", "gymnasium", "matplotlib", "pillow", "tqdm")


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "not installed"


def numerics() -> dict:
    """What a run's floating-point bits depend on beyond the library versions: the machine's
    architecture and the SIMD kernels numpy dispatches to here (its exp, log, arctan2, power
    and complex products round differently with AVX-512, AVX2 or its baseline kernels; README,
    "Reliability"), with the environment variables that choose them."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy 1.x
        from numpy.core import _multiarray_umath as umath

    found = getattr(umath, "__cpu_features__", {})
    return {
        "machine": platform.machine(),
        "numpy_baseline": list(getattr(umath, "__cpu_baseline__", [])),
        "numpy_dispatch": [f for f in getattr(umath, "__cpu_dispatch__", []) if found.get(f)],
        "env": {
            k: os.environ[k]
            for k in ("NPY_ENABLE_CPU_FEATURES", "NPY_DISABLE_CPU_FEATURES")
            if k in os.environ
        },
    }


def numerics_note(doc: dict) -> str | None:
    """One line when the manifest ``doc`` was written with other numerics than this process
    has (so a replay may differ in the last bits, and a spatial run in more); None when they
    match or the manifest predates the record."""
    then = doc.get("numerics")
    if not isinstance(then, dict):
        return None
    now = numerics()
    keys = ("machine", "numpy_baseline", "numpy_dispatch")
    if all(then.get(k) == now[k] for k in keys):
        return None
    was = f"{then.get('machine')} {'+'.join(then.get('numpy_dispatch') or ['baseline'])}"
    here = f"{now['machine']} {'+'.join(now['numpy_dispatch'] or ['baseline'])}"
    return (
        f"recorded with numpy kernels {was}, here {here}: results may differ from the "
        "recorded ones (NPY_ENABLE_CPU_FEATURES=X86_V2 on both sides makes x86-64 runs match)"
    )


def build_manifest(scenario: Scenario, specs: list[RunSpec], argv: list[str] | None = None) -> dict:
    text = (
        Path(scenario.source).read_text()
        if scenario.source and Path(scenario.source).is_file()
        else ""
    )
    return {
        "format": MANIFEST_FORMAT,
        "package": {"name": "expt-mrta", "version": _version("expt-mrta")},
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "libraries": {lib: _version(lib) for lib in LIBRARIES},
        "numerics": numerics(),
        "command": ["mrta", *(argv if argv is not None else sys.argv[1:])],
        "scenario": {
            "name": scenario.name,
            "source": scenario.source,
            "sha256": scenario.source_sha256,
            "toml": text,
            **_map_record(scenario),
        },
        "runs": [asdict(s) for s in specs],
    }


def write_manifest(out: Path, manifest: dict) -> Path:
    path = Path(out) / "run_manifest.json"
    write_json_atomic(path, manifest)
    return path


def read_manifest(path: Path, scratch: Path) -> tuple[dict, list[RunSpec]]:
    """Load a manifest; its scenario is re-materialised from the stored TOML text in ``scratch``."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise UserError(f"{path}: manifest not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UserError(f"{path}: not a readable manifest ({type(exc).__name__})") from None
    if not isinstance(doc, dict) or doc.get("format") != MANIFEST_FORMAT:
        raise UserError(f"{path}: not an expt-mrta run manifest")
    scen = doc.get("scenario", {})
    text = scen.get("toml", "")
    if not text or hashlib.sha256(text.encode()).hexdigest() != scen.get("sha256"):
        raise UserError(
            f"{path}: scenario.toml: stored scenario text missing or does not match its sha256"
        )
    scratch.mkdir(parents=True, exist_ok=True)
    stored = scratch / f"{scen.get('name', 'scenario')}.replay.toml"
    text = _pointed_at_map(text, scen.get("map"), path)
    if not stored.is_file() or stored.read_text() != text:
        stored.write_text(text)
    names = {f.name for f in fields(RunSpec)}
    specs = []
    for k, run in enumerate(doc.get("runs", [])):
        unknown = set(run) - names
        if unknown:
            raise UserError(f"{path}: runs[{k}]: unknown keys {sorted(unknown)}")
        run = {
            **run,
            "scenario": str(stored),
            "overrides": tuple(tuple(o) for o in run["overrides"]),
        }
        specs.append(RunSpec(**run))
    if not specs:
        raise UserError(f"{path}: runs: no run recorded")
    return doc, specs


def _map_record(scenario: Scenario) -> dict:
    """``{"map": {"path", "sha256"}}`` for a scenario on a ROS map, else ``{}``."""
    sp = scenario.spatial
    if sp is None or not sp.map:
        return {}
    return {"map": {"path": sp.map, "sha256": load_map(sp.map).sha256}}


MAP_LINE = re.compile(r"^(\s*map\s*=\s*).*$", re.MULTILINE)


def _pointed_at_map(text: str, record: object, manifest: Path) -> str:
    """The stored scenario text with its ``[spatial] map`` (relative to a folder the replay
    does not run in) replaced by the recorded path, once that file is checked to hold the
    recorded map."""
    if not isinstance(record, dict):
        return text
    where = f"{manifest}: scenario.map"
    map_path, digest = record.get("path"), record.get("sha256")
    if not isinstance(map_path, str) or not isinstance(digest, str):
        raise UserError(f"{where}: needs a path and a sha256")
    try:
        now = load_map(map_path).sha256
    except MapError as err:
        raise UserError(f"{where}: {err}") from None
    if now != digest:
        raise UserError(f"{where}: {map_path} has changed since the run (sha256 {now[:12]}...)")
    out, count = MAP_LINE.subn(lambda m: m.group(1) + json.dumps(map_path), text, count=1)
    if count != 1 or tomllib.loads(out).get("spatial", {}).get("map") != map_path:
        raise UserError(f"{where}: cannot point the stored scenario at {map_path}")
    return out


__all__ = ["build_manifest", "numerics", "numerics_note", "read_manifest", "write_manifest"]
