"""Frames of a finished run (``sim.render.frames``, drawn by ``sim.render.scene``): what each
pixel shows, the window of times, blitting, odd sizes and an empty world."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from sim.recording import Trajectory
from sim.render import frame_times, render_frame, render_frames
from sim.render.scene import FrameScene
from sim.render.style import STATE_FILL, WAIT_RING, type_colours
from sim.render.timeline import robot_poses_at
from sim.states import DRIVING, IDLE, WAITING, WORKING

SIZE = (400, 400)


def rgb255(colour) -> np.ndarray:
    return np.round(np.array(to_rgb(colour)) * 255).astype(int)


def pixel(frame: np.ndarray, col_row: np.ndarray) -> np.ndarray:
    col, row = (int(v) for v in np.floor(col_row))
    return frame[row, col].astype(int)


def test_render_frame_shape_dtype_odd_size(hand):
    frame = render_frame(hand, 3.0, size=(333, 217))
    assert frame.shape == (217, 333, 3)
    assert frame.dtype == np.uint8
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 20  # something was drawn


def test_robot_fill_shows_its_state(hand, scene):
    for t_s, state in ((2.5, DRIVING), (5.0, WORKING)):
        xy, _, states = robot_poses_at(hand, t_s)
        assert states[0] == state
        frame = render_frame(hand, t_s, size=SIZE)
        got = pixel(frame, scene.pixel_xy(xy[0])[0])
        assert np.abs(got - rgb255(STATE_FILL[state])).max() <= 3


def test_robot_moves_along_its_trail(hand, scene):
    earlier, later = 1.8, 3.6
    p_early = scene.pixel_xy(robot_poses_at(hand, earlier)[0][0])[0]
    p_late = scene.pixel_xy(robot_poses_at(hand, later)[0][0])[0]
    assert np.hypot(*(p_late - p_early)) > 20  # it moved on screen
    white, grey = rgb255("white"), rgb255(STATE_FILL[DRIVING])
    f_early = render_frame(hand, earlier, size=SIZE)
    f_late = render_frame(hand, later, size=SIZE)
    assert np.abs(pixel(f_early, p_early) - grey).max() <= 3
    assert np.abs(pixel(f_early, p_late) - white).max() == 0  # not there yet, no trail ahead
    assert np.abs(pixel(f_late, p_late) - grey).max() <= 3
    trail = pixel(f_late, p_early)  # where it was: now under its trail, which is blue
    assert trail[2] - trail[0] > 40
    assert np.abs(trail - grey).max() > 20


def test_trail_is_limited_to_trail_s(hand, scene):
    p_mid = scene.pixel_xy([3.5, 7.6])[0]  # on the path, passed at t = 2.5 s
    with_trail = render_frame(hand, 3.9, size=SIZE, trail_s=10.0)
    short = render_frame(hand, 3.9, size=SIZE, trail_s=0.5)
    no_trail = render_frame(hand, 3.9, size=SIZE, trail_s=0.0)
    white = rgb255("white")
    assert np.abs(pixel(with_trail, p_mid) - white).max() > 40
    assert np.abs(pixel(short, p_mid) - white).max() == 0
    assert np.abs(pixel(no_trail, p_mid) - white).max() == 0


def test_task_appears_is_taken_fades_and_goes(hand, scene):
    site = scene.pixel_xy(hand.task_xy[0])[0]
    colour = np.round(type_colours(2)[0, :3] * 255).astype(int)
    white = rgb255("white")
    before = render_frame(hand, 0.5, size=SIZE)
    assert np.abs(pixel(before, site) - white).max() == 0
    taken = render_frame(hand, 3.0, size=SIZE)
    assert np.abs(pixel(taken, site) - colour).max() <= 3
    done = render_frame(hand, 8.0, size=SIZE)  # done at 6 s: faded for trail_s
    faded = np.round(0.25 * colour + 0.75 * 255).astype(int)
    assert np.abs(pixel(done, site) - faded).max() <= 3
    gone = render_frame(hand, 8.0, size=SIZE, trail_s=1.0)
    assert np.abs(pixel(gone, site) - white).max() == 0


def nearest_colour_distance(frame: np.ndarray, col_row: np.ndarray, colour) -> int:
    """Smallest max-channel distance to ``colour`` among the 3 x 3 pixels around a point (a
    marker a few pixels wide, centred between pixels, is anti-aliased at its exact centre)."""
    col, row = (int(v) for v in np.floor(col_row))
    patch = frame[row - 1 : row + 2, col - 1 : col + 2, :3].astype(int)
    return int(np.abs(patch - np.asarray(colour)).max(axis=-1).min())


def test_lost_task_is_marked_then_vanishes(hand, scene):
    site = scene.pixel_xy(hand.task_xy[1])[0]
    colour = np.round(type_colours(2)[1, :3] * 255).astype(int)
    white = (255, 255, 255)
    assert np.abs(pixel(render_frame(hand, 1.5, size=SIZE), site) - 255).max() == 0
    assert nearest_colour_distance(render_frame(hand, 3.0, size=SIZE), site, colour) <= 3
    assert np.abs(pixel(render_frame(hand, 13.0, size=SIZE), site) - 255).max() == 0
    assert nearest_colour_distance(render_frame(hand, 13.0, size=SIZE), site, white) == 0


def test_blitted_frames_match_fresh_frames(hand):
    """Blitting leaves nothing of earlier frames behind."""
    frames = list(render_frames(hand, frames=4, size=(240, 200), t_from=2.0, t_to=9.0))
    for t_s, frame in zip(frame_times(hand, 4, 2.0, 9.0), frames, strict=True):
        np.testing.assert_array_equal(frame, render_frame(hand, t_s, size=(240, 200)))


def test_window_is_respected(hand):
    np.testing.assert_allclose(frame_times(hand, 5, 2.0, 4.0), [2.0, 2.5, 3.0, 3.5, 4.0])
    np.testing.assert_allclose(frame_times(hand, 3), [0.0, 7.0, 14.0])
    frames = list(render_frames(hand, frames=3, size=(200, 200), t_from=2.0, t_to=4.0))
    assert len(frames) == 3
    np.testing.assert_array_equal(frames[0], render_frame(hand, 2.0, size=(200, 200)))
    np.testing.assert_array_equal(frames[-1], render_frame(hand, 4.0, size=(200, 200)))


def test_empty_world_renders():
    traj = Trajectory(
        times_s=np.array([0.0]),
        positions=np.zeros((1, 1, 2), np.float32) + 1,
        headings=np.zeros((1, 1), np.float32),
        robot_state=np.zeros((1, 1), np.int8),
        task_id=np.zeros(0, int),
        task_type=np.zeros(0, int),
        task_high=np.zeros(0, bool),
        task_xy=np.zeros((0, 2)),
        t_announce=np.zeros(0),
        t_alloc=np.zeros(0),
        t_done=np.zeros(0),
        task_robot=np.zeros(0, int),
        arena_wh=np.array([4.0, 3.0]),
        obstacles=np.zeros((0, 0, 2)),
        type_names=np.array(["A"]),
        robot_names=np.array(["x"]),
    )
    assert render_frame(traj, 0.0, size=(128, 96)).shape == (96, 128, 3)


def test_render_frame_outside_record(hand):
    with pytest.raises(ValueError, match="outside the recorded times"):
        render_frame(hand, 15.0)


def test_idle_sites_are_drawn_hollow_in_their_type_colour(hand):
    import dataclasses

    with_sites = dataclasses.replace(
        hand, site_xy=np.array([[15.0, 15.0], [10.0, 17.0]]), site_type=np.array([1, 0])
    )
    scene = FrameScene(with_sites, SIZE)
    frame = render_frame(with_sites, 1.5, size=SIZE)  # no task at (10, 17) ever
    centre = scene.pixel_xy(np.array([10.0, 17.0]))[0]
    col, row = (int(v) for v in np.floor(centre))
    ring = frame[row - 8 : row + 9, col - 8 : col + 9, :3].astype(int)
    colour = np.round(type_colours(2)[0, :3] * 255).astype(int)
    assert np.abs(ring - colour).max(axis=-1).min() <= 40  # the ring in the type's colour
    assert np.abs(frame[row, col, :3].astype(int) - 255).max() == 0  # hollow: white inside
    plain = render_frame(hand, 1.5, size=SIZE)
    assert np.abs(plain[row - 8 : row + 9, col - 8 : col + 9, :3].astype(int) - 255).max() == 0


def test_a_waiting_robot_is_light_grey_and_ringed(hand, scene):
    """Robot 1 (idle at (15, 5)) recorded WAITING from 8 s: its fill is the waiting grey and a
    dark ring stands WAIT_RING radii from its centre (white there before)."""
    waiting = dataclasses.replace(hand, robot_state=hand.robot_state.copy())
    waiting.robot_state[hand.times_s >= 8.0, 1] = WAITING
    centre = scene.pixel_xy(np.array([15.0, 5.0]))[0]
    ring = scene.pixel_xy(np.array([15.0, 5.0 - WAIT_RING * scene.robot_r_m]))[0]  # below it
    before = render_frame(waiting, 7.0, size=SIZE)
    after = render_frame(waiting, 9.0, size=SIZE)
    assert np.abs(pixel(before, centre) - rgb255(STATE_FILL[IDLE])).max() <= 3
    assert np.abs(pixel(after, centre) - rgb255(STATE_FILL[WAITING])).max() <= 3
    dark = [after[int(ring[1]) + d, int(ring[0])].astype(int).sum() for d in (-1, 0, 1)]
    light = [before[int(ring[1]) + d, int(ring[0])].astype(int).sum() for d in (-1, 0, 1)]
    assert min(dark) < 400 and min(light) > 600
