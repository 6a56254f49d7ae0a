"""Map geometry cached on disk, keyed by the map's content and the geometry's parameters.

Preparing a large map takes seconds; its polygons depend only on the YAML and image bytes and
on the parameters of :func:`sim.maps.geometry.map_obstacles`, so they are stored once per key
(the sha256 of the map's sha256, the parameters and a format version) as an ``.npz`` file read
with ``allow_pickle=False``. A file is written to a temporary name and moved into place with
``os.replace``, so readers never see half a file; a file that cannot be read, or that holds
something else than its name promises, is ignored and written anew. A cache folder that cannot
be written only costs the time to prepare the map again.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from sim.maps.geometry import MapGeometry, map_obstacles
from sim.maps.occupancy import OccupancyMap

FORMAT = 1  # bump when the geometry or the file layout changes: old files are then not found
_COUNTS = ("specks_dropped", "pockets_filled")
_AREAS = ("speck_area_m2", "pocket_area_m2")


def default_cache_dir() -> Path:
    """The user's cache folder for map geometry (``~/.cache/expt-mrta/maps`` on Linux,
    ``~/Library/Caches/expt-mrta/maps`` on macOS, ``~/AppData/Local/expt-mrta/Cache/maps`` on
    Windows); nothing is read from the environment, so a run depends on its arguments only."""
    home = Path.home()
    if sys.platform == "darwin":
        return home / "Library" / "Caches" / "expt-mrta" / "maps"
    if sys.platform.startswith("win"):
        return home / "AppData" / "Local" / "expt-mrta" / "Cache" / "maps"
    return home / ".cache" / "expt-mrta" / "maps"


def geometry_key(occ: OccupancyMap, params: dict[str, float | bool]) -> str:
    """sha256 naming one map's geometry under one set of parameters."""
    text = json.dumps({"format": FORMAT, "map": occ.sha256, **params}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def cached_obstacles(
    occ: OccupancyMap,
    *,
    cache_dir: str | Path | None = None,
    min_speck_m2: float = 0.004,
    min_pocket_m2: float = 0.01,
    fill_detached: bool = False,
    tolerance_m: float = 0.05,
) -> MapGeometry:
    """:func:`sim.maps.geometry.map_obstacles`, read from the cache if it is there.

    Args:
        occ: the map.
        cache_dir: the cache folder (created if missing); None: :func:`default_cache_dir`.
        min_speck_m2, min_pocket_m2, fill_detached, tolerance_m: as ``map_obstacles``.
    """
    params = {
        "min_speck_m2": float(min_speck_m2),
        "min_pocket_m2": float(min_pocket_m2),
        "fill_detached": bool(fill_detached),
        "tolerance_m": float(tolerance_m),
    }
    folder = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = geometry_key(occ, params)
    path = folder / f"{key}.npz"
    hit = read_geometry(path, key, occ, params)
    if hit is not None:
        return hit
    geometry = map_obstacles(occ, **params)
    try:
        write_geometry(path, key, geometry)
    except OSError:  # a read-only or full cache folder costs time, not the result
        pass
    return geometry


def read_geometry(
    path: Path, key: str, occ: OccupancyMap, params: dict[str, float | bool]
) -> MapGeometry | None:
    """The geometry stored at ``path`` if it is whole and is the one ``key`` names, else None."""
    try:
        with np.load(path, allow_pickle=False) as data:
            if str(data["key"]) != key or int(data["format"]) != FORMAT:
                return None
            corners = np.asarray(data["corners"], dtype=np.int64)
            starts = np.asarray(data["starts"], dtype=np.int64)
            counts = [int(v) for v in data["counts"]]
            areas = [float(v) for v in data["areas"]]
    except Exception:  # any way a file can be broken (zip, zlib, npy, keys) means: compute anew
        return None
    ok = (
        corners.ndim == 2
        and corners.shape[1] == 2
        and starts.ndim == 1
        and len(starts) >= 1
        and starts[0] == 0
        and starts[-1] == len(corners)
        and bool((np.diff(starts) >= 3).all())
        and len(counts) == len(_COUNTS)
        and len(areas) == len(_AREAS)
    )
    if not ok:
        return None
    return MapGeometry.from_corners(
        corners,
        starts,
        resolution_m=occ.resolution_m,
        origin_xy=occ.origin_xy,
        width_m=occ.width_m,
        height_m=occ.height_m,
        **dict(zip(_COUNTS, counts, strict=True)),
        **dict(zip(_AREAS, areas, strict=True)),
        **params,
        map_sha256=occ.sha256,
    )


def write_geometry(path: Path, key: str, geometry: MapGeometry) -> None:
    """Store ``geometry`` at ``path`` atomically (a temporary file, then ``os.replace``)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(
                f,
                key=np.array(key),
                format=np.array(FORMAT),
                corners=np.asarray(geometry.corners),
                starts=np.asarray(geometry.starts),
                counts=np.array([getattr(geometry, k) for k in _COUNTS], dtype=np.int64),
                areas=np.array([getattr(geometry, k) for k in _AREAS], dtype=float),
            )
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
