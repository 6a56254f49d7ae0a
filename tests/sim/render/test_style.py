"""The frame's layout (``sim.render.style``): the arena fills the frame, the legend goes where the
arena gets larger."""

from __future__ import annotations

import pytest

from sim.render.scene import FrameScene


def test_fitted_height_leaves_no_empty_band(hand):
    from sim.render.style import fitted_height

    height = fitted_height(600, hand.arena_wh)
    scene = FrameScene(hand, (600, height))
    box = scene.ax.get_position()  # figure fractions
    used = box.height * height + scene.top_px + 18 * scene.scale  # arena + title + tick labels
    assert scene.legend_mode == "right"
    assert abs(used - height) <= 1.5  # no band under the arena
    assert height < 600  # a square arena beside a legend column needs less than a square frame


def test_a_square_frame_puts_the_legend_where_the_arena_gets_larger(hand):
    from sim.render.style import layout_options

    scene = FrameScene(hand, (600, 600))
    span = 20.0 + 2 * scene.pad_m
    options = layout_options(600, 600, span, span, scene.scale)
    best = max(options, key=lambda k: options[k][3])
    assert scene.legend_mode == best == "below"
    assert scene.px_per_m == pytest.approx(options["below"][3])
    assert options["below"][3] > options["right"][3]
