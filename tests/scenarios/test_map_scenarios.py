"""ROS maps as arenas (``[spatial] map``): the frame, the checks, and runs on both bundled maps."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from scenarios.experiments.protocol import RunSpec, execute
from scenarios.loader import load_scenario, map_arena
from sim.maps import load_map
from sim.scenario import ScenarioError, SpatialSpec

HERE = Path(__file__).parent
TB3 = HERE / "maps" / "tb3_sandbox.toml"
MAPS = Path(__file__).parents[2] / "scenarios" / "data" / "maps"
SHORT = (("stream.n_sets", 4), ("stream.learn_sets", 2), ("stream.test_sets", 2))


def variant(tmp_path: Path, old: str, new: str) -> Path:
    """tb3_sandbox.toml with one text replaced, the map named by its absolute path."""
    text = TB3.read_text().replace(
        'map = "../../../scenarios/data/maps/tb3_sandbox.yaml"',
        f'map = "{(MAPS / "tb3_sandbox.yaml").as_posix()}"',
    )
    assert old in text
    path = tmp_path / "variant.toml"
    path.write_text(text.replace(old, new, 1))
    return path


def test_points_of_the_file_are_in_the_map_frame_and_the_arena_is_the_map():
    """tb3_sandbox's origin is (-10, -10) m: the world's frame starts at the map's lower-left
    corner, so every point of the file moves by +10 m in x and y."""
    sc = load_scenario(TB3)
    occ = load_map(MAPS / "tb3_sandbox.yaml")
    assert occ.origin_xy == (-10.0, -10.0)
    sp = sc.spatial
    assert (sp.width_m, sp.height_m) == (occ.width_m, occ.height_m)
    assert (sp.width_m, sp.height_m) == pytest.approx((19.2, 19.2))  # 384 cells of 5 cm
    assert sc.robots[0].start_xy == pytest.approx((10.68, 9.52))
    assert sc.robots[3].start_xy == pytest.approx((11.08, 8.33))
    assert sp.sites[0][0] == pytest.approx((9.43, 11.87))
    arena = map_arena(MAPS / "tb3_sandbox.yaml")
    assert sp.obstacles == arena.polygons and len(arena.polygons) == 57
    inside = np.concatenate([np.asarray(p) for p in sp.obstacles])
    assert inside.min() >= 0.0 and inside.max() <= sp.width_m


def test_the_depot_scenario_keeps_its_own_points_where_the_map_puts_them():
    sc = load_scenario("depot")
    occ = load_map(MAPS / "depot.yaml")
    assert (sc.spatial.width_m, sc.spatial.height_m) == (occ.width_m, occ.height_m)
    assert (occ.width_m, occ.height_m) == pytest.approx((30.2, 15.35))  # 604 x 307 cells
    assert sc.robots[0].start_xy == (23.67, 1.78)  # origin (0, 0): nothing moves
    assert len(sc.spatial.obstacles) == len(map_arena(MAPS / "depot.yaml").polygons)


def test_a_scenario_built_in_python_on_a_map_is_the_file_s():
    """``SpatialSpec.on_map`` takes points in the map's frame, as the file does, and gives the
    same spec; starts move with ``to_world``; a spec naming a map keeps that map's arena."""
    sc = load_scenario(TB3)
    yaml = MAPS / "tb3_sandbox.yaml"
    sites = [[(-0.57, 1.87), (-1.18, 1.63)], [(-1.58, -0.72), (-1.78, 0.08)]]
    sites += [[(-0.42, -1.17), (0.47, 0.19)]]
    built = SpatialSpec.on_map(
        yaml,
        sites=sites,
        control_hz=10.0,
        arrive_tol_m=0.15,
        clearance_m=0.05,
        drive=sc.spatial.drive,
    )
    assert built == sc.spatial
    arena = map_arena(yaml)
    starts = [(0.68, -0.48), (1.63, -0.33), (-1.03, 0.49), (1.08, -1.67)]
    assert [arena.to_world(p) for p in starts] == [r.start_xy for r in sc.robots]
    box = [[(0.5, -0.6), (0.9, -0.6), (0.9, -0.3), (0.5, -0.3)]]
    own = SpatialSpec.on_map(yaml, sites=sites, obstacles=box)
    assert (
        own.obstacles[0][0] == pytest.approx((10.5, 9.4))
        and own.obstacles[1:] == sc.spatial.obstacles
    )
    assert dataclasses.replace(sc.spatial, clearance_m=0.2).obstacles == sc.spatial.obstacles


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "control_hz = 10.0",
            "width_m = 5.0\ncontrol_hz = 10.0",
            "spatial.width_m: not allowed beside spatial.map: the map sets the arena",
        ),
        ('map = "', 'map = "missing/', r"spatial\.map: .*missing"),
        (
            "start = [0.68, -0.48]",
            "start = [-5.0, 0.0]",
            r"robots\[0\]\.start: \(-5, 0\) .* an occupied or unknown cell of spatial\.map",
        ),
        (
            "T1 = [[-0.57, 1.87]",
            "T1 = [[0.0, 4.0]",
            r"spatial\.sites\.T1\[0\]: \(0, 4\) is inside an occupied or unknown cell of "
            r"spatial\.map",
        ),
        ('map = "', "map = 3\n# ", "spatial.map: must be a file name, got number 3"),
        (  # an obstacle of the file's own, in the map's frame, round robot R1's start
            "control_hz = 10.0",
            "obstacles = [[[0.5, -0.6], [0.9, -0.6], [0.9, -0.3], [0.5, -0.3]]]\ncontrol_hz = 10.0",
            r"robots\[0\]\.start: \(0\.68, -0\.48\) overlaps or is inside "
            r"spatial\.obstacles\[0\]",
        ),
    ],
)
def test_bad_map_layouts_are_one_line_naming_the_key(tmp_path, old, new, message):
    with pytest.raises(ScenarioError, match=message) as err:
        load_scenario(variant(tmp_path, old, new))
    assert "\n" not in str(err.value) and str(err.value).startswith(str(tmp_path))


@pytest.mark.parametrize(
    ("allocator", "cost"),
    [("market", "distance"), ("ql", "distance"), ("expt", "distance"), ("expt", "time")],
)
def test_robots_drive_to_their_tasks_on_the_tb3_map(allocator, cost):
    out = execute(RunSpec(str(TB3), allocator, cost, 0))
    assert out["spec"]["cost"] == cost
    sp = out["spatial"]
    assert out["tasks"]["allocated"] >= 15 and sp["failed_tasks"] == 0
    assert 0.3 < sp["distance_per_task_m"] < 4.0  # the arena is about 4 m across
    assert sp["contacts_robot_touch_per_robot_h"] + sp["contacts_robot_impact_per_robot_h"] <= 1.0


@pytest.mark.slow
@pytest.mark.parametrize("allocator", ["market", "ql", "expt"])
def test_the_paper_robots_work_the_depot_map(allocator):
    out = execute(RunSpec("depot", allocator, "distance", 0, SHORT))
    sp = out["spatial"]
    assert out["tasks"]["allocated"] >= 80 and sp["failed_tasks"] == 0
    assert sp["contacts_robot_touch_per_robot_h"] + sp["contacts_robot_impact_per_robot_h"] <= 1.0
    assert sp["contacts_wall_impact_per_robot_h"] == 0.0


@pytest.mark.slow
def test_the_traffic_rules_find_passages_on_a_map_and_grant_them():
    """The traffic layer works on a map's geometry, not only on hand-typed rectangles."""
    over = (("stream.n_sets", 2), ("stream.learn_sets", 1), ("stream.test_sets", 1))
    over += (("spatial.traffic.rules", "on"),)
    out = execute(RunSpec("depot", "market", "distance", 0, over))
    sp = out["spatial"]
    assert sp["traffic_passages"] > 0 and sp["traffic_grants"] > 0
    assert sp["failed_tasks"] == 0 and out["tasks"]["allocated"] >= 40
