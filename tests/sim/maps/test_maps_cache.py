"""The geometry cache: a round trip, a key per map and parameters, corrupt files rewritten."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import sim.maps.cache as cache
from sim.maps import cached_obstacles, default_cache_dir, load_map, map_obstacles

MAPS = Path(__file__).resolve().parents[3] / "scenarios" / "data" / "maps"


@pytest.fixture(scope="module")
def occ():
    return load_map(MAPS / "tb3_sandbox.yaml")


def same(a, b) -> bool:
    return (
        np.array_equal(a.corners, b.corners)
        and np.array_equal(a.starts, b.starts)
        and a.polygons == b.polygons
        and a.arena_polygons == b.arena_polygons
        and (a.specks_dropped, a.pockets_filled) == (b.specks_dropped, b.pockets_filled)
        and (a.speck_area_m2, a.pocket_area_m2) == (b.speck_area_m2, b.pocket_area_m2)
        and (a.tolerance_m, a.min_speck_m2, a.fill_detached)
        == (b.tolerance_m, b.min_speck_m2, b.fill_detached)
        and a.map_sha256 == b.map_sha256
    )


def test_the_cache_round_trips_without_recomputing(occ, tmp_path, monkeypatch):
    first = cached_obstacles(occ, cache_dir=tmp_path)
    files = list(tmp_path.iterdir())
    assert len(files) == 1 and files[0].suffix == ".npz"
    assert same(first, map_obstacles(occ))

    def boom(*args, **kwargs):
        raise AssertionError("recomputed although cached")

    monkeypatch.setattr(cache, "map_obstacles", boom)
    again = cached_obstacles(occ, cache_dir=tmp_path)
    assert same(again, first)
    with np.load(files[0], allow_pickle=False) as data:
        assert data["corners"].dtype == np.int64


def test_the_key_follows_the_map_and_every_parameter(occ, tmp_path):
    cached_obstacles(occ, cache_dir=tmp_path)
    cached_obstacles(occ, cache_dir=tmp_path, tolerance_m=0.1)
    cached_obstacles(occ, cache_dir=tmp_path, min_speck_m2=0.01)
    cached_obstacles(occ, cache_dir=tmp_path, min_pocket_m2=0.02)
    cached_obstacles(occ, cache_dir=tmp_path, fill_detached=True)
    cached_obstacles(occ, cache_dir=tmp_path, tolerance_m=0.05)  # the default again
    assert len(list(tmp_path.glob("*.npz"))) == 5


@pytest.mark.parametrize(
    "damage",
    ["garbage", "truncated", "empty", "other-key", "bad-shape"],
)
def test_a_corrupt_cache_file_is_ignored_and_rewritten(occ, tmp_path, monkeypatch, damage):
    good = cached_obstacles(occ, cache_dir=tmp_path)
    (path,) = tmp_path.glob("*.npz")
    blob = path.read_bytes()
    if damage == "garbage":
        path.write_bytes(b"PK\x03\x04 not a zip at all")
    elif damage == "truncated":
        path.write_bytes(blob[: len(blob) // 2])
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "other-key":
        with np.load(path, allow_pickle=False) as data:
            fields = {k: data[k] for k in data.files}
        fields["key"] = np.array("0" * 64)
        np.savez(path, **fields)
    else:
        with np.load(path, allow_pickle=False) as data:
            fields = {k: data[k] for k in data.files}
        fields["starts"] = fields["starts"][:-1]
        np.savez(path, **fields)
    again = cached_obstacles(occ, cache_dir=tmp_path)
    assert same(again, good)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left
    monkeypatch.setattr(cache, "map_obstacles", None)  # the file was written anew, whole
    assert same(cached_obstacles(occ, cache_dir=tmp_path), good)


def test_a_read_only_cache_costs_time_not_the_result(occ, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache folder would be")
    result = cached_obstacles(occ, cache_dir=blocker / "maps")
    assert same(result, map_obstacles(occ))


def test_the_default_cache_folder_is_under_the_home_folder():
    folder = default_cache_dir()
    assert folder.parts[-2:] == ("expt-mrta", "maps") or folder.parts[-3:] == (
        "expt-mrta",
        "Cache",
        "maps",
    )
    assert Path.home() in folder.parents
