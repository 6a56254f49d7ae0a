"""The state of the pymunk world's fleet: per-robot arrays, the schedule of checks, the clock.

:class:`FleetState` is every per-robot quantity the world keeps between control periods, one
entry per robot in each array and each documented once, here. :class:`Schedule` holds what the
control period may skip and when it must look again; :class:`Clock` counts physics steps. The
world (``sim.spatial.world.PymunkWorld``) makes all three at reset and hands them to its
collaborators, the task bookkeeping (``sim.spatial.jobs.Jobs``) and a control period
(``sim.spatial.control``), which read and write them in place.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from sim.states import DRIVING, IDLE, WAITING, WORKING


@dataclass(slots=True, eq=False)
class FleetState:
    """Per-robot state of the pymunk world; every array has one entry per robot (m).

    Positions are complex numbers x + iy (m), headings angles (rad) from +x. A collaborator may
    write an entry in place or replace a whole array with one of the same shape and dtype.

    Attributes:
        state: int8, ``IDLE``, ``DRIVING`` or ``WORKING`` (``sim.recording``).
        task: int64, id of the task the robot holds; -1 while free.
        task_type: int64, that task's type.
        t_alloc_s: when that task was allocated, s.
        bid: the cost the robot bid for it.
        site: complex, where the task is to be done, m (the start before any task).
        work_end_s: when the work at the site ends, s (while ``WORKING``).
        deadline_s: a robot still driving to its site past this time fails its task, s (work
            begun is finished).
        odo0_m: ``moved_m`` when the task was allocated, m.
        left_m: planned path length still to drive, m.
        progress_m: path left below this counts as progress (restarts the stuck clock), m.
        t_progress_s: when the robot last made progress, s; inf unless driving, so that the
            minimum finds the stalest driving robot.
        recoveries: int, recovery tries since the robot last got going.
        stuck_left_m: path left when it last got stuck, m (inf: not since it got going).
        backoff_until_s: backing off blind until then, s (-inf: not backing off).
        backoff_cmd: (m, 2), the back-off command: forward speed m/s, turn rate rad/s.
        replan: bool, plan a new path to the site once the back-off ends.
        yielding: bool, idle and stepping out of a driving robot's way.
        yield_until_s: the side step is given up at this time, s.
        v_cmd_mps: forward speed commanded in the last control period, m/s.
        q_cmd_mps: half the rim speed difference commanded then, m/s (rims at v +- q).
        blocker: int, the nearest robot in the way (-1: none within reach of a speed cap).
        near_m: that robot's centre distance, m (inf: none).
        last_z_m: complex, positions read at the last control period, m.
        last_th_rad: headings read then, rad.
        moved_m: distance driven since reset, m.
        nobody: (-1 for every robot, inf for every robot), never written: ``blocker`` and
            ``near_m`` while no robot is in any robot's way (:meth:`clear_way`).
    """

    state: np.ndarray
    task: np.ndarray
    task_type: np.ndarray
    t_alloc_s: np.ndarray
    bid: np.ndarray
    site: np.ndarray
    work_end_s: np.ndarray
    deadline_s: np.ndarray
    odo0_m: np.ndarray
    left_m: np.ndarray
    progress_m: np.ndarray
    t_progress_s: np.ndarray
    recoveries: np.ndarray
    stuck_left_m: np.ndarray
    backoff_until_s: np.ndarray
    backoff_cmd: np.ndarray
    replan: np.ndarray
    yielding: np.ndarray
    yield_until_s: np.ndarray
    v_cmd_mps: np.ndarray
    q_cmd_mps: np.ndarray
    blocker: np.ndarray
    near_m: np.ndarray
    last_z_m: np.ndarray
    last_th_rad: np.ndarray
    moved_m: np.ndarray
    nobody: tuple[np.ndarray, np.ndarray]

    @classmethod
    def at_start(cls, starts_xy_m: np.ndarray, headings_rad=None) -> FleetState:
        """Every robot idle and free at its start (x, y), facing ``headings_rad`` (None: +x),
        with nothing commanded."""
        m = len(starts_xy_m)
        site = np.asarray(starts_xy_m, dtype=float) @ np.array([1.0, 1j])
        return cls(
            state=np.full(m, IDLE, dtype=np.int8),
            task=np.full(m, -1, dtype=np.int64),
            task_type=np.zeros(m, dtype=np.int64),
            t_alloc_s=np.zeros(m),
            bid=np.zeros(m),
            site=site,
            work_end_s=np.zeros(m),
            deadline_s=np.zeros(m),
            odo0_m=np.zeros(m),
            left_m=np.zeros(m),
            progress_m=np.full(m, np.inf),
            t_progress_s=np.full(m, np.inf),
            recoveries=np.zeros(m, dtype=int),
            stuck_left_m=np.full(m, np.inf),
            backoff_until_s=np.full(m, -np.inf),
            backoff_cmd=np.zeros((m, 2)),
            replan=np.zeros(m, dtype=bool),
            yielding=np.zeros(m, dtype=bool),
            yield_until_s=np.zeros(m),
            v_cmd_mps=np.zeros(m),
            q_cmd_mps=np.zeros(m),
            blocker=np.full(m, -1),
            near_m=np.full(m, np.inf),
            last_z_m=site.copy(),
            last_th_rad=np.zeros(m) if headings_rad is None else np.array(headings_rad, float),
            moved_m=np.zeros(m),
            nobody=(np.full(m, -1), np.full(m, np.inf)),
        )

    def clear_way(self) -> None:
        """No robot is in any robot's way (``blocker`` -1, ``near_m`` inf for all)."""
        self.blocker, self.near_m = self.nobody

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Every per-robot array by field name (copies; ``nobody`` is a constant)."""
        return {name: getattr(self, name).copy() for name in self.__slots__ if name != "nobody"}

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays`: each array copied in with its field's dtype."""
        for name in self.__slots__:
            if name != "nobody":
                old = getattr(self, name)
                setattr(self, name, np.array(arrays[name], dtype=old.dtype).reshape(old.shape))


@dataclass(slots=True, eq=False)
class Schedule:
    """What a control period may skip, and when each check is due again.

    A check that cannot fire yet is skipped until the earliest time it could. ``Jobs.refresh``
    recomputes the counts and the next end of work and deadline after every task event and makes
    the other checks due at once; the control period pushes them back as it finds nothing to do.

    Attributes:
        next_end_s: earliest end of work of a working robot, s.
        next_deadline_s: earliest deadline of a robot driving to its site, s.
        stuck_check_s: no driving robot can be stuck before this, s.
        site_check_s: no driving robot can be in its arrival zone before this, s.
        prox_check_s: no robot that steers can come within ``look_m`` of another before this, s.
        n_backoff: robots backing off or waiting to replan.
        n_yield: robots yielding.
        n_steer: robots that steer: driving (backing off too) or yielding.
        resting: nothing has steered and every wheel has stood still for two periods: a period
            has nothing to compute.
        calm: the same for the last period alone.
        recovering: some robot has a finite ``stuck_left_m``.
        state_list: ``FleetState.state`` as a Python list (kept for the scalar control only).
        steer_list: the robots that steer, as a list (kept for the scalar control only).
    """

    next_end_s: float = np.inf
    next_deadline_s: float = np.inf
    stuck_check_s: float = -np.inf
    site_check_s: float = -np.inf
    prox_check_s: float = -np.inf
    n_backoff: int = 0
    n_yield: int = 0
    n_steer: int = 0
    resting: bool = True
    calm: bool = True
    recovering: bool = False
    state_list: list[int] = field(default_factory=list)
    steer_list: list[int] = field(default_factory=list)

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The times, counts and flags as 0-d arrays (the lists follow from the fleet state
        and are rebuilt by ``Jobs.refresh``)."""
        return {
            name: np.array(getattr(self, name))
            for name in self.__slots__
            if name not in ("state_list", "steer_list")
        }

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays` (the lists are left to the caller)."""
        for name in self.__slots__:
            if name not in ("state_list", "steer_list"):
                setattr(self, name, type(getattr(self, name))(arrays[name].item()))


@dataclass(slots=True, eq=False)
class Clock:
    """Simulated time as a count of fixed physics steps (so that time never drifts).

    Attributes:
        dt_s: the physics step, s.
        steps: physics steps taken since reset.
    """

    dt_s: float
    steps: int = 0

    @property
    def time_s(self) -> float:
        """Simulated time since reset, s."""
        return self.steps * self.dt_s


def refresh_schedule(fleet: FleetState, schedule: Schedule, clock: Clock, keep_lists: bool) -> None:
    """Refresh the schedule's next-event times and counts after a task event: the next end of
    work and deadline, the robots backing off, yielding and steering (and, with
    ``keep_lists``, the state and the steering robots as lists); the other checks are due at
    once and the world is not resting."""
    f, sch = fleet, schedule
    busy = f.task >= 0
    work = f.state == WORKING
    sch.next_end_s = float(f.work_end_s[work].min(initial=np.inf))
    driving = busy & (f.state == DRIVING)  # a deadline is one to begin work by
    sch.next_deadline_s = float(f.deadline_s[driving].min(initial=np.inf))
    backing = f.replan | (f.backoff_until_s > clock.time_s)
    sch.n_backoff = int(np.count_nonzero(backing))
    sch.n_yield = int(np.count_nonzero(f.yielding))
    sch.n_steer = int(np.count_nonzero(f.state == DRIVING)) + sch.n_yield
    if keep_lists:
        sch.state_list = f.state.tolist()
        steering = (f.state == DRIVING) | f.yielding  # driving, backing off, yielding
        sch.steer_list = steering.nonzero()[0].tolist()
    sch.stuck_check_s = sch.prox_check_s = -np.inf
    sch.resting = False


@numba.njit(cache=True)
def shown_now(state: np.ndarray, t_progress_s: np.ndarray, t_s: float) -> np.ndarray:
    """``sim.states.shown_states`` in one compiled pass (what the world records each control
    period): ``WAITING`` for a driving robot whose stuck clock is set after ``t_s``, else its
    state; a new array of ``state``'s dtype."""
    out = np.empty_like(state)
    for j in range(len(state)):
        out[j] = WAITING if state[j] == DRIVING and t_progress_s[j] > t_s else state[j]
    return out
