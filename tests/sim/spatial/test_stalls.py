"""Where driving robots stand still (``sim.spatial.stalls``): causes counted exactly, and in the
world."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from sim.scenario import StallSpec
from sim.spatial.stalls import CAUSES, StallMeter, nearest_other
from sim.states import DRIVING, IDLE, WORKING

# the settings' defaults (sim.scenario), under the names these tests use
LONG_S = StallSpec().long_s
NEAR_M = StallSpec().near_m
STILL_MPS = StallSpec().still_mps


def _fleet(state, v, xy, th_deg, task=None):
    xy = np.asarray(xy, dtype=float)
    return SimpleNamespace(
        state=np.array(state),
        v_cmd_mps=np.array(v, dtype=float),
        last_z_m=xy[:, 0] + 1j * xy[:, 1],
        last_th_rad=np.radians(np.array(th_deg, dtype=float)),
        task=np.arange(len(state)) if task is None else np.array(task),
    )


@pytest.fixture(params=["small", "numpy"])
def counting(request):
    """Both ways a period is counted: robot by robot in compiled code (a small team) and over
    numpy arrays (``small_max``: the largest team counted robot by robot)."""
    return {"small_max": 0} if request.param == "numpy" else {}


def _random_fleet(rng, m, grid):
    """A random fleet for one period: states, commands at and round ``still_mps``, robots on
    a 0.5 m grid (equal distances) or anywhere, headings often on the cause angles."""
    z = (rng.integers(0, 8, m) + 1j * rng.integers(0, 8, m)) * 0.5
    if not grid:
        z = z + rng.normal(0.0, 0.3, m) + 1j * rng.normal(0.0, 0.3, m)
    th = np.where(rng.random(m) < 0.5, rng.choice([0.0, 45.0, 135.0, 180.0], m), 0.0)
    th = np.radians(th + rng.uniform(0.0, 360.0, m) * (rng.random(m) < 0.5))
    return SimpleNamespace(
        state=rng.choice(np.array([IDLE, DRIVING, DRIVING, WORKING], dtype=np.int8), m),
        v_cmd_mps=rng.choice([0.0, STILL_MPS, 0.5 * STILL_MPS, 1.0], m),
        last_z_m=z,
        last_th_rad=th,
        task=rng.integers(0, 3, m),
    )


@pytest.mark.parametrize("grid", [True, False])
def test_the_compiled_count_of_a_small_team_is_the_python_one(grid):
    """Over 400 random periods of 12 robots (stands going on and ending, ties of distance on
    a grid, headings on the cause angles, robots holding, some outside the arena), the
    compiled count gives every count, stand and map cell the Python reference gives."""
    rng = np.random.default_rng(7)
    compiled = StallMeter(0.1, 3.0, 3.0)
    python = StallMeter(0.1, 3.0, 3.0)
    python._sample_small = python._sample_py
    fleet, holding = _random_fleet(rng, 12, grid), np.zeros(12, dtype=bool)
    for _ in range(400):
        new, change = _random_fleet(rng, 12, grid), rng.random(12) < 0.05  # a few change
        for key, value in vars(new).items():
            setattr(fleet, key, np.where(change, value, getattr(fleet, key)))
        holding = np.where(change, rng.random(12) < 0.2, holding)
        compiled.sample(fleet, holding)
        python.sample(fleet, holding)
        assert compiled.run.tolist() == python.run.tolist()
        assert compiled.run_task.tolist() == python.run_task.tolist()
    assert compiled.driving == python.driving > 0
    assert compiled.still.tolist() == python.still.tolist()
    assert compiled.long.tolist() == python.long.tolist() and python.long.sum() > 0
    assert (compiled.map == python.map).all() and python.map.sum() == python.still.sum()
    assert (python.still > 0).all()  # every cause came up


def test_each_still_robot_is_counted_once_under_its_cause(counting):
    """Nine robots, one period of 0.1 s: robot 0 drives (not still); 1 holds in a queue (a
    robot near or not); 2 stands next to robot 7 at work; 3 next to idle robot 8; 4 and 5
    face each other (170 degrees apart); 6 stands 1 m behind 0, 20 degrees off its heading."""
    d, i, w = DRIVING, IDLE, WORKING
    state = [d, d, d, d, d, d, d, w, i]
    v = [1.0, 0.0, 0.05, -0.05, 0.0, 0.0, 0.0, 0.0, 0.0]
    xy = [(0, 0), (0, 0.7), (10, 0), (20, 0), (30, 0), (30.6, 0), (0, -1.0), (10.8, 0), (20.9, 0)]
    th = [0.0, 0.0, 0.0, 0.0, 0.0, 170.0, 20.0, 0.0, 0.0]
    holding = np.array([False, True, False, False, False, False, False, False, False])
    meter = StallMeter(0.1, **counting)
    meter.sample(_fleet(state, v, xy, th), holding)
    got = dict(zip(CAUSES, meter.still.tolist(), strict=True))
    assert got == {
        "queue": 1,
        "robot_at_work": 1,
        "robot_idle": 1,
        "robot_head_on": 2,
        "robot_crossing": 0,
        "robot_same_way": 1,
        "no_robot": 0,
    }
    assert meter.driving == 7  # robots 0-6 drive; 7 works, 8 is idle
    out = meter.summary()
    assert out["driving_s"] == pytest.approx(0.7)
    assert out["still_s_robot_head_on"] == pytest.approx(0.2)
    assert out["still_share"] == pytest.approx(6 / 7)


def test_thresholds_speed_distance_and_angle(counting):
    """At ``STILL_MPS`` a robot moves; a robot ``NEAR_M`` away or farther is no robot; a
    crossing is between 45 and 135 degrees, the same way within 45."""
    d = DRIVING
    meter = StallMeter(0.1, **counting)
    state = [d] * 7
    v = [STILL_MPS] + [0.0] * 6
    xy = [(0, 0), (0, 10), (NEAR_M, 10), (20, 0), (20.5, 0), (30, 0), (30.5, 0)]
    th = [0.0, 0.0, 0.0, 0.0, 90.0, 0.0, 30.0]
    meter.sample(_fleet(state, v, xy, th), np.zeros(7, bool))
    got = dict(zip(CAUSES, meter.still.tolist(), strict=True))
    assert got["no_robot"] == 2  # robots 1 and 2: NEAR_M apart
    assert got["robot_crossing"] == 2  # robots 3 and 4: 90 degrees
    assert got["robot_same_way"] == 2  # robots 5 and 6: 30 degrees
    assert sum(got.values()) == 6


def test_nearest_other_in_a_large_team_is_the_nearest():
    """Beyond ``DENSE_MAX`` robots the nearest comes from a k-d tree: the same robots as from
    all distances (where one is within ``NEAR_M``), itself never; on a start grid, where up to
    four robots are equally near, the lowest index, as argmin over all distances picks."""
    rng = np.random.default_rng(3)
    scattered = rng.uniform(0, 30, 300) + 1j * rng.uniform(0, 30, 300)
    grid = (np.arange(100) % 10) * 1.0 + 1j * (np.arange(100) // 10) * 1.0 + 40.0
    for z in (scattered, np.concatenate([scattered, grid])):
        rows = np.sort(rng.choice(len(z), 120, replace=False))
        rows = np.union1d(rows, np.arange(300, len(z)))  # every grid robot
        other, dist = nearest_other(z, rows)
        d = np.abs(z[rows, None] - z[None, :])
        d[np.arange(len(rows)), rows] = np.inf
        want = d.min(axis=1)
        close = want < NEAR_M
        assert close.sum() > 20 and (~close).sum() > 0
        assert np.array_equal(other[close], d.argmin(axis=1)[close])
        assert np.allclose(dist[close], want[close], rtol=0, atol=1e-12)
        assert np.all(dist[~close] >= NEAR_M) and np.all(other != rows)


def test_the_map_puts_each_still_period_in_the_cell_of_its_robot(counting):
    """The map holds exactly the counted periods, by cause, in the 0.5 m cell of the robot's
    centre (a robot pushed outside the arena counts in the border cell); without an arena
    there is no map, and a large arena gets cells coarse enough for ``MAP_MAX_CELLS``."""
    from sim.spatial.stalls import MAP_MAX_CELLS

    d, w = DRIVING, WORKING
    state = [d, d, w, d, d, d]
    v = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    xy = [(1.26, 2.74), (4.0, 4.0), (4.6, 4.0), (-0.3, 9.9), (11.0, 9.99), (5.0, 5.0)]
    th = [0.0] * 6
    holding = np.array([True, False, False, False, False, False])
    meter = StallMeter(0.1, 10.0, 8.0, **counting)
    assert meter.map.shape == (len(CAUSES), 16, 20) and meter.cell_m == 0.5
    for _ in range(3):
        meter.sample(_fleet(state, v, xy, th), holding)
    assert np.array_equal(meter.map.sum(axis=(1, 2)), meter.still)
    cells = np.argwhere(meter.map)
    at = {(int(c), int(r), int(k)): int(meter.map[c, r, k]) for c, r, k in cells}
    q, work, none = CAUSES.index("queue"), CAUSES.index("robot_at_work"), CAUSES.index("no_robot")
    assert at == {(q, 5, 2): 3, (work, 8, 8): 3, (none, 15, 0): 3, (none, 15, 19): 3}  # row: y
    assert meter.seconds_map()[work, 8, 8] == pytest.approx(0.3)
    assert StallMeter(0.1, **counting).map.size == 0
    big = StallMeter(0.1, 1000.0, 250.0, **counting)
    assert big.map.shape[1:] == (32, MAP_MAX_CELLS) and big.cell_m == pytest.approx(1000 / 128)


def test_counts_survive_a_checkpoint_and_old_checkpoints_restore_zero():
    meter = StallMeter(0.1, 3.0, 2.0)
    meter.driving, meter.still[:] = 12, np.arange(len(CAUSES))
    meter.map[2, 1, 4] = 7
    other = StallMeter(0.1, 3.0, 2.0)
    other.restore_arrays(meter.state_arrays())
    assert other.driving == 12 and other.still.tolist() == list(range(len(CAUSES)))
    assert np.array_equal(other.map, meter.map) and other.map is not meter.map
    meter.long[:] = np.arange(len(CAUSES)) + 1
    meter.run, meter.run_task = np.array([3, 0, 21]), np.array([8, -1, 9])
    other.restore_arrays(meter.state_arrays())
    assert other.long.tolist() == list(range(1, len(CAUSES) + 1))
    assert other.run.tolist() == [3, 0, 21] and other.run_task.tolist() == [8, -1, 9]
    other.restore_arrays({})  # written before the meter existed
    assert other.driving == 0 and not other.still.any() and not other.map.any()
    assert not other.long.any() and other.run.shape == other.run_task.shape == (0,)
    with pytest.raises(ValueError, match="stalls/long"):
        other.restore_arrays({"long": np.zeros(2)})
    with pytest.raises(ValueError, match="stalls/run"):
        other.restore_arrays({"run": np.zeros(3), "run_task": np.zeros(2)})
    with pytest.raises(ValueError, match="stalls/still"):
        other.restore_arrays({"driving": np.array(1), "still": np.zeros(3)})
    with pytest.raises(ValueError, match="stalls/map"):
        other.restore_arrays({"driving": np.array(1), "map": np.zeros((len(CAUSES), 2, 2))})
    sized = StallMeter(0.1, 3.0, 2.0, n_robots=3)  # the fleet's size known: stands checked
    sized.restore_arrays(meter.state_arrays())
    assert sized.run.tolist() == [3, 0, 21]
    sized.restore_arrays({"run": np.zeros(0), "run_task": np.zeros(0)})  # no period yet
    with pytest.raises(ValueError, match="stalls/run: 4 robots' stands, the fleet has 3"):
        sized.restore_arrays({"run": np.zeros(4), "run_task": np.zeros(4)})


def test_standing_past_long_s_is_long_and_a_stand_ends_when_it_moves_or_changes_task(counting):
    """Periods of 0.1 s, ``LONG_S`` = 2 s: robot 0 stands alone (no robot near) 25 periods:
    the last 5 are long. It moves one period and stands 21 more: 1 long. Standing on, it gets
    another task: a new stand, 20 periods and none long. Robot 1 drives all along; robot 2
    stands idle (not driving: never counted)."""
    d, i = DRIVING, IDLE
    meter = StallMeter(0.1, **counting)
    assert meter.long_after == round(LONG_S / 0.1) == 20
    xy, th = [(0, 0), (10, 0), (20, 0)], [0.0, 0.0, 0.0]

    def period(v0, task0=5):
        meter.sample(_fleet([d, d, i], [v0, 1.0, 0.0], xy, th, [task0, 7, -1]), np.zeros(3, bool))

    for _ in range(25):
        period(0.0)
    assert meter.still[CAUSES.index("no_robot")] == 25 and meter.long.sum() == 5
    assert meter.run.tolist() == [25, 0, 0]
    period(0.5)  # moves: the stand ends
    for _ in range(21):
        period(0.0)
    assert meter.long.sum() == 6
    for _ in range(20):
        period(0.0, task0=6)  # the same place, another task: a new stand
    assert meter.long.sum() == 6 and meter.run.tolist() == [20, 0, 0]
    out = meter.summary()
    assert out["still_long_s_no_robot"] == pytest.approx(0.6)
    assert out["still_s_no_robot"] == pytest.approx(6.6)
    assert sum(v for k, v in out.items() if k.startswith("still_long_s_")) == pytest.approx(0.6)
    meter.sample(_fleet([i, i, i], [0.0] * 3, xy, th, [-1] * 3), np.zeros(3, bool))
    assert meter.run.tolist() == [0, 0, 0]  # nobody drives: every stand over


def test_long_standing_goes_under_the_cause_of_each_period(counting):
    """A robot stands 30 periods; a robot at work is beside it in periods 15-24: of the 10
    long periods (20-29), 5 are 'beside a robot at work' and 5 'no robot'."""
    d, w = DRIVING, WORKING
    meter = StallMeter(0.1, **counting)
    for k in range(30):
        there = 15 <= k < 25
        xy = [(0, 0), (0.8, 0) if there else (30, 0)]
        meter.sample(_fleet([d, w], [0.0, 0.0], xy, [0.0, 0.0], [3, 4]), np.zeros(2, bool))
    long = dict(zip(CAUSES, meter.long.tolist(), strict=True))
    assert long["no_robot"] == 5 and long["robot_at_work"] == 5 and sum(long.values()) == 10


# -- the cases the tests above left open (a mutation screen found them) ----------------------
def test_nearest_other_of_a_lone_robot_is_none():
    other, dist = nearest_other(np.array([3 + 4j]), np.array([0]))
    assert other.dtype.kind == "i" and other.tolist() == [0] and dist.tolist() == [np.inf]


def test_nearest_other_in_a_large_team_beyond_near_m_is_none_and_up_to_64_the_true_one():
    grid = np.array([complex(x, y) for x in range(8) for y in range(8)]) * 2.0  # 64, 2 m apart
    other, dist = nearest_other(grid, np.array([0, 9]))
    assert dist.tolist() == [2.0, 2.0] and other.tolist() == [1, 1]  # all distances: the nearest
    big = np.concatenate([grid, [100 + 100j]])  # 65: the k-d tree, within NEAR_M only
    other, dist = nearest_other(big, np.array([0, 64]))
    assert other.tolist() == [0, 0] and dist.tolist() == [np.inf, np.inf]
    big[1] = 0.5j  # now robot 1 is 0.5 m from robot 0
    other, dist = nearest_other(big, np.array([0, 1]))
    assert other.tolist() == [1, 0] and dist.tolist() == [0.5, 0.5]


def test_of_two_equally_near_robots_the_first_is_the_cause(counting):
    d, w, i = DRIVING, WORKING, IDLE
    meter = StallMeter(0.1, **counting)
    xy = [(5, 5), (5, 5.6), (5, 4.4)]  # robot 1 (working) and 2 (idle) both 0.6 m away
    meter.sample(_fleet([d, w, i], [0, 0, 0], xy, [0, 0, 0]), np.zeros(3, bool))
    assert meter.still.tolist()[CAUSES.index("robot_at_work")] == 1


@pytest.mark.parametrize(
    ("a_deg", "b_deg", "cause"),
    [
        (90.0, 90.0, "robot_same_way"),  # the difference counts, not the sum
        (0.0, 135.0, "robot_crossing"),  # exactly 135 degrees is not yet head-on
        (0.0, 45.0, "robot_crossing"),  # exactly 45 degrees is not yet the same way
    ],
)
def test_the_angle_between_headings_decides_head_on_crossing_or_same_way(
    counting, a_deg, b_deg, cause
):
    d = DRIVING
    meter = StallMeter(0.1, **counting)
    meter.sample(_fleet([d, d], [0.0, 1.0], [(1, 1), (1.5, 1)], [a_deg, b_deg]), np.zeros(2, bool))
    assert meter.still.tolist() == [int(c == cause) for c in CAUSES]


def test_robots_outside_the_arena_count_in_the_cells_at_its_border(counting):
    d = DRIVING
    meter = StallMeter(0.1, width_m=2.0, height_m=1.0, **counting)
    xy = [(-0.7, -0.6), (0.2, 0.2), (2.4, 1.3), (1.2, 0.7)]  # x, y < -0.5 m: below cell 0
    meter.sample(_fleet([d] * 4, [0.0] * 4, xy, [0.0] * 4), np.zeros(4, bool))
    cells = meter.seconds_map().sum(axis=0)  # every cause
    assert cells.shape == (2, 4)
    assert (cells / 0.1).round().astype(int).tolist() == [[2, 0, 0, 0], [0, 0, 1, 1]]


def test_a_meter_without_an_arena_keeps_no_map_and_a_small_arena_has_cells():
    assert StallMeter(0.1).seconds_map().shape == (len(CAUSES), 0, 0)
    assert StallMeter(0.1, 0.8, 0.6).seconds_map().shape == (len(CAUSES), 2, 2)


def test_counts_are_integers_from_a_fresh_meter_a_sampled_one_and_an_old_checkpoint(counting):
    d = DRIVING
    meter = StallMeter(0.1, 4.0, 4.0, **counting)
    for name, a in meter.state_arrays().items():
        assert a.dtype == np.int64, name
    meter.sample(_fleet([d, d], [0.0, 0.0], [(1, 1), (1.5, 1)], [0, 90]), np.zeros(2, bool))
    for name, a in meter.state_arrays().items():
        assert a.dtype == np.int64, name
    old = StallMeter(0.1, 4.0, 4.0, **counting)
    old.restore_arrays({"still": np.arange(len(CAUSES), dtype=float)})  # before stands counted
    for name, a in old.state_arrays().items():
        assert a.dtype == np.int64, name
    assert old.state_arrays()["still"].tolist() == list(range(len(CAUSES)))


def test_driving_adds_up_over_periods_and_one_period_standing_is_all_of_it(counting):
    d = DRIVING
    meter = StallMeter(0.1, **counting)
    meter.sample(_fleet([d, IDLE], [0.0, 0.0], [(1, 1), (9, 9)], [0, 0]), np.zeros(2, bool))
    assert meter.summary()["still_share"] == 1.0  # one robot-period driving, standing
    meter.sample(_fleet([d, d], [1.0, 0.0], [(1, 1), (9, 9)], [0, 0]), np.zeros(2, bool))
    assert meter.driving == 3 and meter.summary()["driving_s"] == pytest.approx(0.3)
    assert meter.summary()["still_share"] == pytest.approx(2 / 3)
