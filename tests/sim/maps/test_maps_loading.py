"""Reading map_server maps: the pixel rules of navigation2's map_io, row order, origin, the
bundled maps' exact cell counts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sim.maps import FREE, OCCUPIED, UNKNOWN, load_map

MAPS = Path(__file__).resolve().parents[3] / "scenarios" / "data" / "maps"


def nav2_trinary(values: np.ndarray, occupied: float, free: float, negate: bool) -> np.ndarray:
    """map_io's trinary rule written out: shade v / 255, occupancy 1 - shade (or the shade)."""
    shade = values / 255.0
    occ = shade if negate else 1.0 - shade
    return np.where(occupied < occ, OCCUPIED, np.where(occ < free, FREE, UNKNOWN))


@pytest.mark.parametrize(
    ("occupied", "free", "negate"),
    [(0.65, 0.196, False), (0.65, 0.25, False), (0.65, 0.196, True), (0.8, 0.2, False)],
)
def test_every_grey_level_is_classified_as_map_io_does(map_file, occupied, free, negate):
    values = np.arange(256, dtype=np.uint8).reshape(16, 16)
    path = map_file(
        values, occupied_thresh=repr(occupied), free_thresh=repr(free), negate=str(int(negate))
    )
    occ = load_map(path)
    expected = np.flipud(nav2_trinary(values.astype(float), occupied, free, negate))
    assert np.array_equal(occ.cells, expected)
    assert np.array_equal(occ.values, expected)


def test_thresholds_at_their_edges_resolve_as_in_ros(map_file):
    """204 has occupancy 1 - 204/255 = 0.2 in exact arithmetic; map_io computes 1 - 0.8 in
    doubles, 0.19999999999999996, which is below a free_thresh of 0.2: free. 51 gives 0.8,
    not above an occupied_thresh of 0.8: unknown. A strict threshold of 1 occupies nothing."""
    values = np.array([[204, 51, 0, 255]], dtype=np.uint8)
    occ = load_map(map_file(values, occupied_thresh="0.8", free_thresh="0.2"))
    assert occ.cells[0].tolist() == [FREE, UNKNOWN, OCCUPIED, FREE]
    occ = load_map(map_file(values, occupied_thresh="1.0", free_thresh="0.0001"))
    assert occ.cells[0].tolist() == [UNKNOWN, UNKNOWN, UNKNOWN, FREE]


def test_row_zero_of_the_image_is_the_top_and_origin_places_the_grid(text_map):
    path = text_map(["#...", "....", "...?"], origin="[-1.5, 2.0, 0.0]", resolution="0.5")
    occ = load_map(path)
    assert occ.shape == (3, 4) and occ.width_m == 2.0 and occ.height_m == 1.5
    assert occ.origin_xy == (-1.5, 2.0) and occ.resolution_m == 0.5
    assert occ.cells[2, 0] == OCCUPIED and occ.cells[0, 3] == UNKNOWN
    j, i, inside = occ.cell_of(np.array([[-1.25, 3.25], [0.25, 2.25], [-1.6, 2.1]]))
    assert (j[:2].tolist(), i[:2].tolist(), inside.tolist()) == (
        [2, 0],
        [0, 3],
        [True, True, False],
    )
    assert occ.cell_centres(np.array([2]), np.array([0])).tolist() == [[-1.25, 3.25]]
    assert not occ.cells.flags.writeable


def test_an_alpha_channel_is_averaged_in_trinary_mode(map_file):
    """map_io averages the opacity with red, green and blue in trinary mode: white and fully
    transparent has shade 3/4, occupancy 1/4 (not below 0.25: unknown; below 0.3: free); black and
    transparent has occupancy 1 (occupied)."""
    rgba = np.array([[[255, 255, 255, 0], [0, 0, 0, 0], [255, 255, 255, 255]]], dtype=np.uint8)
    occ = load_map(map_file(rgba, ext="png", free_thresh="0.25"))
    assert occ.cells[0].tolist() == [UNKNOWN, OCCUPIED, FREE]
    occ = load_map(map_file(rgba, ext="png", free_thresh="0.3"))
    assert occ.cells[0].tolist() == [FREE, OCCUPIED, FREE]
    la = np.array([[[254, 0], [254, 255]]], dtype=np.uint8)  # grey + alpha
    occ = load_map(map_file(la, ext="png", free_thresh="0.25"))
    assert occ.cells[0].tolist() == [UNKNOWN, FREE]


def test_rgb_pixels_use_the_mean_of_their_channels(map_file):
    rgb = np.array([[[255, 255, 0], [254, 254, 254], [0, 30, 0]]], dtype=np.uint8)
    occ = load_map(map_file(rgb, ext="png"))
    assert occ.cells[0].tolist() == [UNKNOWN, FREE, OCCUPIED]  # 1/3 occupancy, 0, 0.96


def test_scale_mode_keeps_map_servers_values_and_translucent_pixels_are_unknown(map_file):
    la = np.array([[[0, 255], [254, 255], [178, 255], [254, 128]]], dtype=np.uint8)
    occ = load_map(map_file(la, ext="png", mode="scale", free_thresh="0.25"))
    between = np.rint((1 - 178 / 255 - 0.25) / (0.65 - 0.25) * 100)
    assert occ.values[0].tolist() == [100, 0, int(between), -1]
    assert occ.cells[0].tolist() == [OCCUPIED, FREE, UNKNOWN, UNKNOWN]


def test_raw_mode_reads_values_as_percent_and_ignores_negate(map_file):
    values = np.array([[0, 20, 50, 100, 101, 255]], dtype=np.uint8)
    for negate in ("0", "1"):
        occ = load_map(map_file(values, mode="raw", free_thresh="0.25", negate=negate))
        assert occ.values[0].tolist() == [0, 20, 50, 100, -1, -1]
        assert occ.cells[0].tolist() == [FREE, FREE, UNKNOWN, OCCUPIED, UNKNOWN, UNKNOWN]


def test_sixteen_bit_images_scale_to_the_same_shades(map_file):
    values = np.array([[0, 65535, 257 * 205]], dtype=np.uint16)
    occ = load_map(map_file(values, ext="png"))
    assert occ.cells[0].tolist() == [OCCUPIED, FREE, UNKNOWN]


def test_yaml_variants_map_server_accepts(text_map):
    path = text_map(["#.."], negate="false", mode="Trinary", origin=None)
    text = path.read_text() + "origin:\n  - 1.0\n  - 2\n  - 0.0  # no yaw\n"
    path.write_text("---\n# a comment\n" + text.replace("resolution: 0.05", "resolution: '5e-2'"))
    occ = load_map(path)
    assert occ.origin_xy == (1.0, 2.0) and occ.resolution_m == 0.05
    assert occ.meta.mode == "trinary" and not occ.meta.negate


def read_pgm(path) -> np.ndarray:
    """A binary (P5) 8-bit PGM parsed with numpy alone: magic, width, height, maxval, pixels."""
    data = path.read_bytes()
    fields, pos = [], 0
    while len(fields) < 4:
        while data[pos : pos + 1].isspace():
            pos += 1
        if data[pos : pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end : end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    assert fields[0] == b"P5" and int(fields[3]) == 255
    w, h = int(fields[1]), int(fields[2])
    return np.frombuffer(data[pos + 1 : pos + 1 + w * h], dtype=np.uint8).reshape(h, w)


@pytest.mark.parametrize(
    ("name", "shape", "origin", "counts"),
    [
        ("depot", (307, 604), (0.0, 0.0), (179481, 5947, 0)),
        ("tb3_sandbox", (384, 384), (-10.0, -10.0), (7903, 870, 138683)),
    ],
)
def test_bundled_maps_load_with_their_exact_cell_counts(name, shape, origin, counts):
    occ = load_map(MAPS / f"{name}.yaml")
    assert occ.shape == shape and occ.resolution_m == 0.05 and occ.origin_xy == origin
    assert occ.width_m == pytest.approx(shape[1] * 0.05) and occ.meta.mode == "trinary"
    found = (int(occ.free.sum()), int(occ.occupied.sum()), int(occ.unknown.sum()))
    assert found == counts
    # the same counts straight from the PGM bytes: 254 is free under both maps' thresholds;
    # depot's free_thresh 0.25 makes its 205-grey (occupancy 0.196) free as well, tb3_sandbox's
    # 0.196 keeps it unknown
    pixels = read_pgm(MAPS / f"{name}.pgm")
    free_thresh = {"depot": 0.25, "tb3_sandbox": 0.196}[name]
    occ_level = 1.0 - pixels / 255.0
    independent = (
        int((occ_level < free_thresh).sum()),
        int((occ_level > 0.65).sum()),
        int(((occ_level >= free_thresh) & (occ_level <= 0.65)).sum()),
    )
    assert independent == counts
    assert np.array_equal(np.flipud(pixels == 0), occ.occupied)
    assert len(occ.sha256) == 64
