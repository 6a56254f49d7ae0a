"""Fixtures of the rendering tests: a hand-made trajectory of two robots and two tasks, and the
frame scene that projects its metres to pixels."""

from __future__ import annotations

import numpy as np
import pytest

from sim.recording import Trajectory
from sim.render.scene import FrameScene
from sim.states import DRIVING, IDLE, WORKING

SIZE = (400, 400)  # px, the frames the projecting scene is built for (test_frames.py)


@pytest.fixture(scope="module")
def hand() -> Trajectory:
    """Two robots, two tasks, 14 s at 0.1 s.

    Robot 0 idles at (2, 9), drives to (5, 6.2) between t = 1 and 4 s (task 0 at (5, 5): type 0,
    high priority, announced and allocated at 1 s), works there until 6 s, then idles. Robot 1
    idles at (15, 5). Task 1 (type 1, low priority, (15, 15)) is announced at 2 s and lost.
    """
    times = np.round(np.arange(0, 14.0001, 0.1), 6)
    start, goal = np.array([2.0, 9.0]), np.array([5.0, 6.2])
    w = np.clip((times - 1.0) / 3.0, 0.0, 1.0)[:, None]
    pos = np.empty((len(times), 2, 2))
    pos[:, 0] = start + w * (goal - start)
    pos[:, 1] = (15.0, 5.0)
    head = np.zeros((len(times), 2))
    head[:, 0] = np.arctan2(*(goal - start)[::-1])
    state = np.full((len(times), 2), IDLE, dtype=np.int8)
    state[(times > 1.0) & (times < 4.0), 0] = DRIVING
    state[(times >= 4.0) & (times < 6.0), 0] = WORKING
    nan = np.nan
    return Trajectory(
        times_s=times,
        positions=pos.astype(np.float32),
        headings=head.astype(np.float32),
        robot_state=state,
        task_id=np.array([0, 1]),
        task_type=np.array([0, 1]),
        task_high=np.array([True, False]),
        task_xy=np.array([[5.0, 5.0], [15.0, 15.0]]),
        t_announce=np.array([1.0, 2.0]),
        t_alloc=np.array([1.0, nan]),
        t_done=np.array([6.0, nan]),
        task_robot=np.array([0, -1]),
        arena_wh=np.array([20.0, 20.0]),
        obstacles=np.array([[[8.0, 8.0], [11.0, 8.0], [11.0, 11.0], [nan, nan]]]),
        type_names=np.array(["weld", "carry"]),
        robot_names=np.array(["R1", "R2"]),
    )


@pytest.fixture(scope="module")
def scene(hand) -> FrameScene:
    """Only for projecting metres to pixels: the layout depends on size and trajectory alone."""
    return FrameScene(hand, SIZE)
