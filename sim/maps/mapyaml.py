"""The YAML file of a ROS map_server map: a strict reader of its few flat keys.

A map_server map is a small YAML file next to an image::

    image: depot.pgm            # PGM or PNG, relative to this file (or absolute)
    mode: trinary               # optional: trinary (default), scale or raw
    resolution: 0.05            # m per cell
    origin: [0.0, 0.0, 0]       # x, y (m) of the lower-left cell's corner, and a yaw (must be 0)
    negate: 0                   # 1: dark pixels are free, light ones occupied
    occupied_thresh: 0.65       # a cell is occupied above this occupancy
    free_thresh: 0.25           # ... and free below this one

These are the keys navigation2's ``map_io`` reads (``image``, ``resolution``, ``origin``,
``negate``, ``occupied_thresh`` and ``free_thresh`` required, ``mode`` optional, case-insensitive);
any other key is an error with a did-you-mean, so a typo never passes silently.

The file is read by a small parser of exactly what map files contain (``key: value`` lines,
``[a, b, c]`` lists, a block list of ``- item`` lines, quoted strings, ``#`` comments) rather than a
general YAML library: the format is flat and tiny, the errors can name the key and line, and
the package needs no YAML dependency. Anything beyond that subset (nested mappings, anchors,
tags, multi-line scalars) is refused with the line it is on.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

from sim.maps.errors import MapError, did_you_mean

MODES = ("trinary", "scale", "raw")
REQUIRED = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")
KEYS = (*REQUIRED, "mode")

_KEY_LINE = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)[ \t]*:(?:[ \t]+(.*))?$")
_NUMBER = re.compile(r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?")
_TRUE = frozenset({"true", "yes", "on", "y"})  # YAML 1.1 booleans, as yaml-cpp reads them
_FALSE = frozenset({"false", "no", "off", "n"})
_UNSUPPORTED = "{&*!|>%@`"


@dataclass(frozen=True, slots=True)
class MapMeta:
    """What a map YAML file says, checked and resolved."""

    image: Path  # the image file, resolved against the YAML file's folder
    image_name: str  # as written in the file
    resolution_m: float  # side of a cell
    origin_xy: tuple[float, float]  # m, map frame: the outer corner of the lower-left cell
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: str  # one of MODES


@dataclass(frozen=True, slots=True)
class Entry:
    """One key's raw value: a scalar string or a list of them, and the line it starts on."""

    value: str | list[str] | None
    line: int
    quoted: bool = False


def parse_yaml(text: str, source: str) -> dict[str, Entry]:
    """The flat ``key: value`` entries of a map YAML document.

    Raises:
        MapError: a line outside the supported subset, or a key given twice.
    """
    entries: dict[str, Entry] = {}
    block: str | None = None  # the key whose block list ("- item" lines) is open
    blocks: set[str] = set()  # keys given as "key:" with nothing after the colon
    started = False
    for n, raw in enumerate(text.splitlines(), start=1):
        line = _strip_comment(raw).rstrip()
        if not line.strip():
            continue
        if line == "---" and not started:
            continue
        if line == "...":
            break
        started = True
        item = line.lstrip()
        if item.startswith("- ") or item == "-":
            if block is None:
                raise MapError(source, f"line {n}", f"a list item outside a list: {raw.strip()!r}")
            listed = entries[block].value
            assert isinstance(listed, list)
            listed.append(_scalar(item[1:].strip(), source, n)[0])
            continue
        if line[0] in " \t":
            raise MapError(source, f"line {n}", f"unexpected indentation: {raw.strip()!r}")
        match = _KEY_LINE.match(line)
        if match is None:
            raise MapError(source, f"line {n}", f"expected 'key: value', got {raw.strip()!r}")
        key, rest = match.group(1), (match.group(2) or "").strip()
        if key in entries:
            first = entries[key].line
            raise MapError(source, key, f"given twice (lines {first} and {n})")
        block = None
        if not rest:
            entries[key] = Entry([], n)
            block = key
            blocks.add(key)
        elif rest.startswith("["):
            entries[key] = Entry(_flow_list(rest, source, n), n)
        else:
            value, quoted = _scalar(rest, source, n)
            entries[key] = Entry(value, n, quoted)
    for key in blocks:
        if not entries[key].value:  # "key:" and no items: YAML's null
            entries[key] = Entry(None, entries[key].line)
    return entries


def _strip_comment(line: str) -> str:
    """The line without a ``#`` comment (one at the start or after a space, outside quotes)."""
    quote = ""
    for k, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = ""
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (k == 0 or line[k - 1] in " \t"):
            return line[:k]
    return line


def _scalar(text: str, source: str, n: int) -> tuple[str, bool]:
    """A plain or quoted scalar: (its text, whether it was quoted)."""
    if text[:1] == '"':
        try:
            value = json.loads(text)
        except ValueError:
            raise MapError(source, f"line {n}", f"bad double-quoted string {text!r}") from None
        if not isinstance(value, str):
            raise MapError(source, f"line {n}", f"bad double-quoted string {text!r}")
        return value, True
    if text[:1] == "'":
        if len(text) < 2 or text[-1] != "'" or "'" in text[1:-1].replace("''", ""):
            raise MapError(source, f"line {n}", f"bad single-quoted string {text!r}")
        return text[1:-1].replace("''", "'"), True
    if text[:1] in _UNSUPPORTED or text[:1] in "[]" or ": " in text:
        raise MapError(source, f"line {n}", f"unsupported YAML (map files are flat): {text!r}")
    return text, False


def _flow_list(text: str, source: str, n: int) -> list[str]:
    """The items of a one-line ``[a, b, c]`` list."""
    if not text.endswith("]") or "[" in text[1:] or "]" in text[:-1]:
        raise MapError(source, f"line {n}", f"a list must be one line '[a, b, c]', got {text!r}")
    inner = text[1:-1].strip()
    if not inner:
        return []
    return [_scalar(part.strip(), source, n)[0] for part in inner.split(",")]


def read_meta(path: Path, text: str, source: str) -> MapMeta:
    """Check the entries of a map YAML file (its text given) and resolve its image path.

    Args:
        path: the YAML file (its folder anchors a relative ``image``).
        text: the file's text.
        source: how errors name the file.

    Raises:
        MapError: an unknown or missing key, or a value of the wrong type or range.
    """
    entries = parse_yaml(text, source)
    for key in entries:
        if key not in KEYS:
            raise MapError(source, key, f"unknown key{did_you_mean(key, KEYS)}")
    for key in REQUIRED:
        if key not in entries:
            raise MapError(source, key, "missing (map_server requires it)")
    image_name = _string(entries["image"], source, "image")
    mode = _string(entries["mode"], source, "mode").lower() if "mode" in entries else "trinary"
    if mode not in MODES:
        choices = ", ".join(repr(m) for m in MODES)
        hint = did_you_mean(mode, MODES)
        raise MapError(source, "mode", f"must be one of {choices}, got {mode!r}{hint}")
    resolution = _number(entries["resolution"], source, "resolution")
    if not resolution > 0:
        raise MapError(source, "resolution", f"must be > 0 (m per cell), got {resolution:g}")
    origin = _origin(entries["origin"], source)
    occupied = _threshold(entries["occupied_thresh"], source, "occupied_thresh")
    free = _threshold(entries["free_thresh"], source, "free_thresh")
    if not free < occupied:
        raise MapError(
            source, "free_thresh", f"must be below occupied_thresh ({occupied:g}), got {free:g}"
        )
    image = Path(image_name)
    if not image.is_absolute():
        image = path.parent / image
    return MapMeta(
        image=image,
        image_name=image_name,
        resolution_m=resolution,
        origin_xy=origin,
        negate=_negate(entries["negate"], source),
        occupied_thresh=occupied,
        free_thresh=free,
        mode=mode,
    )


def _string(entry: Entry, source: str, key: str) -> str:
    if not isinstance(entry.value, str) or not entry.value.strip():
        raise MapError(source, key, f"must be a non-empty string, got {_shown(entry)}")
    return entry.value.strip()


def _to_float(text: str, source: str, key: str, shown: str) -> float:
    if not _NUMBER.fullmatch(text.strip()):
        if text.strip().lower() in {".inf", "+.inf", "-.inf", ".nan"}:
            raise MapError(source, key, f"must be a finite number, got {shown}")
        raise MapError(source, key, f"must be a number, got {shown}")
    value = float(text)
    if not math.isfinite(value):
        raise MapError(source, key, f"must be a finite number, got {shown}")
    return value


def _number(entry: Entry, source: str, key: str) -> float:
    if not isinstance(entry.value, str):
        raise MapError(source, key, f"must be a number, got {_shown(entry)}")
    return _to_float(entry.value, source, key, _shown(entry))


def _threshold(entry: Entry, source: str, key: str) -> float:
    value = _number(entry, source, key)
    if not 0.0 <= value <= 1.0:
        raise MapError(source, key, f"must be in [0, 1], got {value:g}")
    return value


def _origin(entry: Entry, source: str) -> tuple[float, float]:
    if not isinstance(entry.value, list):
        raise MapError(source, "origin", f"must be a list [x, y, yaw], got {_shown(entry)}")
    if len(entry.value) != 3:
        count = len(entry.value)
        raise MapError(source, "origin", f"must be [x, y, yaw], got {count} values")
    x, y, yaw = (_to_float(v, source, "origin", repr(v)) for v in entry.value)
    if yaw != 0.0:
        raise MapError(source, "origin", f"yaw must be 0 (got {yaw:g}): rotated maps are not read")
    return (x, y)


def _negate(entry: Entry, source: str) -> bool:
    word = entry.value.strip().lower() if isinstance(entry.value, str) else None
    if word in {"0", "1"}:
        return word == "1"
    if word in _TRUE | _FALSE and not entry.quoted:
        return word in _TRUE
    raise MapError(source, "negate", f"must be 0, 1, true or false, got {_shown(entry)}")


def _shown(entry: Entry) -> str:
    if entry.value is None:
        return "nothing"
    if isinstance(entry.value, list):
        return "[" + ", ".join(entry.value) + "]"
    return repr(entry.value)
