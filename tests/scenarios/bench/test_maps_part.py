"""mrta bench's maps part: the 30 m x 50 m map at 3 cm it prepares, and what it reports."""

from __future__ import annotations

import pytest

from scenarios.bench.run import bench_maps_part


def test_the_maps_part_prepares_the_large_map_and_plans_over_it():
    lines = []
    out = bench_maps_part(lines.append)
    assert out["cells"] == 1000 * 1667  # 30 m / 3 cm columns, 50 m / 3 cm rows (rounded up)
    assert out["polygons"] > 100 and out["vertices"] >= 3 * out["polygons"]
    assert out["specks_dropped"] > 0  # the synthetic map's noise
    assert out["prepare_s"] == pytest.approx(out["load_s"] + out["geometry_s"])
    assert out["planner_s"] > 0 and "geometry" not in out
    assert len(lines) == 2 and f"{out['polygons']} polygons" in lines[1]
