"""Every way a map file can be wrong gives one MapError line: '<file>: <key>: <problem>'."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from sim.maps import MapError, load_map

GOOD = np.array([[0, 254, 254], [254, 254, 205]], dtype=np.uint8)


def _yaml(path, text: str) -> None:
    path.write_text(text)


# (id, changes to the YAML keys (None drops one), extra YAML lines, key, words in the problem)
CASES = [
    ("yaw", {"origin": "[0.0, 0.0, 0.5]"}, "", "origin", "yaw must be 0 (got 0.5)"),
    ("no-image", {"image": "x.pgm"}, "", "image", "no such file 'x.pgm'"),
    ("empty-image", {"image": "''"}, "", "image", "must be a non-empty string"),
    ("unknown-key", {}, "resolutoin: 0.05\n", "resolutoin", "did you mean 'resolution'?"),
    ("unknown-key-far", {}, "colour: red\n", "colour", "unknown key"),
    ("missing", {"negate": None}, "", "negate", "missing"),
    ("resolution-type", {"resolution": "fine"}, "", "resolution", "must be a number, got 'fine'"),
    ("resolution-zero", {"resolution": "0"}, "", "resolution", "must be > 0"),
    ("resolution-negative", {"resolution": "-0.05"}, "", "resolution", "must be > 0"),
    ("resolution-inf", {"resolution": ".inf"}, "", "resolution", "must be a finite number"),
    ("resolution-nan", {"resolution": ".nan"}, "", "resolution", "must be a finite number"),
    ("resolution-list", {"resolution": "[0.05]"}, "", "resolution", "must be a number"),
    ("origin-scalar", {"origin": "0"}, "", "origin", "must be a list [x, y, yaw]"),
    ("origin-short", {"origin": "[0, 0]"}, "", "origin", "got 2 values"),
    ("origin-text", {"origin": "[0, a, 0]"}, "", "origin", "must be a number, got 'a'"),
    ("occupied-high", {"occupied_thresh": "1.5"}, "", "occupied_thresh", "in [0, 1], got 1.5"),
    ("free-negative", {"free_thresh": "-0.1"}, "", "free_thresh", "in [0, 1], got -0.1"),
    ("free-above", {"free_thresh": "0.7"}, "", "free_thresh", "below occupied_thresh (0.65)"),
    ("free-equal", {"free_thresh": "0.65"}, "", "free_thresh", "below occupied_thresh"),
    ("free-text", {"free_thresh": "low"}, "", "free_thresh", "must be a number, got 'low'"),
    ("negate", {"negate": "2"}, "", "negate", "must be 0, 1, true or false, got '2'"),
    ("mode", {"mode": "trinery"}, "", "mode", "did you mean 'trinary'?"),
    ("twice", {}, "negate: 1\n", "negate", "given twice (lines 5 and 8)"),
    ("syntax", {}, "resolution 0.05\n", "line 8", "expected 'key: value'"),
    ("nested", {}, "extra:\n  inner: 1\n", "line 9", "unexpected indentation"),
    ("flow-map", {"origin": "{x: 0}"}, "", "line 4", "unsupported YAML"),
    ("stray-item", {}, "- 3\n", "line 8", "a list item outside a list"),
]


@pytest.mark.parametrize(
    ("changes", "extra", "key", "words"),
    [c[1:] for c in CASES],
    ids=[c[0] for c in CASES],
)
def test_a_bad_yaml_value_names_file_and_key_on_one_line(map_file, changes, extra, key, words):
    path = map_file(GOOD)
    text = path.read_text()
    lines = dict(line.split(": ", 1) for line in text.splitlines())
    for k, v in changes.items():
        lines[k] = v
    _yaml(path, "".join(f"{k}: {v}\n" for k, v in lines.items() if v is not None) + extra)
    with pytest.raises(MapError) as info:
        load_map(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {key}: "), message
    assert words in message, message
    assert isinstance(info.value, ValueError) and info.value.key == key


def test_an_unreadable_image(map_file):
    path = map_file(GOOD)
    (path.parent / "m.pgm").write_bytes(b"P5\n3 2\n255\nshort")
    with pytest.raises(MapError, match=r"m\.yaml: image: cannot read 'm\.pgm' as an image"):
        load_map(path)
    (path.parent / "m.pgm").write_bytes(b"not an image at all")
    with pytest.raises(MapError, match=r"image: cannot read 'm\.pgm' as an image") as info:
        load_map(path)
    assert "\n" not in str(info.value)


def test_a_map_with_no_free_cell(map_file):
    path = map_file(np.full((3, 3), 205, dtype=np.uint8))
    with pytest.raises(MapError, match=r"m\.yaml: image: no free cell in 'm\.pgm'"):
        load_map(path)


def test_an_image_too_large(map_file):
    path = map_file(GOOD)
    with pytest.raises(MapError, match=r"image: 'm\.pgm' is 3 x 2 pixels, more than the 5 cells"):
        load_map(path, max_cells=5)


def test_a_missing_or_binary_yaml_file(tmp_path):
    with pytest.raises(MapError, match=r"nothere\.yaml: yaml: cannot read the file"):
        load_map(tmp_path / "nothere.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_bytes(b"\xff\xfe\x00image")
    with pytest.raises(MapError, match=r"bad\.yaml: yaml: not a UTF-8 text file"):
        load_map(bad)


def test_the_image_path_is_relative_to_the_yaml_file_or_absolute(tmp_path, map_file):
    path = map_file(GOOD)
    sub = tmp_path / "maps"
    sub.mkdir()
    moved = sub / "m.yaml"
    moved.write_text(path.read_text())
    with pytest.raises(MapError, match=r"image: no such file 'm\.pgm'"):
        load_map(moved)
    Image.fromarray(GOOD).save(sub / "m.pgm")
    assert load_map(moved).shape == (2, 3)
    absolute = path.read_text().replace("image: m.pgm", f"image: {tmp_path / 'm.pgm'}")
    moved.write_text(absolute)
    assert load_map(moved).meta.image == tmp_path / "m.pgm"
