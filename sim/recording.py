"""Trajectory recording: cheap appends during a run, arrays afterwards, ``.npz`` on disk.

The simulation only records; rendering (``sim.render``) reads a finished :class:`Trajectory`.
Files are written with ``allow_pickle=False`` semantics: every field is a plain numeric or
unicode array.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sim.atomic import atomic_open
from sim.maps import FREE, OCCUPIED, cached_obstacles, load_map

# map_saver's grey levels for free, occupied and unknown cells: the picture a ROS user knows
MAP_GREY = {FREE: 254, OCCUPIED: 0}
UNKNOWN_GREY = 205


@dataclass(frozen=True)
class Trajectory:
    """Robot poses and task events of one run, as arrays."""

    times_s: np.ndarray  # (T,)
    positions: np.ndarray  # (T, m, 2) m
    headings: np.ndarray  # (T, m) rad
    robot_state: np.ndarray  # (T, m) int8: IDLE, DRIVING, WORKING, WAITING
    task_id: np.ndarray  # (N,)
    task_type: np.ndarray  # (N,)
    task_high: np.ndarray  # (N,) bool
    task_xy: np.ndarray  # (N, 2) m
    t_announce: np.ndarray  # (N,) s
    t_alloc: np.ndarray  # (N,) s, NaN if lost
    t_done: np.ndarray  # (N,) s, NaN if never done
    task_robot: np.ndarray  # (N,) robot index, -1 if lost
    arena_wh: np.ndarray  # (2,) m
    obstacles: np.ndarray  # (P, V, 2) m, polygons padded with NaN
    type_names: np.ndarray  # (n,) str
    robot_names: np.ndarray  # (m,) str
    site_xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (S, 2) m: every site
    site_type: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # (S,)
    # the ROS map under the arena, if any: grey cells (row 0 at the bottom, the arena's extent),
    # the map-frame point of the arena's corner (0, 0), and how many of the last obstacles are
    # the map's own (drawn as its cells, not as polygons)
    map_grey: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=np.uint8))
    map_origin_xy: np.ndarray = field(default_factory=lambda: np.zeros(2))  # (2,) m
    map_polygons: np.ndarray = field(default_factory=lambda: np.array(0, dtype=np.int64))

    def save(self, path: Path) -> None:
        """Write an ``.npz`` atomically (temporary file, then rename)."""
        with atomic_open(Path(path), "wb") as fh:
            np.savez_compressed(fh, **{k: getattr(self, k) for k in self.__dataclass_fields__})

    @classmethod
    def load(cls, path: Path) -> Trajectory:
        """Read a saved trajectory (files from before sites were recorded load without them)."""
        with np.load(Path(path), allow_pickle=False) as data:
            return cls(**{k: data[k] for k in cls.__dataclass_fields__ if k in data.files})


class TrajectoryRecorder:
    """Collects poses (from the world) and task events (from the experiment loop)."""

    def __init__(
        self,
        arena_wh,
        obstacles,
        type_names,
        robot_names,
        every_s: float = 0.1,
        sites=(),
        map_path: str = "",
    ) -> None:
        self.every_s = every_s  # record poses at most this often (simulated seconds)
        self.arena_wh = np.asarray(arena_wh, dtype=float)
        width = max((len(p) for p in obstacles), default=0)
        self.obstacles = np.full((len(obstacles), width, 2), np.nan)
        for k, poly in enumerate(obstacles):
            self.obstacles[k, : len(poly)] = poly
        self.type_names = np.asarray(type_names, dtype=str)
        self.robot_names = np.asarray(robot_names, dtype=str)
        pts = [(xy, i) for i, per_type in enumerate(sites) for xy in per_type]
        self.site_xy = np.array([p for p, _ in pts], dtype=float).reshape(-1, 2)
        self.site_type = np.array([i for _, i in pts], dtype=np.int64)
        self.map_grey, self.map_origin_xy, self.map_polygons = _map_picture(map_path, obstacles)
        self._times: list[float] = []
        self._pos: list[np.ndarray] = []
        self._head: list[np.ndarray] = []
        self._state: list[np.ndarray] = []
        self._rows: list[list] = []  # one per announcement: a replayed set announces ids again
        self._latest: dict[int, int] = {}  # task id -> row of its latest announcement
        self._next_t = -np.inf

    @classmethod
    def for_scenario(cls, scenario, every_s: float = 0.1) -> TrajectoryRecorder:
        """A recorder for a spatial scenario's arena, obstacles, task types and robots."""
        sp = scenario.spatial
        names = [r.name for r in scenario.robots]
        return cls(
            (sp.width_m, sp.height_m),
            sp.obstacles,
            scenario.task_types,
            names,
            every_s,
            sp.sites,
            map_path=sp.map,
        )

    def has_poses(self) -> bool:
        return bool(self._times)

    def poses(self, t_s: float, positions, headings, states) -> None:
        """Record robot poses if ``every_s`` has passed since the last record."""
        if t_s + 1e-9 < self._next_t:
            return
        self._next_t = t_s + self.every_s
        self._times.append(t_s)
        self._pos.append(np.array(positions, dtype=np.float32))
        self._head.append(np.array(headings, dtype=np.float32))
        self._state.append(np.array(states, dtype=np.int8))

    def announce(self, t_s: float, ids, types, high, sites) -> None:
        for k, tid in enumerate(np.asarray(ids).tolist()):
            xy = sites[k] if sites is not None else (np.nan, np.nan)
            self._latest[tid] = len(self._rows)
            self._rows.append(
                [
                    tid,
                    int(types[k]),
                    bool(high[k]),
                    float(xy[0]),
                    float(xy[1]),
                    t_s,
                    np.nan,
                    np.nan,
                    -1,
                ]
            )

    def allocate(self, t_s: float, ids, assignment) -> None:
        pairs = zip(np.asarray(ids).tolist(), np.asarray(assignment).tolist(), strict=True)
        for tid, robot in pairs:
            if robot >= 0:
                row = self._rows[self._latest[tid]]
                row[6], row[8] = t_s, robot

    def done(self, task_id: int, t_s: float) -> None:
        self._rows[self._latest[task_id]][7] = t_s

    def finish(self) -> Trajectory:
        """The recording as arrays; tasks in announcement order (a replayed set appears again)."""
        rows = self._rows

        def col(k: int, dtype) -> np.ndarray:
            return np.array([r[k] for r in rows], dtype=dtype) if rows else np.zeros(0, dtype=dtype)

        m = len(self.robot_names)
        return Trajectory(
            times_s=np.array(self._times, dtype=float),
            positions=np.array(self._pos, dtype=np.float32).reshape(-1, m, 2),
            headings=np.array(self._head, dtype=np.float32).reshape(-1, m),
            robot_state=np.array(self._state, dtype=np.int8).reshape(-1, m),
            task_id=col(0, np.int64),
            task_type=col(1, np.int64),
            task_high=col(2, bool),
            task_xy=np.column_stack([col(3, float), col(4, float)]).reshape(-1, 2),
            t_announce=col(5, float),
            t_alloc=col(6, float),
            t_done=col(7, float),
            task_robot=col(8, np.int64),
            arena_wh=self.arena_wh,
            obstacles=self.obstacles,
            type_names=self.type_names,
            robot_names=self.robot_names,
            site_xy=self.site_xy,
            site_type=self.site_type,
            map_grey=self.map_grey,
            map_origin_xy=self.map_origin_xy,
            map_polygons=self.map_polygons,
        )


def map_grey(cells: np.ndarray) -> np.ndarray:
    """(ny, nx) uint8 grey levels of a map's FREE / OCCUPIED / UNKNOWN cells, as map_saver
    writes them (free 254, occupied 0, unknown 205)."""
    out = np.full(cells.shape, UNKNOWN_GREY, dtype=np.uint8)
    for code, grey in MAP_GREY.items():
        out[cells == code] = grey
    return out


def _map_picture(map_path: str, obstacles) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The grey cells and origin of the map at ``map_path`` ("" for none), and how many of the
    last ``obstacles`` are its polygons (the loader appends them after the file's own)."""
    if not map_path:
        return np.zeros((0, 0), dtype=np.uint8), np.zeros(2), np.array(0, dtype=np.int64)
    occ = load_map(map_path)
    n_map = min(len(cached_obstacles(occ).arena_polygons), len(obstacles))
    origin = np.asarray(occ.origin_xy, dtype=float)
    return map_grey(occ.cells), origin, np.array(n_map, dtype=np.int64)
