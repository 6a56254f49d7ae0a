"""A synthetic warehouse map and the time it takes to prepare one, for benchmarks.

``synthetic_warehouse`` draws a map_server image of a warehouse (outer wall in a band of unknown
cells, an inner wall with doors, rows of racks, a rotated rack, round pillars and specks of
noise); ``prepare_time_probe`` writes it with its YAML file and times :func:`load_map` and
:func:`map_obstacles` on it::

    .venv/bin/python -c "import tempfile; from sim.maps.probe import prepare_time_probe as p; \\
        print(p(tempfile.mkdtemp()))"
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from PIL import Image

from sim.maps.geometry import map_obstacles
from sim.maps.occupancy import load_map

FREE_PIXEL, OCCUPIED_PIXEL, UNKNOWN_PIXEL = 254, 0, 205  # as map_saver writes them


def synthetic_warehouse(
    width_m: float = 30.0,
    height_m: float = 50.0,
    resolution_m: float = 0.03,
    *,
    n_specks: int = 400,
    ragged: float = 0.3,
    seed: int = 0,
) -> np.ndarray:
    """(rows, cols) uint8 image, row 0 at the top, of a warehouse ``width_m`` x ``height_m``:
    ``n_specks`` single occupied pixels of noise, and each free pixel beside an occupied one
    turned occupied with probability ``ragged`` (walls as a scan sees them)."""
    nx, ny = round(width_m / resolution_m), round(height_m / resolution_m)
    x = (np.arange(nx) + 0.5) * resolution_m
    y = (np.arange(ny) + 0.5)[::-1, None] * resolution_m  # row 0 is the top of the map
    xx, yy = np.broadcast_to(x, (ny, nx)), np.broadcast_to(y, (ny, nx))
    img = np.full((ny, nx), FREE_PIXEL, dtype=np.uint8)
    inset, wall = 0.4, 0.15

    def box(x0: float, x1: float, y0: float, y1: float) -> np.ndarray:
        return (xx >= x0) & (xx < x1) & (yy >= y0) & (yy < y1)

    outside = ~box(inset, width_m - inset, inset, height_m - inset)
    img[outside] = UNKNOWN_PIXEL
    ring = box(inset - wall, width_m - inset + wall, inset - wall, height_m - inset + wall)
    img[ring & outside] = OCCUPIED_PIXEL
    mid = 0.6 * height_m  # an inner wall across the hall, with two doors
    inner = box(inset, width_m - inset, mid, mid + wall)
    for door in (0.25 * width_m, 0.7 * width_m):
        inner &= ~box(door, door + 1.6, mid - 1.0, mid + 1.0)
    img[inner] = OCCUPIED_PIXEL
    for col in range(6):  # two rows of racks below the wall: outlines round unknown insides
        for row in range(2):
            x0, y0 = 2.5 + col * 4.3, 3.0 + row * 11.0
            outer, core = (
                box(x0, x0 + 1.2, y0, y0 + 8.0),
                box(x0 + 0.1, x0 + 1.1, y0 + 0.1, y0 + 7.9),
            )
            img[outer] = OCCUPIED_PIXEL
            img[core] = UNKNOWN_PIXEL
    angle = math.radians(30.0)  # a rack standing askew in the upper hall
    cx, cy = 0.3 * width_m, 0.8 * height_m
    u = (xx - cx) * math.cos(angle) + (yy - cy) * math.sin(angle)
    v = -(xx - cx) * math.sin(angle) + (yy - cy) * math.cos(angle)
    img[(np.abs(u) < 2.5) & (np.abs(v) < 0.6)] = OCCUPIED_PIXEL
    for px in np.arange(6.0, width_m - 3.0, 6.0):  # round pillars in the upper hall
        for py in np.arange(mid + 3.0, height_m - 2.0, 5.0):
            if abs(px - cx) > 3.5 or abs(py - cy) > 2.5:
                img[(xx - px) ** 2 + (yy - py) ** 2 < 0.2**2] = OCCUPIED_PIXEL
    rng = np.random.default_rng(seed)
    solid = img == OCCUPIED_PIXEL
    beside = np.zeros_like(solid)
    beside[1:] |= solid[:-1]
    beside[:-1] |= solid[1:]
    beside[:, 1:] |= solid[:, :-1]
    beside[:, :-1] |= solid[:, 1:]
    rough = beside & (img == FREE_PIXEL) & (rng.random(img.shape) < ragged)
    img[rough] = OCCUPIED_PIXEL
    free_rows, free_cols = np.nonzero(img == FREE_PIXEL)
    pick = rng.choice(len(free_rows), size=min(n_specks, len(free_rows)), replace=False)
    img[free_rows[pick], free_cols[pick]] = OCCUPIED_PIXEL
    return img


def write_map(
    directory: str | Path,
    name: str,
    image: np.ndarray,
    resolution_m: float,
    origin_xy: tuple[float, float] = (0.0, 0.0),
    *,
    free_thresh: float = 0.196,
) -> Path:
    """Write ``name.pgm`` and ``name.yaml`` (trinary, occupied_thresh 0.65) into ``directory``;
    the YAML file's path. ``free_thresh`` 0.196 (ROS map_saver's) keeps 205-grey unknown."""
    folder = Path(directory)
    folder.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.asarray(image, dtype=np.uint8)).save(folder / f"{name}.pgm")
    yaml = folder / f"{name}.yaml"
    yaml.write_text(
        f"image: {name}.pgm\nmode: trinary\nresolution: {resolution_m!r}\n"
        f"origin: [{origin_xy[0]!r}, {origin_xy[1]!r}, 0.0]\nnegate: 0\n"
        f"occupied_thresh: 0.65\nfree_thresh: {free_thresh!r}\n"
    )
    return yaml


def prepare_time_probe(
    directory: str | Path,
    *,
    width_m: float = 30.0,
    height_m: float = 50.0,
    resolution_m: float = 0.03,
    seed: int = 0,
    geometry: bool = False,
) -> dict:
    """Write a synthetic warehouse map into ``directory`` and time preparing it.

    Returns:
        ``cells``, ``load_s`` (:func:`load_map`), ``geometry_s`` (:func:`map_obstacles`, default
        parameters), ``prepare_s`` (both), ``polygons``, ``vertices`` and ``specks_dropped``;
        with ``geometry``, also ``geometry``: the :class:`MapGeometry` itself.
    """
    want = geometry
    image = synthetic_warehouse(width_m, height_m, resolution_m, seed=seed)
    path = write_map(directory, "synthetic_warehouse", image, resolution_m)
    t0 = time.perf_counter()
    occ = load_map(path)
    t1 = time.perf_counter()
    geometry = map_obstacles(occ)
    t2 = time.perf_counter()
    return {
        "cells": int(image.size),
        "load_s": t1 - t0,
        "geometry_s": t2 - t1,
        "prepare_s": t2 - t0,
        "polygons": geometry.n_polygons,
        "vertices": geometry.n_vertices,
        "specks_dropped": geometry.specks_dropped,
    } | ({"geometry": geometry} if want else {})
