"""Where driving robots stand still, and what stands in their way.

A robot on its way to a task that is commanded less than ``still_mps`` in a control period
stands still for that period (turning in place, waiting for a way through, holding in a site's
queue). :class:`StallMeter` counts those periods by cause: the site queue it holds in, or the
nearest other robot within ``near_m`` and what that robot does (the robot collision avoidance
stops it for is not always the one a speed cap names, so the meter looks for itself). With collision
avoidance on, this is where the time goes that avoidance costs (docs/model/spatial-world.md,
"What the world measures"): ``mrta run`` prints it on one line and its ``metrics.json`` holds it
under ``spatial`` as ``still_s_<cause>``, ``driving_s`` and the share of the driving time
(``still_share``).

Short stops and jams: a stand is the unbroken run of standing periods of one robot on one
task. The meter also counts, by cause, the standing that comes after the first ``long_s`` of a
stand (``still_long_s_<cause>``): a robot that stands 7 s adds 7 s to ``still_s_`` and 5 s to
``still_long_s_``; stops to turn or to let a robot by add nothing there.

Causes (``CAUSES``): ``queue`` (holding for a place at its site), ``robot_at_work``,
``robot_idle`` (idle, stepping aside or driving out of a site), ``robot_head_on`` (a driving
robot heading more than 135 degrees away from its heading), ``robot_same_way`` (less than 45
degrees), ``robot_crossing`` (between), ``no_robot`` (turning at a corner, braking for a wall,
no robot within ``near_m``).

Where: given the arena's size, the meter also keeps a map, the standing periods by cause in
square cells (``map_cell_m``, coarser in a large arena so that the longer side has at most
``MAP_MAX_CELLS``): :meth:`StallMeter.seconds_map`. ``mrta run`` draws it (``stalls.png``)
and writes it (``stalls.npz``), and names the cells robots stood in longest.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.spatial import cKDTree

from sim.scenario import StallSpec
from sim.states import DRIVING, WORKING

SMALL_TEAM = 32  # up to this many robots a period is counted in plain Python (numpy's overhead)
DENSE_MAX = 64  # up to this many robots the nearest is found from all distances, else a k-d tree
TREE_K = 9  # a large team: the robots looked at for the nearest (on a square grid 4 tie)
MAP_MAX_CELLS = 128  # ... or coarser, so that the arena's longer side has at most this many
CAUSES = (
    "queue",
    "robot_at_work",
    "robot_idle",
    "robot_head_on",
    "robot_crossing",
    "robot_same_way",
    "no_robot",
)
_QUEUE, _WORK, _IDLE, _HEAD_ON, _CROSSING, _SAME_WAY, _NONE = range(len(CAUSES))
_COS_HEAD_ON = math.cos(math.radians(135.0))
_COS_SAME_WAY = math.cos(math.radians(45.0))


class StallMeter:
    """Control periods of driving robots, and of those standing still, by cause.

    Args:
        period_s: the control period, s.
        width_m, height_m: the arena, for the map of where robots stand (none without them).
        n_robots: the fleet's size, if known: a checkpoint's stands must be of that many
            robots (0: not checked).
        spec: what counts as standing, near and long (``[spatial.stalls]``).
        small_max: up to this many robots a period is counted in plain Python (numpy's
            overhead), else over arrays (the same counts).
    """

    def __init__(
        self,
        period_s: float,
        width_m: float = 0.0,
        height_m: float = 0.0,
        n_robots: int = 0,
        spec: StallSpec | None = None,
        small_max: int = SMALL_TEAM,
    ) -> None:
        spec = StallSpec() if spec is None else spec
        self.still_mps, self.near_m = spec.still_mps, spec.near_m
        self.small_max = small_max
        self.period_s = period_s
        self.n_robots = n_robots
        self.driving = 0  # robot-periods driving (state DRIVING)
        self.still = np.zeros(len(CAUSES), dtype=np.int64)  # robot-periods standing, by cause
        self.long = np.zeros(len(CAUSES), dtype=np.int64)  # ... beyond long_s into a stand
        self.long_after = round(
            spec.long_s / period_s
        )  # periods of a stand before it counts as long
        # per robot (sized at the first period): standing periods of its stand so far, and the
        # task it stands on (a stand ends when the robot moves or its task changes)
        self.run = np.zeros(0, dtype=np.int64)
        self.run_task = np.zeros(0, dtype=np.int64)
        self.cell_m = max(spec.map_cell_m, max(width_m, height_m) / MAP_MAX_CELLS)
        nx = math.ceil(width_m / self.cell_m - 1e-9) if width_m > 0 else 0
        ny = math.ceil(height_m / self.cell_m - 1e-9) if height_m > 0 else 0
        # robot-periods standing by cause, cell (row: y, column: x)
        self.map = np.zeros((len(CAUSES), ny, nx), dtype=np.int64)

    def sample(self, fleet, holding: np.ndarray) -> None:
        """Count one control period, after it set the commands (``fleet.v_cmd_mps``; positions
        and headings ``fleet.last_z_m``, ``last_th_rad``); ``holding``: (m,) robots holding in
        a site's queue."""
        if len(fleet.state) <= self.small_max:
            return self._sample_small(fleet, holding)
        drive = fleet.state == DRIVING
        n = int(np.count_nonzero(drive))
        still = drive & (np.abs(fleet.v_cmd_mps) < self.still_mps)
        rows = still.nonzero()[0]
        runs = self._stands(rows, fleet.task)
        if not n:
            return
        self.driving += n
        if not len(rows):
            return
        other, dist = nearest_other(fleet.last_z_m, rows, self.near_m)
        near = dist < self.near_m
        other = np.where(near, other, 0)
        th = fleet.last_th_rad
        cos = np.cos(th[other] - th[rows])
        driving = fleet.state[other] == DRIVING
        cause = np.where(cos < _COS_HEAD_ON, _HEAD_ON, _CROSSING)
        cause = np.where(cos > _COS_SAME_WAY, _SAME_WAY, cause)
        cause = np.where(driving, cause, _IDLE)
        cause = np.where(fleet.state[other] == WORKING, _WORK, cause)
        cause = np.where(near, cause, _NONE)
        cause = np.where(holding[rows], _QUEUE, cause)
        self.still += np.bincount(cause, minlength=len(CAUSES))
        self.long += np.bincount(cause[runs > self.long_after], minlength=len(CAUSES))
        if self.map.size:
            iy, ix = self._cells(fleet.last_z_m[rows])
            np.add.at(self.map, (cause, iy, ix), 1)

    def _stands(self, rows: np.ndarray, task: np.ndarray) -> np.ndarray:
        """The robots ``rows`` stand in this period, the others do not: each stand goes on
        (same task) or starts; the standing periods of each of ``rows``' stands so far."""
        m = len(task)
        if len(self.run) != m:
            self.run, self.run_task = np.zeros(m, dtype=np.int64), np.full(m, -1, dtype=np.int64)
        on = (self.run[rows] > 0) & (self.run_task[rows] == task[rows])
        run = np.zeros(m, dtype=np.int64)
        run[rows] = np.where(on, self.run[rows] + 1, 1)
        self.run = run
        self.run_task[rows] = task[rows]
        return run[rows]

    def _sample_small(self, fleet, holding: np.ndarray) -> None:
        """:meth:`sample` robot by robot in compiled code (a small team): :meth:`_sample_py`'s
        counts, stands and map, bit for bit (:func:`sample_small`)."""
        m = len(fleet.state)
        if len(self.run) != m:
            self.run, self.run_task = np.zeros(m, dtype=np.int64), np.full(m, -1, dtype=np.int64)
        self.driving += sample_small(
            fleet.state,
            fleet.v_cmd_mps,
            fleet.task,
            fleet.last_z_m,
            fleet.last_th_rad,
            holding,
            self.run,
            self.run_task,
            self.still_mps,
            self.near_m,
            self.long_after,
            1.0 / self.cell_m if self.map.size else 0.0,
            self.still,
            self.long,
            self.map,
        )

    def _sample_py(self, fleet, holding: np.ndarray) -> None:
        """:meth:`sample` robot by robot in plain Python (the reference of
        :meth:`_sample_small`): the same causes, the nearest robot the first of equal
        distances as numpy's ``argmin``, the same stands."""
        state, v = fleet.state.tolist(), fleet.v_cmd_mps.tolist()
        rows, n = [], 0
        for j, (sj, vj) in enumerate(zip(state, v, strict=True)):
            if sj == DRIVING:
                n += 1
                if abs(vj) < self.still_mps:
                    rows.append(j)
        m, task = len(state), fleet.task.tolist()
        if len(self.run) != m:
            self.run, self.run_task = np.zeros(m, dtype=np.int64), np.full(m, -1, dtype=np.int64)
        old, old_task, run = self.run.tolist(), self.run_task.tolist(), [0] * m
        for j in rows:
            run[j] = old[j] + 1 if old[j] > 0 and old_task[j] == task[j] else 1
            old_task[j] = task[j]
        self.run, self.run_task = np.array(run, dtype=np.int64), np.array(old_task, dtype=np.int64)
        if not n:
            return
        self.driving += n
        if not rows:
            return
        z, th, hold = fleet.last_z_m.tolist(), fleet.last_th_rad.tolist(), holding.tolist()
        causes = []
        for j in rows:
            if hold[j]:
                causes.append(_QUEUE)
                continue
            zj, best, k = z[j], math.inf, -1
            for i, zi in enumerate(z):
                if i != j:
                    d = abs(zi - zj)
                    if d < best:
                        best, k = d, i
            if best >= self.near_m:
                cause = _NONE
            elif state[k] == WORKING:
                cause = _WORK
            elif state[k] != DRIVING:
                cause = _IDLE
            else:
                cos = math.cos(th[k] - th[j])
                cause = (
                    _HEAD_ON
                    if cos < _COS_HEAD_ON
                    else (_SAME_WAY if cos > _COS_SAME_WAY else _CROSSING)
                )
            causes.append(cause)
        for j, cause in zip(rows, causes, strict=True):
            self.still[cause] += 1
            if run[j] > self.long_after:
                self.long[cause] += 1
        if self.map.size:
            _, ny, nx = self.map.shape
            inv = 1.0 / self.cell_m
            for j, cause in zip(rows, causes, strict=True):
                ix = min(max(int(z[j].real * inv), 0), nx - 1)
                iy = min(max(int(z[j].imag * inv), 0), ny - 1)
                self.map[cause, iy, ix] += 1

    def _cells(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Map cells (row, column) of points ``z`` (x + iy, m); points outside the arena (a
        robot pushed through a wall) count in the nearest cell at its border."""
        _, ny, nx = self.map.shape
        inv = 1.0 / self.cell_m
        ix = np.clip((z.real * inv).astype(np.int64), 0, nx - 1)
        iy = np.clip((z.imag * inv).astype(np.int64), 0, ny - 1)
        return iy, ix

    def summary(self) -> dict[str, float]:
        """``still_s_<cause>`` (robot-seconds standing still while driving, by cause),
        ``driving_s`` (robot-seconds driving), ``still_share`` (standing over driving) and
        ``still_long_s_<cause>`` (of the standing, what came after ``long_s`` of a stand)."""
        still = self.still.tolist()
        out = {f"still_s_{c}": k * self.period_s for c, k in zip(CAUSES, still, strict=True)}
        out["driving_s"] = float(self.driving * self.period_s)
        out["still_share"] = float(self.still.sum() / max(self.driving, 1))
        long = self.long.tolist()
        out |= {f"still_long_s_{c}": k * self.period_s for c, k in zip(CAUSES, long, strict=True)}
        return out

    def seconds_map(self) -> np.ndarray:
        """(causes, rows, columns) robot-seconds standing, by cause (``CAUSES``) and cell: the
        cell of row r, column c spans x in [c, c + 1) and y in [r, r + 1) times ``cell_m``."""
        return self.map * self.period_s

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The counts since reset (checkpoints)."""
        return {
            "driving": np.array(self.driving, dtype=np.int64),
            "still": self.still.copy(),
            "map": self.map.copy(),
            "long": self.long.copy(),
            "run": self.run.copy(),
            "run_task": self.run_task.copy(),
        }

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays`; a checkpoint written before the meter (or its map)
        existed restores zero counts."""
        self.driving = int(arrays.get("driving", 0))
        still = np.asarray(arrays.get("still", np.zeros(len(CAUSES))), dtype=np.int64)
        if still.shape != (len(CAUSES),):
            raise ValueError(f"stalls/still: expected {len(CAUSES)} counts, got {still.shape}")
        self.still = still.copy()
        where = np.asarray(arrays.get("map", np.zeros_like(self.map)), dtype=np.int64)
        if where.shape != self.map.shape:
            raise ValueError(f"stalls/map: expected shape {self.map.shape}, got {where.shape}")
        self.map = where.copy()
        # checkpoints written before stands were counted: no long standing, no stand going on
        long = np.asarray(arrays.get("long", np.zeros(len(CAUSES))), dtype=np.int64)
        if long.shape != (len(CAUSES),):
            raise ValueError(f"stalls/long: expected {len(CAUSES)} counts, got {long.shape}")
        self.long = long.copy()
        run = np.asarray(arrays.get("run", np.zeros(0)), dtype=np.int64)
        run_task = np.asarray(arrays.get("run_task", np.full(len(run), -1)), dtype=np.int64)
        if run.ndim != 1 or run_task.shape != run.shape:
            raise ValueError(f"stalls/run: shapes {run.shape} and {run_task.shape} differ")
        if self.n_robots and len(run) not in (0, self.n_robots):  # 0: no period sampled yet
            raise ValueError(
                f"stalls/run: {len(run)} robots' stands, the fleet has {self.n_robots}"
            )
        self.run, self.run_task = run.copy(), run_task.copy()


@numba.njit(cache=True)
def sample_small(
    state, v, task, z, th, hold, run, run_task, still_mps, near_m, long_after, inv_cell, still,
    long, where,
) -> int:  # fmt: skip
    """One control period of :class:`StallMeter` in one pass, as ``StallMeter._sample_py``
    counts it (its distances ``abs`` of a complex, the C library's ``hypot``; its angles the
    C library's ``cos``): stands into ``run`` and ``run_task`` (``run`` zero for every robot
    not standing), standing periods by cause into ``still`` and ``long`` and, with
    ``inv_cell`` > 0, into the map ``where`` (causes, rows, columns). Returns the robots
    driving (0: nothing counted, only the stands ended)."""
    m, n = len(state), 0
    for j in range(m):
        stands = state[j] == DRIVING and abs(v[j]) < still_mps
        n += state[j] == DRIVING
        if stands:
            run[j] = run[j] + 1 if run[j] > 0 and run_task[j] == task[j] else 1
            run_task[j] = task[j]
        else:
            run[j] = 0
    if not n:
        return 0
    for j in range(m):
        if not run[j]:  # not standing
            continue
        if hold[j]:
            cause = _QUEUE
        else:
            zj, best, k = z[j], math.inf, -1
            for i in range(m):
                if i != j:
                    d = math.hypot(z[i].real - zj.real, z[i].imag - zj.imag)
                    if d < best:
                        best, k = d, i
            if best >= near_m:
                cause = _NONE
            elif state[k] == WORKING:
                cause = _WORK
            elif state[k] != DRIVING:
                cause = _IDLE
            else:
                cos = math.cos(th[k] - th[j])
                if cos < _COS_HEAD_ON:
                    cause = _HEAD_ON
                elif cos > _COS_SAME_WAY:
                    cause = _SAME_WAY
                else:
                    cause = _CROSSING
        still[cause] += 1
        if run[j] > long_after:
            long[cause] += 1
        if inv_cell > 0.0:
            _, ny, nx = where.shape
            ix = min(max(int(z[j].real * inv_cell), 0), nx - 1)
            iy = min(max(int(z[j].imag * inv_cell), 0), ny - 1)
            where[cause, iy, ix] += 1
    return n


def nearest_other(
    z: np.ndarray, rows: np.ndarray, near_m: float = 1.2
) -> tuple[np.ndarray, np.ndarray]:
    """For each robot ``rows``, the nearest other robot and its centre distance; of robots at
    the same distance the lowest index, as ``argmin`` over all of them (robots on a start
    grid are). In a large team the ``TREE_K`` nearest within ``near_m`` are looked at (a k-d
    tree): inf, and index 0, when none is that near."""
    m = len(z)
    if m < 2:
        return np.zeros(len(rows), dtype=int), np.full(len(rows), np.inf)
    if m <= DENSE_MAX:
        d = np.abs(z[rows, None] - z[None, :])
        d[np.arange(len(rows)), rows] = np.inf
        other = d.argmin(axis=1)
        return other, d[np.arange(len(rows)), other]
    xy = np.column_stack([z.real, z.imag])
    tree = cKDTree(xy, balanced_tree=False, compact_nodes=False)  # quicker to build
    k = min(TREE_K, m)
    dist, idx = tree.query(xy[rows], k=k, distance_upper_bound=near_m)
    dist = np.where(idx == rows[:, None], np.inf, dist)  # not itself
    best = dist.min(axis=1)
    tied = dist == best[:, None]
    other = np.where(tied & np.isfinite(dist), idx, m).min(axis=1)  # lowest index of the nearest
    return np.where(other < m, other, 0), best
