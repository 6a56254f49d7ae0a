"""What a run on a ROS map leaves behind: the spec keeps the map's path (not only its polygons),
the manifest records that path and the map's digest so a replay reads the same map from any
folder, and drawings show the map's cells as one grey image in the map's frame."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from scenarios.cli import main
from scenarios.loader import load_scenario
from sim.maps import FREE, OCCUPIED, UNKNOWN, load_map
from sim.recording import Trajectory, TrajectoryRecorder, map_grey
from sim.render import render_frame
from sim.render.scene import FrameScene

HERE = Path(__file__).parent
TB3 = HERE / "maps" / "tb3_sandbox.toml"
MAPS = Path(__file__).parents[2] / "scenarios" / "data" / "maps"
RELATIVE = 'map = "../../../scenarios/data/maps/tb3_sandbox.yaml"'


def own_copy(folder: Path) -> Path:
    """tb3_sandbox.toml and its map copied into ``folder``, the map named relative to it."""
    (folder / "floor").mkdir(parents=True)
    for suffix in (".yaml", ".pgm"):
        shutil.copyfile(MAPS / f"tb3_sandbox{suffix}", folder / "floor" / f"tb3_sandbox{suffix}")
    text = TB3.read_text()
    assert RELATIVE in text
    path = folder / "tb3.toml"
    path.write_text(text.replace(RELATIVE, 'map = "floor/tb3_sandbox.yaml"'))
    return path


def test_the_spec_keeps_the_resolved_map_path_and_scenarios_without_one_keep_none():
    sc = load_scenario(TB3)
    assert sc.spatial.map == str((MAPS / "tb3_sandbox.yaml").resolve())
    assert load_scenario("paper_spatial").spatial.map == ""


def test_a_recorded_run_draws_the_map_cells_in_the_map_frame():
    """The recorder keeps the map's cells as map_saver's greys (free 254, occupied 0, unknown
    205), its origin, and which obstacles are the map's (drawn as cells, not polygons)."""
    sc = load_scenario(TB3)
    rec = TrajectoryRecorder.for_scenario(sc)
    occ = load_map(MAPS / "tb3_sandbox.yaml")
    assert rec.map_grey.shape == (384, 384) and rec.map_origin_xy.tolist() == [-10.0, -10.0]
    assert int(rec.map_polygons) == len(sc.spatial.obstacles) == 57
    counts = {g: int((rec.map_grey == g).sum()) for g in (254, 0, 205)}
    assert counts[254] == int((occ.cells == FREE).sum())
    assert counts[0] == int((occ.cells == OCCUPIED).sum())
    assert counts[205] == int((occ.cells == UNKNOWN).sum()) and sum(counts.values()) == 384 * 384
    cells = np.array([[FREE, OCCUPIED], [UNKNOWN, FREE]], dtype=np.int8)
    assert map_grey(cells).tolist() == [[254, 0], [205, 254]]


def test_a_frame_on_a_map_shows_unknown_cells_grey_and_the_floor_light(tmp_path):
    """One frame of a short recording: pixels over the sea of unknown cells are map_saver's
    grey, pixels on the free floor near the middle are light; the file round-trips."""
    sc = load_scenario(TB3)
    rec = TrajectoryRecorder.for_scenario(sc)
    rec.poses(0.0, np.array([r.start_xy for r in sc.robots]), np.zeros(4), np.zeros(4))
    traj = rec.finish()
    traj.save(tmp_path / "t.npz")
    again = Trajectory.load(tmp_path / "t.npz")
    assert np.array_equal(again.map_grey, traj.map_grey) and int(again.map_polygons) == 57
    img = render_frame(again, 0.0, size=(400, 400))
    grey = img[..., 0].astype(int)
    assert (np.abs(grey - img[..., 2]) < 3).mean() > 0.9  # mostly grey
    assert (np.abs(grey - 205) <= 2).mean() > 0.3  # unknown cells fill most of the arena
    scene = FrameScene(again, size=(400, 400))
    occ = load_map(MAPS / "tb3_sandbox.yaml")
    far = distance_transform_edt(occ.free) * occ.resolution_m  # m to the nearest blocked cell
    j, i = np.unravel_index(np.argmax(far), far.shape)  # the freest cell: floor, no pillar
    world = occ.cell_centres(np.array([j]), np.array([i]))[0] - occ.origin_xy
    assert far[j, i] > 0.4 and np.min(np.hypot(*(again.positions[0] - world).T)) > 0.3
    x, y = scene.ax.transData.transform(world)
    assert grey[round(400 - y), round(x)] == 254  # map_saver's free grey, not a polygon's
    for v, label in zip(scene.ax.get_xticks(), scene.ax.get_xticklabels(), strict=True):
        assert float(label.get_text().replace("\u2212", "-")) == pytest.approx(v - 10.0)


@pytest.mark.slow
def test_a_run_on_a_map_replays_from_its_manifest_and_refuses_a_changed_map(tmp_path, capsys):
    """The stored scenario names its map relative to its own folder; the replay runs in a
    scratch folder, so it reads the map by the path and digest the manifest recorded."""
    scenario = own_copy(tmp_path / "mine")
    out = tmp_path / "run"
    args = ["run", str(scenario), "--allocator", "market", "--cost", "distance", "--out", str(out)]
    assert main([*args, "--no-progress"]) == 0
    manifest = json.loads((out / "run_manifest.json").read_text())
    recorded = manifest["scenario"]["map"]
    assert recorded["path"] == str((tmp_path / "mine" / "floor" / "tb3_sandbox.yaml").resolve())
    assert recorded["sha256"] == load_map(MAPS / "tb3_sandbox.yaml").sha256
    assert "floor/tb3_sandbox.yaml" in manifest["scenario"]["toml"]  # the file as written
    again = tmp_path / "again"
    replay = ["run", "--replay", str(out / "run_manifest.json"), "--no-progress"]
    assert main([*replay, "--out", str(again)]) == 0
    assert (again / "metrics.json").read_bytes() == (out / "metrics.json").read_bytes()
    capsys.readouterr()
    yaml = tmp_path / "mine" / "floor" / "tb3_sandbox.yaml"
    yaml.write_text(yaml.read_text().replace("free_thresh: 0.196", "free_thresh: 0.19"))
    assert main([*replay, "--out", str(tmp_path / "third")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "scenario.map" in err and "has changed since the run" in err
    assert not (tmp_path / "third").exists()


@pytest.mark.parametrize("name", ["depot", "tb3_sandbox"])
def test_bundled_maps_keep_map_savers_greys(name):
    """The bundled images are map_saver output: only its three levels occur."""
    occ = load_map(MAPS / f"{name}.yaml")
    assert set(np.unique(map_grey(occ.cells)).tolist()) <= {0, 205, 254}
