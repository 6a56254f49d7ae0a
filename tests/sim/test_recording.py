"""Trajectory recording (``sim.recording``): what a recorder keeps, in which types, and what an
``.npz`` gives back, worked out by hand for a small run."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.recording import Trajectory, TrajectoryRecorder
from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.states import DRIVING, IDLE, WAITING, WORKING, shown_states

TRIANGLE = ((1.0, 1.0), (2.0, 1.0), (1.5, 2.0))
SQUARE = ((4.0, 4.0), (5.0, 4.0), (5.0, 5.0), (4.0, 5.0))


def recorder(every_s: float = 0.5) -> TrajectoryRecorder:
    sites = (((1.0, 5.0), (2.0, 5.0)), ((6.0, 1.0),))  # two of type A, one of type B
    return TrajectoryRecorder(
        (8.0, 6.0), (TRIANGLE, SQUARE), ("A", "B"), ("R1", "R2"), every_s, sites
    )


def test_the_arena_obstacles_names_and_sites_are_kept_as_plain_arrays():
    t = recorder().finish()
    assert t.arena_wh.dtype == float and t.arena_wh.tolist() == [8.0, 6.0]
    assert t.obstacles.shape == (2, 4, 2)  # padded to the widest polygon with NaN
    assert t.obstacles[0, :3].tolist() == [list(p) for p in TRIANGLE]
    assert np.isnan(t.obstacles[0, 3]).all()
    assert t.obstacles[1].tolist() == [list(p) for p in SQUARE]
    assert t.type_names.tolist() == ["A", "B"] and t.type_names.dtype.kind == "U"
    assert t.robot_names.tolist() == ["R1", "R2"] and t.robot_names.dtype.kind == "U"
    assert t.site_xy.tolist() == [[1.0, 5.0], [2.0, 5.0], [6.0, 1.0]]
    assert t.site_type.dtype == np.int64 and t.site_type.tolist() == [0, 0, 1]


def test_an_arena_without_obstacles_or_sites_records_empty_arrays_of_the_right_shape():
    t = TrajectoryRecorder((3.0, 2.0), (), ("A",), ("R1",)).finish()
    assert t.obstacles.shape == (0, 0, 2)
    assert t.site_xy.shape == (0, 2) and t.site_xy.dtype == float
    assert t.site_type.shape == (0,) and t.site_type.dtype == np.int64
    assert t.positions.shape == (0, 1, 2) and t.headings.shape == (0, 1)
    assert t.robot_state.shape == (0, 1) and t.times_s.shape == (0,)
    assert t.positions.dtype == np.float32 and t.headings.dtype == np.float32
    assert t.robot_state.dtype == np.int8 and t.times_s.dtype == np.float64
    assert t.task_xy.shape == (0, 2) and t.task_id.dtype == np.int64
    assert t.task_high.dtype == bool and t.t_alloc.dtype == float


def test_poses_are_kept_at_most_every_every_s_of_simulated_time():
    rec = recorder(every_s=0.5)
    assert not rec.has_poses()
    t, kept = 0.0, []
    for k in range(12):  # a clock that adds 0.1 s a period, as a world's does
        if k in (0, 5, 10):
            kept.append(t)
        rec.poses(t, [[t, 0.0], [0.0, t]], [t, -t], [IDLE, DRIVING])
        t += 0.1
    assert rec.has_poses()
    tr = rec.finish()
    # ten additions of 0.1 give 0.9999999999999999: the 1e-9 s slack keeps that period
    assert kept[2] < 1.0 and tr.times_s.tolist() == kept
    assert tr.positions.dtype == np.float32 and tr.headings.dtype == np.float32
    assert tr.positions[1].tolist() == np.float32([[kept[1], 0.0], [0.0, kept[1]]]).tolist()
    assert tr.headings[2].tolist() == np.float32([kept[2], -kept[2]]).tolist()
    assert tr.robot_state.dtype == np.int8 and tr.robot_state.tolist() == [[IDLE, DRIVING]] * 3


def test_a_pose_just_short_of_the_period_is_skipped():
    rec = recorder(every_s=1.0)
    rec.poses(0.0, [[0, 0], [1, 1]], [0, 0], [IDLE, IDLE])
    rec.poses(1.0 - 2e-9, [[0, 0], [1, 1]], [0, 0], [IDLE, IDLE])
    rec.poses(1.0 - 1e-9, [[0, 0], [1, 1]], [0, 0], [WORKING, WAITING])  # + 1e-9 is 1.0: kept
    tr = rec.finish()
    assert (1.0 - 1e-9) + 1e-9 == 1.0
    assert tr.times_s.tolist() == [0.0, 1.0 - 1e-9]
    assert tr.robot_state[1].tolist() == [WORKING, WAITING]


def test_task_events_fill_one_row_per_announcement():
    rec = recorder()
    rec.announce(0.0, np.array([10, 11, 12]), [0, 1, 0], [True, False, False], None)
    rec.allocate(0.0, [10, 11, 12], np.array([1, -1, 0]))
    rec.announce(2.0, [13], [1], [True], np.array([[6.0, 1.0]]))
    rec.allocate(2.0, [13], [1])
    rec.done(12, 7.5)
    t = rec.finish()
    assert t.task_id.tolist() == [10, 11, 12, 13] and t.task_id.dtype == np.int64
    assert t.task_type.tolist() == [0, 1, 0, 1] and t.task_type.dtype == np.int64
    assert t.task_high.tolist() == [True, False, False, True]
    assert np.isnan(t.task_xy[:3]).all() and t.task_xy[3].tolist() == [6.0, 1.0]
    assert t.t_announce.tolist() == [0.0, 0.0, 0.0, 2.0]
    assert np.array_equal(t.t_alloc, [0.0, np.nan, 0.0, 2.0], equal_nan=True)
    assert np.array_equal(t.t_done, [np.nan, np.nan, 7.5, np.nan], equal_nan=True)
    assert t.task_robot.tolist() == [1, -1, 0, 1] and t.task_robot.dtype == np.int64


def test_a_task_announced_again_is_a_new_row_and_later_events_go_to_it():
    rec = recorder()
    rec.announce(0.0, [5], [0], [False], np.array([[1.0, 5.0]]))
    rec.allocate(0.0, [5], [0])
    rec.announce(3.0, [5], [0], [False], np.array([[1.0, 5.0]]))  # a replayed set
    rec.allocate(3.0, [5], [1])
    rec.done(5, 9.0)
    t = rec.finish()
    assert t.task_id.tolist() == [5, 5]
    assert t.t_alloc.tolist() == [0.0, 3.0] and t.task_robot.tolist() == [0, 1]
    assert np.isnan(t.t_done[0]) and t.t_done[1] == 9.0


def test_a_trajectory_survives_a_round_trip_through_npz_field_by_field(tmp_path):
    rec = recorder()
    rec.poses(0.0, [[1, 2], [3, 4]], [0.5, 1.5], [DRIVING, WORKING])
    rec.announce(0.0, [1], [1], [True], np.array([[6.0, 1.0]]))
    rec.allocate(0.0, [1], [0])
    rec.done(1, 4.0)
    traj = rec.finish()
    path = tmp_path / "run.npz"
    traj.save(path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.npz"]  # no temporary file left
    back = Trajectory.load(path)
    for f in dataclasses.fields(Trajectory):
        a, b = getattr(traj, f.name), getattr(back, f.name)
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), f.name
    with np.load(path, allow_pickle=False) as data:
        assert sorted(data.files) == sorted(f.name for f in dataclasses.fields(Trajectory))


def test_a_file_from_before_sites_were_recorded_loads_without_them(tmp_path):
    traj = recorder().finish()
    old = {f.name: getattr(traj, f.name) for f in dataclasses.fields(Trajectory)}
    del old["site_xy"], old["site_type"]
    np.savez(tmp_path / "old.npz", **old)
    back = Trajectory.load(tmp_path / "old.npz")
    assert back.site_xy.shape == (0, 2) and back.site_type.shape == (0,)
    assert back.obstacles.shape == traj.obstacles.shape


def test_a_recorder_for_a_scenario_reads_its_arena():
    sp = SpatialSpec(12.0, 9.0, (SQUARE,), (((1.0, 1.0),), ((3.0, 3.0), (4.0, 3.0))), DriveSpec())
    sc = Scenario(
        "rec",
        ("A", "B"),
        (RobotSpec("W1", (0,), (2.0, 2.0)), RobotSpec("W2", (1,), (3.0, 2.0))),
        ((1.0, np.inf), (np.inf, 1.0)),
        (10.0, 10.0),
        spatial=sp,
    )
    rec = TrajectoryRecorder.for_scenario(sc, every_s=0.25)
    assert rec.every_s == 0.25
    t = rec.finish()
    assert t.arena_wh.tolist() == [12.0, 9.0] and t.obstacles.shape == (1, 4, 2)
    assert t.robot_names.tolist() == ["W1", "W2"] and t.type_names.tolist() == ["A", "B"]
    assert t.site_type.tolist() == [0, 1, 1]
    assert TrajectoryRecorder.for_scenario(sc).every_s == pytest.approx(0.1)


def test_recorded_states_show_a_driving_robot_that_decided_to_wait_as_waiting():
    state = np.array([DRIVING, DRIVING, WORKING, IDLE, DRIVING], dtype=np.int8)
    t_progress = np.array([12.0, 10.0, 30.0, np.inf, np.inf])
    got = shown_states(state, t_progress, 10.0)
    assert got.tolist() == [WAITING, DRIVING, WORKING, IDLE, WAITING]
    assert got.dtype == np.int8


def test_the_default_pose_period_is_a_tenth_of_a_second():
    assert TrajectoryRecorder((3.0, 2.0), (), ("A",), ("R1",)).every_s == 0.1


def test_an_allocation_for_other_tasks_than_announced_is_refused():
    rec = recorder()
    rec.announce(0.0, [1, 2], [0, 0], [False, False], None)
    with pytest.raises(ValueError, match="zip"):
        rec.allocate(0.0, [1, 2], [0])


def test_integer_times_and_coordinates_are_recorded_as_floats():
    """A caller's whole seconds and metres give the same arrays as floats would."""
    rec = TrajectoryRecorder((8, 6), (((1, 1), (2, 1), (1, 2)),), ("A",), ("R1",), 1, (((1, 5),),))
    rec.poses(0, [[1, 2]], [0], [IDLE])
    rec.announce(2, [7], [0], [True], np.array([[1, 5]]))
    rec.allocate(3, [7], [0])
    rec.done(7, 9)
    t = rec.finish()
    for name in ("arena_wh", "obstacles", "site_xy", "times_s", "task_xy", "t_announce"):
        assert getattr(t, name).dtype == np.float64, name
    assert t.t_alloc.dtype == np.float64 and t.t_done.dtype == np.float64
    assert (t.t_announce[0], t.t_alloc[0], t.t_done[0]) == (2.0, 3.0, 9.0)


def test_a_file_with_an_object_array_is_refused_not_unpickled(tmp_path):
    traj = recorder().finish()
    fields = {f.name: getattr(traj, f.name) for f in dataclasses.fields(Trajectory)}
    fields["robot_names"] = np.array([{"R1": 1}, None], dtype=object)  # pickled on save
    np.savez(tmp_path / "evil.npz", **fields)
    with pytest.raises(ValueError, match="allow_pickle=False"):
        Trajectory.load(tmp_path / "evil.npz")
