"""Moving text stamped onto rendered frames with Pillow.

Matplotlib's Agg text is the costliest thing in a blitted frame (about 0.4 ms per short label and
3 ms for a title line, measured with matplotlib 3.11), so robot ids are rendered once as sprites
and alpha-blended with numpy, and the title line is drawn with Pillow (about 0.3 ms). The font is
matplotlib's bundled DejaVu Sans Bold with Pillow's basic layout: the same pixels everywhere.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

FONT = "DejaVu Sans"
LABEL_BOX_ALPHA = 191  # of 255: the white box behind an id lets trails show through a little


def font_path() -> str:
    """Path of matplotlib's bundled bold sans font."""
    from matplotlib import font_manager

    return font_manager.findfont(font_manager.FontProperties(family=FONT, weight="bold"))


class TextStamp:
    """Robot-id sprites and a title strip for frames of one size.

    Args:
        names: one label per robot.
        label_px, title_px: font sizes in pixels.
        width: frame width in pixels (the title strip spans it).
        title_h: height in pixels of the title strip at the top of the frame (background white).
        clip: (col0, col1, row0, row1) pixel box outside which labels are cut off.
        colour: text colour.
    """

    def __init__(
        self,
        names: Iterable[str],
        label_px: int,
        title_px: int,
        width: int,
        title_h: int,
        clip: tuple[int, int, int, int],
        colour: str,
    ) -> None:
        from PIL import Image, ImageDraw, ImageFont

        basic = ImageFont.Layout.BASIC  # no raqm, even where it is installed
        path = font_path()
        label_font = ImageFont.truetype(path, label_px, layout_engine=basic)
        self.title_font = ImageFont.truetype(path, title_px, layout_engine=basic)
        self.colour, self.clip = colour, clip
        pad = max(1, round(label_px / 5))
        self.sprites = []  # (premultiplied RGB * 255, 1 - alpha), float32
        for name in names:
            left, top, right, bottom = label_font.getbbox(str(name))
            im = Image.new("RGBA", (right - left + 2 * pad, bottom - top + 2 * pad), (0, 0, 0, 0))
            draw = ImageDraw.Draw(im)
            draw.rounded_rectangle(
                (0, 0, im.width - 1, im.height - 1),
                radius=pad,
                fill=(255, 255, 255, LABEL_BOX_ALPHA),
            )
            draw.text((pad - left, pad - top), str(name), font=label_font, fill=colour)
            rgba = np.asarray(im, dtype=np.float32) / 255.0
            alpha = rgba[..., 3:]
            self.sprites.append((rgba[..., :3] * alpha * 255.0, 1.0 - alpha))
        self.title_im = Image.new("RGB", (width, title_h), "white")
        self.title_draw = ImageDraw.Draw(self.title_im)
        self.title_xy = (round(0.02 * width), round(title_px / 2))

    def stamp(self, buf: np.ndarray, title: str, centres: np.ndarray, r_px: float) -> None:
        """Draw ``title`` and each robot's label beside its robot, never over another label.

        Args:
            buf: (H, W, >=3) uint8 frame, changed in place.
            title: the title line.
            centres: (m, 2) (column, row) pixel positions of the robots.
            r_px: robot radius in pixels (labels sit just off the robot's disc).
        """
        sizes = [keep.shape[1::-1] for _, keep in self.sprites]  # (w, h)
        anchors = place_labels(np.asarray(centres, dtype=float), sizes, r_px)
        self.title_im.paste("white", (0, 0, *self.title_im.size))
        self.title_draw.text(self.title_xy, title, font=self.title_font, fill=self.colour)
        buf[: self.title_im.height, :, :3] = np.asarray(self.title_im)
        cx0, cx1, cy0, cy1 = self.clip
        for (col, row), (premul, keep) in zip(anchors, self.sprites, strict=True):
            if not (np.isfinite(col) and np.isfinite(row)):
                continue  # no free place near the robot: the label is dropped this frame
            h, w = keep.shape[:2]
            x0, y1 = round(col), round(row)
            y0 = y1 - h
            ax0, ax1, ay0, ay1 = max(x0, cx0), min(x0 + w, cx1), max(y0, cy0), min(y1, cy1)
            if ax0 >= ax1 or ay0 >= ay1:
                continue
            sub = (slice(ay0 - y0, ay1 - y0), slice(ax0 - x0, ax1 - x0))
            region = buf[ay0:ay1, ax0:ax1, :3]
            region[...] = (region * keep[sub] + premul[sub] + 0.5).astype(np.uint8)


def place_labels(centres: np.ndarray, sizes, r_px: float) -> np.ndarray:
    """Bottom-left anchors (column, row) of labels, one per robot, that overlap no other label.

    Each label tries the four corners off its robot (upper right first, as labels have always
    sat); a label that overlaps an already placed one in all four is dropped (NaN). Robots are
    taken in index order, so the same robot keeps its label from frame to frame when it can.
    Labels are looked up in a grid of cells a label wide, so a frame costs O(m).
    """
    m = len(centres)
    out = np.full((m, 2), np.nan)
    if m == 0:
        return out
    cell = max(max(w for w, _ in sizes), max(h for _, h in sizes), 1)
    grid: dict[tuple[int, int], list[tuple[float, float, float, float]]] = {}
    off = 0.75 * r_px
    for k, ((cx, cy), (w, h)) in enumerate(zip(centres, sizes, strict=True)):
        if not (np.isfinite(cx) and np.isfinite(cy)):
            continue
        for dx, dy in ((off, -off), (off, off + h), (-off - w, -off), (-off - w, off + h)):
            x0, y1 = cx + dx, cy + dy  # bottom-left corner, rows grow downwards
            box = (x0, y1 - h, x0 + w, y1)
            cells = {
                (int(i // cell), int(j // cell)) for i in (box[0], box[2]) for j in (box[1], box[3])
            }
            near = [b for c in cells for b in grid.get(c, ())]
            if all(b[2] <= box[0] or box[2] <= b[0] or b[3] <= box[1] or box[3] <= b[1]
                   for b in near):  # fmt: skip
                out[k] = (x0, y1)
                for c in cells:
                    grid.setdefault(c, []).append(box)
                break
    return out
