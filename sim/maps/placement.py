"""Places on a map's free floor: task sites and robot starts with room around them.

:func:`free_places` draws points (seeded) on the free cells of a map where a robot centre fits
with ``clearance_m`` to every blocked cell and to the map's edge, all in the largest connected
region of such places (so every place can reach every other), at least ``min_gap_m`` apart.
``mrta map-sites`` prints them as a scenario's ``[spatial.sites]`` block (and robot starts).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from sim.maps.errors import MapError
from sim.maps.occupancy import OccupancyMap
from sim.maps.reference import Clearance, eroded_free


def reachable_floor(occ: OccupancyMap, clearance_m: float, blocked=None) -> np.ndarray:
    """(ny, nx) bool: the cells whose centre has ``clearance_m`` of room and that belong to the
    largest 8-connected region of such cells (``blocked``: the cells to keep clear of, default
    the map's occupied and unknown ones)."""
    cells = occ.blocked if blocked is None else blocked
    room = eroded_free(cells, occ.resolution_m, occ.origin_xy, clearance_m)
    labels, n = ndimage.label(room, structure=np.ones((3, 3), dtype=bool))
    if n == 0:
        return room
    sizes = np.bincount(labels.ravel())[1:]
    return labels == 1 + int(np.argmax(sizes))


def free_places(
    occ: OccupancyMap,
    count: int,
    rng: np.random.Generator,
    *,
    clearance_m: float,
    min_gap_m: float = 1.0,
    avoid: np.ndarray | None = None,
    blocked=None,
) -> np.ndarray:
    """``count`` points (count, 2) in the map frame, m: each on a cell of the largest region
    of the floor a robot centre fits with ``clearance_m`` (:func:`reachable_floor`), at least
    ``min_gap_m`` from each other and from the points ``avoid`` (k, 2). Points are drawn cell
    by cell from ``rng`` and placed at a random spot of the cell whose clearance is checked
    exactly.

    Raises:
        MapError: fewer such places than ``count`` (one line naming the map).
    """
    floor = reachable_floor(occ, clearance_m, blocked)
    j, i = np.nonzero(floor)
    clear = Clearance.from_map(occ, blocked=blocked)
    taken = [] if avoid is None else [tuple(p) for p in np.asarray(avoid, float).reshape(-1, 2)]
    out: list[tuple[float, float]] = []
    order = rng.permutation(len(j))
    res = occ.resolution_m
    ox, oy = occ.origin_xy
    for k in order.tolist():
        x = ox + (i[k] + rng.uniform(0.25, 0.75)) * res
        y = oy + (j[k] + rng.uniform(0.25, 0.75)) * res
        if taken and np.min(np.hypot(*(np.asarray(taken) - (x, y)).T)) < min_gap_m:
            continue
        on_free, room = clear.query(np.array([[x, y]]))
        if not (on_free[0] and room[0] >= clearance_m):
            continue
        taken.append((x, y))
        out.append((x, y))
        if len(out) == count:
            return np.array(out)
    raise MapError(
        occ.source,
        "floor",
        f"room for only {len(out)} of {count} places {min_gap_m:g} m apart with "
        f"{clearance_m:g} m of clearance",
    )


__all__ = ["free_places", "reachable_floor"]
