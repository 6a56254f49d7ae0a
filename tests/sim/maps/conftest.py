"""Tiny hand-built maps written to tmp_path, and the two bundled maps."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

MAPS = Path(__file__).resolve().parents[3] / "scenarios" / "data" / "maps"

YAML = {
    "mode": "trinary",
    "resolution": "0.05",
    "origin": "[0.0, 0.0, 0]",
    "negate": "0",
    "occupied_thresh": "0.65",
    "free_thresh": "0.196",
}


def write(
    folder: Path,
    pixels: np.ndarray,
    *,
    name: str = "m",
    ext: str = "pgm",
    **keys: str | None,
) -> Path:
    """Write ``pixels`` (rows top first; (h, w) grey, (h, w, 2|3|4) with channels) as
    ``name.ext`` and a YAML file of the defaults above, overridden by ``keys`` (None: leave the
    key out); the YAML file's path."""
    img = Image.fromarray(np.asarray(pixels))
    img.save(folder / f"{name}.{ext}")
    entries = {"image": f"{name}.{ext}", **YAML, **keys}
    text = "".join(f"{k}: {v}\n" for k, v in entries.items() if v is not None)
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return path


@pytest.fixture()
def map_file(tmp_path):
    """``map_file(pixels, **keys)``: a map in tmp_path (see :func:`write`)."""

    def make(pixels: np.ndarray, **kwargs) -> Path:
        return write(tmp_path, pixels, **kwargs)

    return make


def grid(rows: list[str]) -> np.ndarray:
    """A grey image from text, top row first: '#' occupied (0), '.' free (254), '?' unknown
    (205)."""
    value = {"#": 0, ".": 254, "?": 205}
    return np.array([[value[c] for c in row] for row in rows], dtype=np.uint8)


@pytest.fixture()
def text_map(tmp_path):
    """``text_map(rows, **keys)``: a map drawn with :func:`grid`."""

    def make(rows: list[str], **kwargs) -> Path:
        return write(tmp_path, grid(rows), **kwargs)

    return make
