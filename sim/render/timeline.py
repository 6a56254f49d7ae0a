"""What a frame shows at one simulated instant, read from a ``Trajectory`` (numpy only).

Robot poses are interpolated between records; each task is in one display state: not yet
announced (hidden), waiting, taken by a robot, done or lost (never allocated). Done and lost
tasks are shown for a window of recent history and then left out, so long runs do not clutter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.recording import Trajectory


def robot_poses_at(traj: Trajectory, t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Robot positions (m, 2) and headings (m,) interpolated at ``t_s``; states (m,) as recorded.

    Outside the recorded times the first or last pose is held.
    """
    times = traj.times_s
    k = min(max(int(np.searchsorted(times, t_s, side="right")) - 1, 0), len(times) - 1)
    xy = traj.positions[k].astype(float)
    heading = traj.headings[k].astype(float)
    if k + 1 < len(times) and t_s > times[k]:
        w = (t_s - times[k]) / (times[k + 1] - times[k])
        xy = xy + w * (traj.positions[k + 1] - xy)
        turn = (traj.headings[k + 1] - heading + np.pi) % (2 * np.pi) - np.pi
        heading = heading + w * turn
    return xy, heading, traj.robot_state[k].astype(int)


def trails_at(traj: Trajectory, t_s: float, trail_s: float, xy_now: np.ndarray) -> np.ndarray:
    """Each robot's recorded positions in (t_s - trail_s, t_s], ending at ``xy_now``: (m, L, 2)."""
    times = traj.times_s
    i0 = int(np.searchsorted(times, t_s - trail_s, side="left"))
    i1 = int(np.searchsorted(times, t_s, side="right"))
    if trail_s <= 0 or i1 <= i0:
        return np.empty((len(xy_now), 0, 2))
    return np.concatenate([traj.positions[i0:i1], xy_now[None]], axis=0).transpose(1, 0, 2)


def task_counts_at(traj: Trajectory, t_s: float) -> dict[str, int]:
    """Announced, done, lost (never allocated) and in-progress (allocated, not done yet) task
    counts at ``t_s``. Tasks are allocated when announced, so announced = done + lost + in
    progress (a failed task counts as done when it ends: the record marks its end)."""
    announced = traj.t_announce <= t_s
    done = traj.t_done <= t_s
    in_progress = announced & (traj.t_alloc <= t_s) & ~done & (traj.task_robot >= 0)
    return {
        "announced": int(announced.sum()),
        "done": int(done.sum()),
        "lost": int((announced & (traj.task_robot < 0)).sum()),
        "in_progress": int(in_progress.sum()),
    }


@dataclass(frozen=True, slots=True)
class TaskView:
    """Boolean masks over the trajectory's tasks, for one instant."""

    waiting: np.ndarray  # announced, not done, not lost (allocated now or later)
    taken: np.ndarray  # allocated to a robot and not done yet: draw robot -> task
    done: np.ndarray  # done within the recent window
    lost: np.ndarray  # never allocated, announced within the recent window


def task_view_at(traj: Trajectory, t_s: float, window_s: float) -> TaskView:
    """Which tasks to draw how at ``t_s``; tasks without a site (NaN) are never drawn."""
    seen = (traj.t_announce <= t_s) & np.all(np.isfinite(traj.task_xy), axis=1)
    done = seen & (traj.t_done <= t_s)
    lost = seen & (traj.task_robot < 0)
    taken = seen & (traj.t_alloc <= t_s) & ~done & ~lost
    return TaskView(
        waiting=seen & ~done & ~lost,
        taken=taken,
        done=done & (traj.t_done > t_s - window_s),
        lost=lost & (traj.t_announce > t_s - window_s),
    )


def nan_joined(parts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, L, 2) polylines to x, y arrays with NaN breaks, so one ``Line2D`` draws them all."""
    k, length, _ = parts.shape
    out = np.full((k, length + 1, 2), np.nan)
    out[:, :length] = parts
    out = out.reshape(-1, 2)
    return out[:, 0], out[:, 1]
