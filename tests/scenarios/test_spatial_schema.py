"""The [spatial] table: bundled layouts load, bad layouts fail at load time naming the key."""

from __future__ import annotations

import copy
import tomllib
from importlib import resources

import numpy as np
import pytest

from scenarios.loader import ScenarioError, load_scenario, parse_scenario
from sim.scenario import OrcaSpec
from sim.spatial.world import PymunkWorld
from sim.tasks import Batch

# the settings' defaults (sim.scenario), under the names these tests use
MARGIN_M = OrcaSpec().margin_m


SPATIAL = ["paper_spatial", "warehouse", "warehouse_wide", "warehouse_pickface", "large"]


def doc(name: str = "paper_spatial") -> dict:
    text = (resources.files("scenarios") / "data" / f"{name}.toml").read_text()
    return tomllib.loads(text)


def fails(d: dict, *needles: str) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(d, source="x.toml")
    msg = str(info.value)
    assert "\n" not in msg
    for needle in needles:
        assert needle in msg, msg
    return msg


@pytest.mark.parametrize("name", SPATIAL)
def test_bundled_spatial_scenarios_load_and_drive(name):
    sc = load_scenario(name)
    sp = sc.spatial
    assert sp is not None and all(r.start_xy is not None for r in sc.robots)
    assert len(sp.sites) == sc.n_types and all(len(s) >= 2 for s in sp.sites)
    world = PymunkWorld(sc)
    capable = sc.capability_matrix()
    k = min(3, sc.n_types)
    robots = [int(np.flatnonzero(capable[:, i])[0]) for i in range(k)]
    if len(set(robots)) == k:
        sites = np.array([sp.sites[i][0] for i in range(k)], dtype=float)
        batch = Batch(0, 0, np.arange(k), np.arange(k), np.zeros(k, bool), sites)
        world.apply(batch, np.array(robots), np.ones(k))
    world.advance(2.0)
    assert np.isfinite(world.snapshot().positions).all()


def test_paper_spatial_keeps_the_paper_robots_and_stream():
    paper, spatial = load_scenario("paper"), load_scenario("paper_spatial")
    assert [r.capabilities for r in paper.robots] == [r.capabilities for r in spatial.robots]
    assert paper.cost == spatial.cost and paper.stream == spatial.stream


def test_site_inside_an_obstacle():
    d = doc()
    d["spatial"]["sites"]["T1"][0] = [6.0, 5.5]
    fails(d, "x.toml: spatial.sites.T1[0]:", "inside spatial.obstacles[0]")


def test_site_too_close_to_an_obstacle_for_a_robot_centre():
    d = doc()
    d["spatial"]["sites"]["T2"][1] = [8.2, 5.5]
    fails(d, "spatial.sites.T2[1]:", "spatial.obstacles[0]", "no robot centre")


def test_site_outside_the_arena():
    d = doc()
    d["spatial"]["sites"]["T3"][0] = [25.0, 5.0]
    fails(d, "spatial.sites.T3[0]:", "outside the arena")


def test_robot_starting_in_the_wall():
    d = doc()
    d["robots"][0]["start"] = [0.1, 10.0]
    fails(d, "robots[0].start:", "outside the arena or into a wall")


def test_robot_starting_inside_an_obstacle():
    d = doc()
    d["robots"][2]["start"] = [6.0, 6.0]
    fails(d, "robots[2].start:", "spatial.obstacles[0]")


def test_overlapping_robots():
    d = doc()
    d["robots"][1]["start"] = [1.8, 10.0]
    fails(d, "robots[1].start:", "overlaps robots[0] (R1)")


def test_robot_without_a_start():
    d = doc()
    del d["robots"][4]["start"]
    fails(d, "robots[4].start:", "missing")


def test_site_walled_off_from_every_capable_robot():
    d = doc()
    d["spatial"]["obstacles"] += [
        [[0.0, 16.5], [4.0, 16.5], [4.0, 17.0], [0.0, 17.0]],
        [[3.5, 16.5], [4.0, 16.5], [4.0, 20.0], [3.5, 20.0]],
    ]
    fails(d, "spatial.sites.T2[1]:", "unreachable from robots[")


def test_unknown_key_suggests_the_nearest():
    d = doc()
    d["spatial"]["widht_m"] = d["spatial"].pop("width_m")
    fails(d, "spatial.widht_m: unknown key (did you mean 'width_m'?)")
    d = doc()
    d["spatial"]["drive"]["radius"] = 0.3
    fails(d, "spatial.drive.radius: unknown key (did you mean 'radius_m'?)")
    d = doc()
    d["spatial"]["sites"]["T9"] = [[1.0, 1.0]]
    fails(d, "spatial.sites.T9: unknown key")


def test_missing_site_list_for_a_type():
    d = doc()
    del d["spatial"]["sites"]["T5"]
    fails(d, "spatial.sites.T5: missing")


@pytest.mark.parametrize(
    "key, value, needle",
    [
        ("dt_s", 0.0, "spatial.dt_s: must be in [0.0001, 0.05] s, got 0.0"),
        ("dt_s", -1.0, "spatial.dt_s: must be in [0.0001, 0.05] s, got -1.0"),
        ("dt_s", float("nan"), "spatial.dt_s: must be finite"),
        ("width_m", float("inf"), "spatial.width_m: must be finite"),
        ("control_hz", 1000.0, "spatial.control_hz: control (1000 Hz) cannot run faster"),
        ("arrive_tol_m", 0.0, "spatial.arrive_tol_m: must be in (0, 10] m, got 0.0"),
        ("max_recoveries", 1.5, "spatial.max_recoveries: must be an integer"),
        ("grid_res_m", 1e-4, "spatial.grid_res_m: must be in [0.01, 10] m, got 0.0001"),
    ],
)
def test_bad_numbers(key, value, needle):
    d = doc()
    d["spatial"][key] = value
    fails(d, needle)


def test_a_fine_grid_on_a_large_arena_is_refused():
    d = doc()
    d["spatial"].update(width_m=30.0, height_m=30.0, grid_res_m=0.01)  # 3000 x 3000 cells
    fails(d, "spatial.grid_res_m: the grid would have more than 4,000,000 cells")
    d["spatial"].update(width_m=19.0, height_m=19.0)  # 1900 x 1900 cells: in bounds
    assert loads(d).grid_res_m == 0.01


def test_obstacles_must_be_convex_and_in_the_arena():
    d = doc()
    d["spatial"]["obstacles"][1] = [[12, 4], [16, 4], [14, 5], [16, 7], [12, 7]]
    fails(d, "spatial.obstacles[1]: must be convex")
    d = doc()
    d["spatial"]["obstacles"][2][1] = [28.0, 13.0]
    fails(d, "spatial.obstacles[2][1]: vertex (28, 13) outside the arena")
    d = doc()
    d["spatial"]["obstacles"][0][0] = [4.0, "a"]
    fails(d, "spatial.obstacles[0][0][1]: must be a number")


def test_clockwise_obstacles_are_accepted():
    d = copy.deepcopy(doc())
    d["spatial"]["obstacles"][0] = d["spatial"]["obstacles"][0][::-1]
    poly = np.array(parse_scenario(d).spatial.obstacles[0])
    x, y = poly.T
    assert set(map(tuple, poly.tolist())) == {(4, 4), (8, 4), (8, 7), (4, 7)}
    assert (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() > 0  # stored counter-clockwise


def loads(d: dict):
    return parse_scenario(d, source="x.toml").spatial


@pytest.mark.parametrize("key", ["width_m", "height_m"])
def test_arena_size_must_be_positive(key):
    for value in (0.0, -1.0):
        d = doc()
        d["spatial"][key] = value
        fails(d, f"x.toml: spatial.{key}: must be in (0, 10,000] m, got {value}")
    d = doc()
    d["spatial"][key] = 0.5  # positive, but the first obstacle no longer fits
    fails(d, "x.toml: spatial.obstacles[0][0]: vertex (4, 4) outside the arena")


def test_drive_and_sites_must_be_tables_of_positive_numbers():
    d = doc()
    d["spatial"]["drive"] = 5
    fails(d, "x.toml: spatial.drive: must be a table, got number 5")
    d = doc()
    d["spatial"]["sites"] = 5
    fails(d, "x.toml: spatial.sites: must be a table, got number 5")
    for value in (0.0, -0.1):
        d = doc()
        d["spatial"]["drive"]["radius_m"] = value
        fails(d, f"x.toml: spatial.drive.radius_m: must be in [0.01, 5] m, got {value}")


def test_wheels_as_wide_as_the_robot_fit():
    d = doc()
    d["spatial"]["drive"]["wheel_base_m"] = 0.5  # = 2 * radius_m
    assert loads(d).drive.wheel_base_m == 0.5


def test_points_name_their_coordinate():
    d = doc()
    d["spatial"]["obstacles"][0][0] = ["a", 4.0]
    fails(d, "x.toml: spatial.obstacles[0][0][0]: must be a number, got string 'a'")


def test_obstacles_are_optional_and_may_touch_the_walls():
    d = doc()
    del d["spatial"]["obstacles"]
    assert loads(d).obstacles == ()
    d = doc()
    d["spatial"]["obstacles"] = [[[16.0, 0.0], [20.0, 0.0], [20.0, 1.0], [16.0, 1.0]]]
    assert loads(d).obstacles == (((16.0, 0.0), (20.0, 0.0), (20.0, 1.0), (16.0, 1.0)),)


@pytest.mark.parametrize("clockwise", [False, True])
def test_small_obstacles_are_convex_and_stored_counter_clockwise(clockwise):
    tri = [[10.0, 8.0], [10.5, 8.0], [10.0, 8.5]]  # edges of 0.5 m: cross products 0.25
    d = doc()
    d["spatial"]["obstacles"] = [tri[::-1] if clockwise else tri]
    x, y = np.array(loads(d).obstacles[0]).T
    assert (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() > 0


def test_collinear_vertices_of_a_clockwise_polygon_are_refused():
    d = doc()
    d["spatial"]["obstacles"][0] = [[4.0, 4.0], [4.0, 7.0], [8.0, 7.0], [8.0, 4.0], [6.0, 4.0]]
    fails(d, "x.toml: spatial.obstacles[0]: must be convex, with no repeated or collinear")


def test_ten_thousand_sites_are_allowed():
    d = doc()
    d["spatial"]["sites"]["T5"] = [[14.0, 2.0]] * 10_000
    assert len(loads(d).sites[4]) == 10_000


@pytest.mark.parametrize(
    ("xy", "problem"),
    [
        ((0.0, 5.0), "(0, 5) is within 0.35 m of the arena wall: unreachable"),
        ((20.0, 5.0), "(20, 5) is within 0.35 m of the arena wall: unreachable"),
        ((10.0, 0.0), "(10, 0) is within 0.35 m of the arena wall: unreachable"),
        ((10.0, 20.0), "(10, 20) is within 0.35 m of the arena wall: unreachable"),
        ((19.8, 5.0), "(19.8, 5) is within 0.35 m of the arena wall: unreachable"),
        ((10.0, 19.8), "(10, 19.8) is within 0.35 m of the arena wall: unreachable"),
        (
            (8.0, 5.5),
            "(8, 5.5) is within 0.35 m (robot radius + clearance) of spatial.obstacles[0]",
        ),
    ],
)
def test_sites_on_a_wall_or_an_obstacle_edge(xy, problem):
    d = doc()
    d["spatial"]["sites"]["T2"][0] = list(xy)
    fails(d, f"x.toml: spatial.sites.T2[0]: {problem}")


def test_a_site_half_a_metre_from_the_wall_is_fine():
    d = doc()
    d["spatial"]["sites"]["T2"][0] = [10.0, 0.5]
    assert loads(d).sites[1][0] == (10.0, 0.5)


@pytest.mark.parametrize("start", [[0.25, 10.0], [1.5, 0.25], [19.75, 10.0], [1.5, 19.75]])
def test_robots_may_start_touching_a_wall(start):
    d = doc()
    d["robots"][0]["start"] = start
    assert parse_scenario(d).robots[0].start_xy == tuple(start)


@pytest.mark.parametrize("start", [[19.9, 10.0], [1.5, 19.9]])
def test_robots_starting_in_the_far_walls(start):
    d = doc()
    d["robots"][0]["start"] = start
    fails(d, "x.toml: robots[0].start:", "puts a robot of radius 0.25 m outside the arena")


def test_robots_0_6_m_apart_are_fine_and_the_first_overlap_is_named():
    d = doc()
    d["robots"][1]["start"] = [2.1, 10.0]
    assert parse_scenario(d).robots[1].start_xy == (2.1, 10.0)
    d = doc()
    d["robots"][5]["start"] = [1.5, 10.3]  # R6 on R1
    d["robots"][2]["start"] = [3.4, 10.3]  # R3 on R2
    fails(d, "x.toml: robots[5].start: overlaps robots[0] (R1): centres 0.3 m apart, need >= 0.5 m")


def test_the_file_s_numbers_and_drive_are_kept():
    d = doc()
    d["spatial"]["drive"]["radius_m"] = 0.3
    sp = loads(d)
    assert (sp.width_m, sp.height_m, sp.control_hz, sp.arrive_tol_m) == (20.0, 20.0, 10.0, 0.5)
    assert (sp.stuck_timeout_s, sp.max_recoveries) == (8.0, 3)
    assert sp.drive.radius_m == 0.3 and sp.drive.max_speed_mps == 1.5


@pytest.mark.parametrize(
    "changes",
    [
        {"dt_s": 0.05, "control_hz": 20.0},  # the coarsest step, control as fast as physics
        {"control_hz": 2.0},
        {"control_hz": 2.5},
        {"max_recoveries": 1000},
        {"collision_slop_m": 0.049},
    ],
)
def test_numbers_at_their_limits_are_accepted(changes):
    d = doc()
    d["spatial"].update(changes)
    sp = loads(d)
    assert all(getattr(sp, k) == v for k, v in changes.items())


def test_collision_slop_of_5_cm_is_refused():
    d = doc()
    d["spatial"]["collision_slop_m"] = 0.05
    fails(d, "x.toml: spatial.collision_slop_m: must be in [0, 0.05) m, got 0.05")


def test_warehouse_wide_differs_from_the_warehouse_only_in_its_cross_aisle():
    """The variant behind ``mrta sweep avoidance_wide``: every key the same as warehouse.toml
    except the name, the description and the shelf ends at the cross aisle (x 9.5 -> 9.2 and
    10.5 -> 10.8: a 1.6 m aisle where the warehouse has 1 m)."""
    narrow, wide = doc("warehouse"), doc("warehouse_wide")
    for key in ("name", "description"):
        assert narrow["scenario"].pop(key) != wide["scenario"].pop(key)
    moved = {9.5: 9.2, 10.5: 10.8}
    polys = narrow["spatial"].pop("obstacles")
    assert sum(x in moved for poly in polys for x, _ in poly) == 20  # 10 shelves, 2 corners each
    shelves = [[[moved.get(x, x), y] for x, y in poly] for poly in polys]
    assert shelves == wide["spatial"].pop("obstacles")
    assert narrow == wide


def test_warehouse_pickface_differs_from_the_warehouse_only_in_its_pick_and_restock_sites():
    """A variant in ``mrta sweep avoidance_layouts``: every key the same as
    warehouse.toml except the name, the description and the pick and restock sites, each moved
    from the middle of its 2 m aisle to 0.5 m from the face of the shelf row below the aisle."""
    mid, face = doc("warehouse"), doc("warehouse_pickface")
    for key in ("name", "description"):
        assert mid["scenario"].pop(key) != face["scenario"].pop(key)
    shelves = mid["spatial"]["obstacles"][:10]
    tops = {poly[2][1] for poly in shelves}  # the shelf rows' upper faces, y
    for kind in ("pick", "restock"):
        sites, moved = mid["spatial"]["sites"].pop(kind), face["spatial"]["sites"].pop(kind)
        assert len(sites) == len(moved) == 4
        for (x, y), (fx, fy) in zip(sites, moved, strict=True):
            assert fx == x and fy == y - 0.5
            assert y - 1.0 in tops and fy - (y - 1.0) == 0.5  # mid-aisle before, 0.5 m off the face
    assert mid == face


def test_warehouse_pickface_sites_leave_a_lane_beside_a_robot_at_work():
    """A passing robot's centre keeps ORCA's pair distance from a robot at work and its own
    radius plus ``MARGIN_M`` from a shelf: beside a robot at work in the middle of a 2 m aisle
    that leaves a band 0.1 m wide, beside one at a shelf face 0.6 m."""
    for name, band in (("warehouse", 0.1), ("warehouse_pickface", 0.6)):
        sp = load_scenario(name).spatial
        r_eff = sp.drive.radius_m + MARGIN_M
        shelves = [np.asarray(p) for p in sp.obstacles[:10]]
        for kind in (0, 1):  # pick, restock: in the aisles between the shelf rows
            for x, y in sp.sites[kind]:
                row = [p for p in shelves if p[:, 0].min() <= x <= p[:, 0].max()]
                above = min(p[:, 1].min() for p in row if p[:, 1].min() > y)
                below = max(p[:, 1].max() for p in row if p[:, 1].max() < y)
                assert above - below == 2.0  # a 2 m aisle
                free = (above - r_eff) - (y + 2.0 * r_eff)
                assert free == pytest.approx(band), (name, x, y)


SMALLEST = [
    ("law", "turn_in_place_deg"),  # steering divides by 1 - cos(angle)
    ("law", "react_periods"),  # ORCA divides by the reaction time
    ("orca", "tau_s"),  # ORCA divides by its time horizons
    ("orca", "tau_obstacle_s"),
]


@pytest.mark.parametrize(("table", "key"), SMALLEST)
def test_a_setting_the_law_divides_by_is_refused_below_0_01(table, key):
    """0, the smallest subnormal (5e-324: 1/x overflows; its cosine is 1) and just below
    0.01 are refused in one line naming the key; 0.01 is taken."""
    for tiny in (0, 5e-324, 1e-9, 0.0099):
        d = doc()
        d["spatial"].setdefault(table, {})[key] = tiny
        fails(d, f"spatial.{table}.{key}")
    d = doc()
    d["spatial"].setdefault(table, {})[key] = 0.01
    assert getattr(getattr(parse_scenario(d, source="x.toml").spatial, table), key) == 0.01


def test_the_smallest_turn_in_place_angle_gives_a_finite_steering_gain():
    from sim.spatial.controller import DiffDriveController

    d = doc()
    d["spatial"].setdefault("law", {})["turn_in_place_deg"] = 0.01
    sp = parse_scenario(d, source="x.toml").spatial
    gain = DiffDriveController(sp.drive, 0.1, law=sp.law).align_gain_
    assert np.isfinite(gain) and gain > 0.0
