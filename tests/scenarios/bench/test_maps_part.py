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
    assert len(lines) == 4 and f"{out['polygons']} polygons" in lines[1]
    bids = out["depot_bids"]
    assert set(bids) == {"planner_s", "known_ms", "new_ms", "known_ref_ms", "new_ref_ms"}
    assert f"{bids['known_ms']:.1f} ms (numpy {bids['known_ref_ms']:.1f} ms)" in lines[3]
