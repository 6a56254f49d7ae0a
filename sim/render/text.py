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

    def stamp(self, buf: np.ndarray, title: str, anchors: np.ndarray) -> None:
        """Draw ``title`` and each robot's label with its bottom-left corner at ``anchors``.

        Args:
            buf: (H, W, >=3) uint8 frame, changed in place.
            title: the title line.
            anchors: (m, 2) (column, row) pixel positions, one per robot.
        """
        self.title_im.paste("white", (0, 0, *self.title_im.size))
        self.title_draw.text(self.title_xy, title, font=self.title_font, fill=self.colour)
        buf[: self.title_im.height, :, :3] = np.asarray(self.title_im)
        cx0, cx1, cy0, cy1 = self.clip
        for (col, row), (premul, keep) in zip(anchors, self.sprites, strict=True):
            if not (np.isfinite(col) and np.isfinite(row)):
                continue
            h, w = keep.shape[:2]
            x0, y1 = round(col), round(row)
            y0 = y1 - h
            ax0, ax1, ay0, ay1 = max(x0, cx0), min(x0 + w, cx1), max(y0, cy0), min(y1, cy1)
            if ax0 >= ax1 or ay0 >= ay1:
                continue
            sub = (slice(ay0 - y0, ay1 - y0), slice(ax0 - x0, ax1 - x0))
            region = buf[ay0:ay1, ax0:ax1, :3]
            region[...] = (region * keep[sub] + premul[sub] + 0.5).astype(np.uint8)
