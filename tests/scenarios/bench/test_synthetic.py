"""The synthetic trajectory (``scenarios.bench.synthetic``) that render benchmarks and tests draw:
plausible, seeded, and the same after a round trip through npz."""

from __future__ import annotations

import numpy as np
from matplotlib.path import Path as MplPath

from scenarios.bench.synthetic import synthetic_trajectory
from sim.recording import Trajectory
from sim.render import render_frame
from sim.states import DRIVING, IDLE, WORKING


def test_synthetic_trajectory_is_plausible(synth):
    T, m = len(synth.times_s), len(synth.robot_names)
    assert synth.positions.shape == (T, m, 2) and m == 10
    assert synth.headings.shape == synth.robot_state.shape == (T, m)
    np.testing.assert_allclose(np.diff(synth.times_s), 0.1, atol=1e-6)
    assert set(np.unique(synth.robot_state)) == {IDLE, DRIVING, WORKING}
    assert np.all((synth.positions >= 0) & (synth.positions <= 20))
    assert synth.obstacles.shape[0] == 3 and np.isnan(synth.obstacles).any()  # NaN-padded
    flat = synth.positions.reshape(-1, 2)
    for poly in synth.obstacles:
        pts = poly[np.all(np.isfinite(poly), axis=1)]
        assert not MplPath(pts).contains_points(flat).any()  # nobody drives through walls
    n = len(synth.task_id)
    assert n == 20 and synth.task_xy.shape == (n, 2)
    lost = synth.task_robot < 0
    assert lost.any() and (~lost).any()
    assert np.all(np.isnan(synth.t_alloc[lost]))
    assert np.all(synth.t_alloc[~lost] >= synth.t_announce[~lost])
    done = np.isfinite(synth.t_done)
    assert done.sum() >= 5 and np.all(synth.t_done[done] > synth.t_alloc[done])
    assert synth.task_high.any() and (~synth.task_high).any()


def test_synthetic_trajectory_is_seeded():
    a = synthetic_trajectory(np.random.default_rng(3), robots=4, seconds=15.0, tasks=6)
    b = synthetic_trajectory(np.random.default_rng(3), robots=4, seconds=15.0, tasks=6)
    c = synthetic_trajectory(np.random.default_rng(4), robots=4, seconds=15.0, tasks=6)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.task_xy, b.task_xy)
    assert not np.array_equal(a.positions, c.positions)


def test_synthetic_trajectory_round_trips_through_npz(tmp_path):
    traj = synthetic_trajectory(np.random.default_rng(5), robots=3, seconds=10.0, tasks=5)
    traj.save(tmp_path / "t.npz")
    back = Trajectory.load(tmp_path / "t.npz")
    frame_a = render_frame(traj, 5.0, size=(128, 128))
    frame_b = render_frame(back, 5.0, size=(128, 128))
    np.testing.assert_array_equal(frame_a, frame_b)
