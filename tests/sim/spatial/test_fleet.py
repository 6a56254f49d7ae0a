"""The pymunk world's fleet state (``sim.spatial.fleet``): the documented starting values, the
schedule a task event leaves, the clock, and the round trip through plain arrays."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.spatial.fleet import Clock, FleetState, Schedule, refresh_schedule, shown_now
from sim.states import DRIVING, IDLE, WAITING, WORKING, shown_states

STARTS = np.array([[1.0, 2.0], [3.5, 0.5], [6.0, 4.0]])


def test_at_start_every_robot_is_idle_free_and_still_at_its_start():
    f = FleetState.at_start(STARTS)
    assert f.state.dtype == np.int8 and f.state.tolist() == [IDLE] * 3
    assert f.task.dtype == np.int64 and f.task.tolist() == [-1] * 3
    assert f.task_type.dtype == np.int64 and f.task_type.tolist() == [0] * 3
    assert f.site.tolist() == [1 + 2j, 3.5 + 0.5j, 6 + 4j]
    assert f.last_z_m.tolist() == f.site.tolist() and f.last_z_m is not f.site
    assert f.last_th_rad.tolist() == [0.0] * 3  # facing +x
    for name in ("t_alloc_s", "bid", "work_end_s", "deadline_s", "odo0_m", "left_m"):
        assert getattr(f, name).tolist() == [0.0] * 3, name
    for name in ("yield_until_s", "v_cmd_mps", "q_cmd_mps", "moved_m"):
        assert getattr(f, name).tolist() == [0.0] * 3, name
    # inf where the minimum must not find a robot that is not driving, -inf: not backing off
    assert f.progress_m.tolist() == [math.inf] * 3
    assert f.t_progress_s.tolist() == [math.inf] * 3
    assert f.stuck_left_m.tolist() == [math.inf] * 3
    assert f.backoff_until_s.tolist() == [-math.inf] * 3
    assert f.recoveries.tolist() == [0] * 3 and f.recoveries.dtype.kind == "i"
    assert f.backoff_cmd.shape == (3, 2) and not f.backoff_cmd.any()
    assert f.replan.dtype == bool and not f.replan.any()
    assert f.yielding.dtype == bool and not f.yielding.any()
    assert f.blocker.tolist() == [-1] * 3 and f.near_m.tolist() == [math.inf] * 3
    assert f.nobody[0].tolist() == [-1] * 3 and f.nobody[1].tolist() == [math.inf] * 3


def test_at_start_takes_headings_and_integer_starts():
    f = FleetState.at_start([[1, 2], [3, 4]], headings_rad=[3, -1])  # whole radians
    assert f.last_th_rad.dtype == float and f.last_th_rad.tolist() == [3.0, -1.0]
    assert f.site.dtype == complex and f.site.tolist() == [1 + 2j, 3 + 4j]


def test_clear_way_puts_back_the_constant_nobody():
    f = FleetState.at_start(STARTS)
    f.blocker, f.near_m = np.array([2, -1, 0]), np.array([1.0, np.inf, 1.0])
    f.clear_way()
    assert f.blocker is f.nobody[0] and f.near_m is f.nobody[1]
    assert f.nobody[0].tolist() == [-1] * 3 and f.nobody[1].tolist() == [math.inf] * 3


def test_fleet_arrays_round_trip_with_each_field_s_dtype_and_shape():
    f = FleetState.at_start(STARTS, [0.1, 0.2, 0.3])
    f.state[1], f.task[1], f.site[2] = DRIVING, 7, 9.0 + 1.0j
    f.backoff_cmd[0] = (-0.2, 0.5)
    f.replan[2] = True
    arrays = f.state_arrays()
    assert "nobody" not in arrays and len(arrays) == len(FleetState.__slots__) - 1
    assert arrays["task"] is not f.task and arrays["task"].tolist() == [-1, 7, -1]
    g = FleetState.at_start(np.zeros((3, 2)))
    floats = {k: v.astype(float) if v.dtype.kind in "bi" else v for k, v in arrays.items()}
    floats["backoff_cmd"] = floats["backoff_cmd"].ravel()  # any shape of the right size
    g.restore_arrays(floats)
    for name, a in arrays.items():
        b = getattr(g, name)
        assert b.dtype == a.dtype and b.shape == a.shape and np.array_equal(a, b), name
    assert g.state_arrays()["site"] is not g.site


def test_refresh_schedule_finds_the_next_end_of_work_and_deadline_and_counts():
    f = FleetState.at_start(np.zeros((5, 2)))
    clock = Clock(0.01, steps=1000)  # 10 s
    f.task[:] = [3, 4, 0, -1, 6]  # task ids count from 0
    f.state[:] = [WORKING, DRIVING, DRIVING, IDLE, WORKING]
    f.work_end_s[:] = [30.0, 5.0, 5.0, 1.0, 20.0]  # only working robots' ends count
    f.deadline_s[:] = [2.0, 40.0, 35.0, 1.0, 3.0]  # only driving robots' deadlines count
    f.backoff_until_s[:] = [-np.inf, 10.0, 12.0, -np.inf, -np.inf]  # 10.0 is over
    f.replan[3] = True
    f.yielding[3] = True
    sch = Schedule(stuck_check_s=50.0, prox_check_s=50.0, site_check_s=7.0, resting=True)
    refresh_schedule(f, sch, clock, keep_lists=False)
    assert (sch.next_end_s, sch.next_deadline_s) == (20.0, 35.0)
    assert (sch.n_backoff, sch.n_yield, sch.n_steer) == (2, 1, 3)
    assert sch.stuck_check_s == -math.inf and sch.prox_check_s == -math.inf
    assert sch.site_check_s == 7.0 and sch.resting is False
    assert sch.state_list == [] and sch.steer_list == []
    refresh_schedule(f, sch, clock, keep_lists=True)
    assert sch.state_list == [WORKING, DRIVING, DRIVING, IDLE, WORKING]
    assert sch.steer_list == [1, 2, 3]


def test_refresh_schedule_of_an_idle_fleet_has_nothing_due():
    f = FleetState.at_start(STARTS)
    sch = Schedule()
    refresh_schedule(f, sch, Clock(0.1), keep_lists=True)
    assert (sch.next_end_s, sch.next_deadline_s) == (math.inf, math.inf)
    assert (sch.n_backoff, sch.n_yield, sch.n_steer) == (0, 0, 0)
    assert sch.steer_list == [] and sch.state_list == [IDLE] * 3


def test_a_new_schedule_has_every_check_due_and_nothing_to_compute():
    sch = Schedule()
    assert (sch.next_end_s, sch.next_deadline_s) == (math.inf, math.inf)
    assert (sch.stuck_check_s, sch.site_check_s, sch.prox_check_s) == (-math.inf,) * 3
    assert (sch.n_backoff, sch.n_yield, sch.n_steer) == (0, 0, 0)
    assert (sch.resting, sch.calm, sch.recovering) == (True, True, False)
    assert (
        sch.state_list == []
        and sch.steer_list == []
        and sch.steer_list is not Schedule().steer_list
    )


def test_schedule_arrays_round_trip_with_python_types():
    sch = Schedule(12.5, 40.0, 3.0, 4.0, 5.0, 1, 2, 3, False, False, True, [1], [2])
    arrays = sch.state_arrays()
    assert sorted(arrays) == sorted(n for n in Schedule.__slots__ if not n.endswith("_list"))
    assert all(a.shape == () for a in arrays.values())
    back = Schedule()
    back.restore_arrays(arrays)
    for name in arrays:
        got, want = getattr(back, name), getattr(sch, name)
        assert got == want and type(got) is type(want), name
    assert back.state_list == [] and back.steer_list == []  # left to the caller


def test_the_clock_counts_steps_so_time_never_drifts():
    clock = Clock(1.0 / 60.0)
    assert clock.steps == 0 and clock.time_s == 0.0
    for _ in range(6000):
        clock.steps += 1
    assert clock.time_s == 6000 * (1.0 / 60.0) == pytest.approx(100.0, abs=1e-12)


def test_the_states_recorded_are_shown_states_compiled():
    """``shown_now`` gives ``sim.states.shown_states``' answer and dtype: waiting only for a
    driving robot whose stuck clock is set after now (not at now, not inf while idle)."""
    rng = np.random.default_rng(3)
    seen = set()
    for _ in range(200):
        state = rng.choice(np.array([IDLE, DRIVING, WORKING], dtype=np.int8), 9)
        clock = rng.choice([-np.inf, 4.0, 5.0, 6.0, np.inf], 9)
        got, want = shown_now(state, clock, 5.0), shown_states(state, clock, 5.0)
        assert got.dtype == want.dtype == np.int8 and got.tolist() == want.tolist()
        assert got is not state
        seen |= set(got.tolist())
    assert seen == {IDLE, DRIVING, WORKING, WAITING}
    state = np.array([DRIVING, DRIVING, DRIVING, IDLE], dtype=np.int8)
    clock = np.array([5.0, 5.5, np.inf, np.inf])
    assert shown_now(state, clock, 5.0).tolist() == [DRIVING, WAITING, WAITING, IDLE]
