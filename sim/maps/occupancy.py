"""A ROS map_server map read into an occupancy grid: free, occupied and unknown cells.

The image's pixels become cells exactly as navigation2's ``map_io`` (``loadMapFromFile``) turns
them into an ``OccupancyGrid``:

- a pixel's *shade* is the mean of its red, green and blue (in ``trinary`` mode an alpha
  channel, as opacity, is averaged in too), on 0..1; its *occupancy* is ``1 - shade``, or the
  shade itself if ``negate`` is set. The arithmetic is map_io's (16-bit quanta, so an 8-bit value
  v has shade v / 255 rounded once), so a pixel exactly at a threshold lands where it does in ROS;
- ``trinary``: occupied if occupancy > ``occupied_thresh``, free if < ``free_thresh``, else
  unknown;
- ``scale``: a pixel that is not fully opaque is unknown; otherwise as trinary, and map_server's
  value for a cell between the thresholds is ``rint(100 (occ - free) / (occupied - free))``;
- ``raw``: the value is ``round(255 shade)`` (``negate`` is ignored, as in map_io); 0..100 is the
  occupancy in percent, anything above is unknown. To say which cells a robot may drive on, a
  raw value v is read as occupancy v / 100 against the two thresholds, like the other modes.

Row 0 of the image is the *top* of the map; the grids here have row 0 at the bottom (the map
frame's y points up), so cell ``[j, i]`` covers ``x in origin_x + [i, i + 1] * resolution`` and
``y in origin_y + [j, j + 1] * resolution``, as in ROS. Only free cells are drivable: occupied
and unknown cells both block.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from sim.maps.errors import MapError
from sim.maps.mapyaml import MapMeta, read_meta

FREE, OCCUPIED, UNKNOWN = 0, 100, -1  # cell codes: those of a ROS OccupancyGrid
_QUANTUM = 65535.0  # map_io reads pixels as 16-bit quanta (GraphicsMagick Q16)


@dataclass(frozen=True, slots=True, eq=False)
class OccupancyMap:
    """A map's grid and where it lies in the map frame (read-only arrays, row 0 at the bottom).

    ``cells`` holds FREE / OCCUPIED / UNKNOWN; ``values`` the ``OccupancyGrid`` data map_server
    would publish (-1 unknown, 0..100 occupancy in percent; the same as ``cells`` in trinary
    mode). ``sha256`` digests the YAML bytes followed by the image bytes.
    """

    cells: np.ndarray  # (ny, nx) int8
    values: np.ndarray  # (ny, nx) int8
    resolution_m: float
    origin_xy: tuple[float, float]  # m: the outer corner of cell [0, 0]
    meta: MapMeta
    source: str  # the YAML file, as the caller named it
    sha256: str

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx): rows (along y) and columns (along x)."""
        return self.cells.shape

    @property
    def width_m(self) -> float:
        return self.cells.shape[1] * self.resolution_m

    @property
    def height_m(self) -> float:
        return self.cells.shape[0] * self.resolution_m

    @property
    def free(self) -> np.ndarray:
        """(ny, nx) True on drivable cells."""
        return self.cells == FREE

    @property
    def occupied(self) -> np.ndarray:
        return self.cells == OCCUPIED

    @property
    def unknown(self) -> np.ndarray:
        return self.cells == UNKNOWN

    @property
    def blocked(self) -> np.ndarray:
        """(ny, nx) True where a robot may not be: occupied or unknown."""
        return self.cells != FREE

    def cell_of(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Row j, column i of the cell holding each point (n, 2) m, and whether it is on the map."""
        pts = np.asarray(xy, dtype=float).reshape(-1, 2)
        rel = (pts - np.asarray(self.origin_xy)) / self.resolution_m
        i, j = np.floor(rel[:, 0]).astype(np.int64), np.floor(rel[:, 1]).astype(np.int64)
        ny, nx = self.shape
        inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        return np.clip(j, 0, ny - 1), np.clip(i, 0, nx - 1), inside

    def cell_centres(self, j: np.ndarray, i: np.ndarray) -> np.ndarray:
        """(n, 2) m: the centres of cells [j, i]."""
        ox, oy = self.origin_xy
        res = self.resolution_m
        return np.column_stack([ox + (np.asarray(i) + 0.5) * res, oy + (np.asarray(j) + 0.5) * res])


def load_map(path: str | Path, *, max_cells: int = 25_000_000) -> OccupancyMap:
    """Read a ROS map_server map (its YAML file and the image it names).

    Args:
        path: the map's YAML file.
        max_cells: refuse larger images (memory and preparation time grow with the cells).

    Raises:
        MapError: one line naming the file, the key and the problem (a missing or unreadable
            file, a bad key or value, an image too large, a map with no free cell).
    """
    source = str(path)
    path = Path(path)
    try:
        yaml_bytes = path.read_bytes()
    except OSError as exc:
        raise MapError(source, "yaml", f"cannot read the file ({exc.strerror or exc})") from None
    try:
        text = yaml_bytes.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise MapError(source, "yaml", "not a UTF-8 text file") from None
    meta = read_meta(path, text, source)
    if not meta.image.is_file():
        raise MapError(source, "image", f"no such file {meta.image_name!r}")
    try:
        image_bytes = meta.image.read_bytes()
    except OSError as exc:
        raise MapError(source, "image", f"cannot read {meta.image_name!r} ({exc})") from None
    shade, alpha = _decode(image_bytes, meta, source, max_cells)
    values, cells = classify(shade, alpha, meta)
    if not (cells == FREE).any():
        raise MapError(
            source,
            "image",
            f"no free cell in {meta.image_name!r} (mode {meta.mode}, negate {int(meta.negate)}, "
            f"free_thresh {meta.free_thresh:g}): nowhere to drive",
        )
    digest = hashlib.sha256(yaml_bytes)
    digest.update(image_bytes)
    cells, values = np.flipud(cells).copy(), np.flipud(values).copy()
    cells.flags.writeable = False
    values.flags.writeable = False
    return OccupancyMap(
        cells=cells,
        values=values,
        resolution_m=meta.resolution_m,
        origin_xy=meta.origin_xy,
        meta=meta,
        source=source,
        sha256=digest.hexdigest(),
    )


def classify(
    shade: np.ndarray, alpha: np.ndarray | None, meta: MapMeta
) -> tuple[np.ndarray, np.ndarray]:
    """map_server's values and the cell codes of an image (rows as in the image).

    Args:
        shade: (rows, cols) brightness 0..1 (alpha averaged in already in trinary mode).
        alpha: (rows, cols) opacity 0..1, or None for an image without an alpha channel.
        meta: the mode, negate and thresholds.

    Returns:
        (values, cells), both int8: ``values`` as in a ROS ``OccupancyGrid``, ``cells`` FREE,
        OCCUPIED or UNKNOWN.
    """
    occ_t, free_t = meta.occupied_thresh, meta.free_thresh
    if meta.mode == "raw":
        percent = np.floor(shade * 255.0 + 0.5)  # std::round: halves away from zero
        values = np.where(percent <= 100.0, percent, UNKNOWN).astype(np.int8)
        occ = values / 100.0
        cells = np.where(occ_t < occ, OCCUPIED, np.where(occ < free_t, FREE, UNKNOWN))
        cells[values == UNKNOWN] = UNKNOWN
        return values, cells.astype(np.int8)
    occ = shade if meta.negate else 1.0 - shade
    cells = np.where(occ_t < occ, OCCUPIED, np.where(occ < free_t, FREE, UNKNOWN))
    if meta.mode == "trinary":
        cells = cells.astype(np.int8)
        return cells.copy(), cells
    between = np.rint((occ - free_t) / (occ_t - free_t) * 100.0)
    values = np.where(cells == UNKNOWN, between, cells)
    if alpha is not None:
        translucent = alpha < 1.0
        cells[translucent] = UNKNOWN
        values[translucent] = UNKNOWN
    return values.astype(np.int8), cells.astype(np.int8)


def _decode(
    data: bytes, meta: MapMeta, source: str, max_cells: int
) -> tuple[np.ndarray, np.ndarray | None]:
    """(shade, alpha) of an image file's bytes; see :func:`image_shade`."""
    name = meta.image_name
    try:
        with Image.open(io.BytesIO(data)) as img:
            size = img.size
            if size[0] * size[1] > max_cells:
                raise MapError(
                    source,
                    "image",
                    f"{name!r} is {size[0]} x {size[1]} pixels, more than the "
                    f"{max_cells:,} cells supported",
                )
            img.load()
            shade = image_shade(img, trinary_alpha=meta.mode == "trinary")
            return shade, _alpha(img)
    except MapError:
        raise
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        raise MapError(source, "image", f"cannot read {name!r} as an image ({exc})") from None


def image_shade(img: Image.Image, *, trinary_alpha: bool) -> np.ndarray:
    """(rows, cols) brightness 0..1 of a Pillow image, computed as map_io computes it.

    The mean of red, green and blue as 16-bit quanta (an 8-bit value v is the quantum 257 v),
    divided by 65535; with ``trinary_alpha`` and an alpha channel the opacity is a fourth term
    of the mean, as in map_io's trinary mode.

    Raises:
        ValueError: an image mode with no meaning as a map (floating point, > 16 bits).
    """
    rgb, alpha = _channels(img)
    total = rgb.sum(axis=-1) if rgb.ndim == 3 else rgb * 3.0
    count = 3.0
    if trinary_alpha and alpha is not None:
        total = total + alpha
        count = 4.0
    return (total / count) / _QUANTUM


def _alpha(img: Image.Image) -> np.ndarray | None:
    """(rows, cols) opacity 0..1, or None if the image has no alpha channel."""
    alpha = _channels(img)[1]
    return None if alpha is None else alpha / _QUANTUM


def _channels(img: Image.Image) -> tuple[np.ndarray, np.ndarray | None]:
    """(colour quanta: (rows, cols) grey or (rows, cols, 3) RGB; alpha quanta or None)."""
    mode = img.mode
    if mode.startswith("I;16") or mode == "I":
        grey = np.asarray(img, dtype=np.int64)
        if grey.min() < 0 or grey.max() > 65535:
            raise ValueError(f"{mode} pixels outside 0..65535")
        return grey.astype(float), None
    if mode == "P":
        img = img.convert("RGBA" if "transparency" in img.info else "RGB")
    elif mode == "1":
        img = img.convert("L")
    elif mode in ("La", "PA"):
        img = img.convert("LA")
    elif mode == "RGBa":
        img = img.convert("RGBA")
    elif mode == "F":
        raise ValueError("floating-point images are not maps")
    elif mode not in ("L", "LA", "RGB", "RGBA"):
        img = img.convert("RGB")
    arr = np.asarray(img, dtype=float) * 257.0
    if img.mode == "L":
        return arr, None
    if img.mode == "LA":
        return arr[..., 0], arr[..., 1]
    if img.mode == "RGB":
        return arr, None
    return arr[..., :3], arr[..., 3]
