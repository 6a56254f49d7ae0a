"""What a frame shows at one instant (``sim.render.timeline``): poses, task counts, task views."""

from __future__ import annotations

import numpy as np

from sim.render.timeline import robot_poses_at, task_counts_at, task_view_at


def test_counts(hand):
    zero = {"announced": 0, "done": 0, "lost": 0, "in_progress": 0}
    assert task_counts_at(hand, 0.5) == zero
    # task 0 allocated at 1 s, done at 6 s; task 1 announced at 2 s and lost
    assert task_counts_at(hand, 3.0) == {"announced": 2, "done": 0, "lost": 1, "in_progress": 1}
    assert task_counts_at(hand, 7.0) == {"announced": 2, "done": 1, "lost": 1, "in_progress": 0}


def test_pose_interpolation(hand):
    xy, heading, state = robot_poses_at(hand, 2.05)
    np.testing.assert_allclose(xy, (hand.positions[20] + hand.positions[21]) / 2, atol=1e-6)
    np.testing.assert_allclose(heading, hand.headings[20], atol=1e-6)
    np.testing.assert_array_equal(state, hand.robot_state[20])
    np.testing.assert_allclose(robot_poses_at(hand, 99.0)[0], hand.positions[-1])


def test_task_view(hand):
    before = task_view_at(hand, 0.5, 10.0)
    assert not any(m.any() for m in (before.waiting, before.taken, before.done, before.lost))
    during = task_view_at(hand, 3.0, 10.0)
    np.testing.assert_array_equal(during.taken, [True, False])
    np.testing.assert_array_equal(during.lost, [False, True])
    after = task_view_at(hand, 8.0, 10.0)
    np.testing.assert_array_equal(after.done, [True, False])
    assert not after.taken.any()
    later = task_view_at(hand, 13.0, 5.0)  # both events older than the window
    assert not later.done.any() and not later.lost.any()
