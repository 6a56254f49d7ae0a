"""Headless rendering: frames, GIFs, the synthetic trajectory, argument checks, the backend."""

from __future__ import annotations

import dataclasses
import itertools
import os
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from matplotlib.colors import to_rgb
from matplotlib.path import Path as MplPath
from PIL import Image

from scenarios.bench.synthetic import synthetic_trajectory
from sim.recording import Trajectory
from sim.render import frame_times, render_frame, render_frames, render_gif, render_mp4
from sim.render.scene import FrameScene
from sim.render.style import STATE_FILL, WAIT_RING, type_colours
from sim.render.timeline import robot_poses_at, task_counts_at, task_view_at
from sim.states import DRIVING, IDLE, WAITING, WORKING

SIZE = (400, 400)
REPO = Path(__file__).resolve().parents[2]


def rgb255(colour) -> np.ndarray:
    return np.round(np.array(to_rgb(colour)) * 255).astype(int)


def pixel(frame: np.ndarray, col_row: np.ndarray) -> np.ndarray:
    col, row = (int(v) for v in np.floor(col_row))
    return frame[row, col].astype(int)


@pytest.fixture(scope="module")
def hand() -> Trajectory:
    """Two robots, two tasks, 14 s at 0.1 s.

    Robot 0 idles at (2, 9), drives to (5, 6.2) between t = 1 and 4 s (task 0 at (5, 5): type 0,
    high priority, announced and allocated at 1 s), works there until 6 s, then idles. Robot 1
    idles at (15, 5). Task 1 (type 1, low priority, (15, 15)) is announced at 2 s and lost.
    """
    times = np.round(np.arange(0, 14.0001, 0.1), 6)
    start, goal = np.array([2.0, 9.0]), np.array([5.0, 6.2])
    w = np.clip((times - 1.0) / 3.0, 0.0, 1.0)[:, None]
    pos = np.empty((len(times), 2, 2))
    pos[:, 0] = start + w * (goal - start)
    pos[:, 1] = (15.0, 5.0)
    head = np.zeros((len(times), 2))
    head[:, 0] = np.arctan2(*(goal - start)[::-1])
    state = np.full((len(times), 2), IDLE, dtype=np.int8)
    state[(times > 1.0) & (times < 4.0), 0] = DRIVING
    state[(times >= 4.0) & (times < 6.0), 0] = WORKING
    nan = np.nan
    return Trajectory(
        times_s=times,
        positions=pos.astype(np.float32),
        headings=head.astype(np.float32),
        robot_state=state,
        task_id=np.array([0, 1]),
        task_type=np.array([0, 1]),
        task_high=np.array([True, False]),
        task_xy=np.array([[5.0, 5.0], [15.0, 15.0]]),
        t_announce=np.array([1.0, 2.0]),
        t_alloc=np.array([1.0, nan]),
        t_done=np.array([6.0, nan]),
        task_robot=np.array([0, -1]),
        arena_wh=np.array([20.0, 20.0]),
        obstacles=np.array([[[8.0, 8.0], [11.0, 8.0], [11.0, 11.0], [nan, nan]]]),
        type_names=np.array(["weld", "carry"]),
        robot_names=np.array(["R1", "R2"]),
    )


@pytest.fixture(scope="module")
def synth() -> Trajectory:
    return synthetic_trajectory(np.random.default_rng(7), robots=10, seconds=60.0, tasks=20)


@pytest.fixture(scope="module")
def scene(hand) -> FrameScene:
    """Only for projecting metres to pixels: the layout depends on size and trajectory alone."""
    return FrameScene(hand, SIZE)


# --- frames ---------------------------------------------------------------------------------


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


def test_counts(hand):
    zero = {"announced": 0, "done": 0, "lost": 0, "in_progress": 0}
    assert task_counts_at(hand, 0.5) == zero
    # task 0 allocated at 1 s, done at 6 s; task 1 announced at 2 s and lost
    assert task_counts_at(hand, 3.0) == {"announced": 2, "done": 0, "lost": 1, "in_progress": 1}
    assert task_counts_at(hand, 7.0) == {"announced": 2, "done": 1, "lost": 1, "in_progress": 0}


def test_pose_interpolation(hand):
    xy, heading, state = robot_poses_at(hand, 2.05)
    np.testing.assert_allclose(xy, (hand.positions[20] + hand.positions[21]) / 2, atol=1e-6)
    np.testing.assert_allclose(heading, hand.headings[20], atol=1e-6)
    np.testing.assert_array_equal(state, hand.robot_state[20])
    np.testing.assert_allclose(robot_poses_at(hand, 99.0)[0], hand.positions[-1])


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


# --- GIF ------------------------------------------------------------------------------------


def test_gif_has_the_frames_asked_for(synth, tmp_path):
    out = render_gif(synth, tmp_path / "sub" / "run.gif", frames=12, fps=10, size=(240, 200))
    assert out == tmp_path / "sub" / "run.gif"
    assert [p.name for p in out.parent.iterdir()] == ["run.gif"]  # no temporary left behind
    with Image.open(out) as im:
        assert im.format == "GIF"
        assert im.size == (240, 200)
        assert im.n_frames == 12
        assert im.info["loop"] == 0
        assert im.info["duration"] == 100
        decoded = []
        for k in range(im.n_frames):
            im.seek(k)
            decoded.append(np.asarray(im.convert("RGB")).astype(int))
    for a, b in itertools.pairwise(decoded):
        assert np.any(a != b)
    assert (np.abs(decoded[0] - decoded[-1]).max(axis=2) > 30).sum() > 100
    # one palette for all frames, close to the RGB frames
    rgb = list(render_frames(synth, frames=12, size=(240, 200)))
    for k in (0, 6, 11):
        err = np.abs(decoded[k] - rgb[k].astype(int)).max(axis=2)
        assert np.mean(err > 12) < 0.01
        assert np.all(err[(rgb[k] == 255).all(axis=2)] == 0)  # white stays exactly white


def test_gif_is_deterministic(hand, tmp_path):
    a = render_gif(hand, tmp_path / "a.gif", frames=5, size=(160, 160))
    b = render_gif(hand, tmp_path / "b.gif", frames=5, size=(160, 160))
    assert a.read_bytes() == b.read_bytes()


def test_close_frames_stay_distinct(hand, tmp_path):
    """Frames 0.01 s apart still differ (the clock prints more decimals), so none are merged."""
    out = render_gif(hand, tmp_path / "c.gif", frames=4, size=(160, 160), t_from=0.0, t_to=0.03)
    with Image.open(out) as im:
        assert im.n_frames == 4


def test_gif_replaces_existing_file_atomically(hand, tmp_path):
    target = tmp_path / "run.gif"
    target.write_bytes(b"old")
    render_gif(hand, target, frames=2, size=(128, 128))
    assert target.read_bytes()[:6] == b"GIF89a"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.gif"]


# --- bad arguments --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"frames": 0}, "frames must be a positive integer"),
        ({"frames": -3}, "frames must be a positive integer"),
        ({"frames": 2.5}, "frames must be a positive integer"),
        ({"size": (0, 100)}, "size must be"),
        ({"size": (100, 0)}, "size must be"),
        ({"size": (100,)}, "size must be"),
        ({"t_from": 5.0, "t_to": 2.0}, "t_from .* is after t_to"),
        ({"t_from": 3.0, "t_to": 3.0}, "identical frames"),
        ({"t_from": -1.0}, "outside the recorded times"),
        ({"t_to": 99.0}, "outside the recorded times"),
        ({"trail_s": -1.0}, "trail_s must be"),
        ({"fps": 0}, "fps must be"),
        ({"fps": 120}, "fps must be"),
    ],
)
def test_bad_arguments_raise_before_writing(hand, tmp_path, kwargs, message):
    target = tmp_path / "bad.gif"
    with pytest.raises(ValueError, match=message):
        render_gif(hand, target, **{"frames": 3, "size": (128, 128), **kwargs})
    assert not list(tmp_path.iterdir())
    if "fps" not in kwargs:
        with pytest.raises(ValueError, match=message):
            render_frames(hand, **{"frames": 3, "size": (128, 128), **kwargs})


def test_render_frame_outside_record(hand):
    with pytest.raises(ValueError, match="outside the recorded times"):
        render_frame(hand, 15.0)


def test_mp4_without_ffmpeg_says_so(hand, tmp_path, monkeypatch):
    monkeypatch.setattr("sim.render.animation.shutil.which", lambda name: None)
    with pytest.raises(RuntimeError, match="ffmpeg"):
        render_mp4(hand, tmp_path / "a.mp4", frames=2, size=(128, 128))
    assert not list(tmp_path.iterdir())


# --- headless, backend untouched ------------------------------------------------------------


def test_backend_of_this_process_is_unchanged(hand, tmp_path):
    before = matplotlib.get_backend(auto_select=False)
    had_pyplot = "matplotlib.pyplot" in sys.modules
    render_gif(hand, tmp_path / "x.gif", frames=2, size=(128, 128))
    render_frame(hand, 1.0, size=(128, 128))
    assert matplotlib.get_backend(auto_select=False) == before
    assert ("matplotlib.pyplot" in sys.modules) == had_pyplot


def test_renders_without_display_or_mplbackend(tmp_path):
    env = {
        k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "DISPLAY", "WAYLAND_DISPLAY")
    }
    script = (
        "import sys, numpy as np, matplotlib\n"
        "from sim.render import render_gif\n"
        "from scenarios.bench.synthetic import synthetic_trajectory\n"
        "tr = synthetic_trajectory(np.random.default_rng(1), robots=3, seconds=8.0, tasks=4)\n"
        "render_gif(tr, sys.argv[1], frames=3, size=(128, 128))\n"
        "print(matplotlib.get_backend(auto_select=False), 'matplotlib.pyplot' in sys.modules)\n"
    )
    out = tmp_path / "headless.gif"
    done = subprocess.run(
        [sys.executable, "-c", script, str(out)],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert done.stdout.split() == ["None", "False"]
    with Image.open(out) as im:
        assert im.n_frames == 3


# --- synthetic trajectory -------------------------------------------------------------------


def test_synthetic_trajectory_is_plausible(synth):
    T, m = len(synth.times_s), len(synth.robot_names)
    assert synth.positions.shape == (T, m, 2) and m == 10
    assert synth.headings.shape == synth.robot_state.shape == (T, m)
    np.testing.assert_allclose(np.diff(synth.times_s), 0.1, atol=1e-6)
    assert set(np.unique(synth.robot_state)) == {IDLE, DRIVING, WORKING}
    assert np.all((synth.positions >= 0) & (synth.positions <= 20))
    assert synth.obstacles.shape[0] == 3 and np.isnan(synth.obstacles).any()  # NaN-padded
    flat = synth.positions.reshape(-1, 2)
    for poly in synth.obstacles:
        pts = poly[np.all(np.isfinite(poly), axis=1)]
        assert not MplPath(pts).contains_points(flat).any()  # nobody drives through walls
    n = len(synth.task_id)
    assert n == 20 and synth.task_xy.shape == (n, 2)
    lost = synth.task_robot < 0
    assert lost.any() and (~lost).any()
    assert np.all(np.isnan(synth.t_alloc[lost]))
    assert np.all(synth.t_alloc[~lost] >= synth.t_announce[~lost])
    done = np.isfinite(synth.t_done)
    assert done.sum() >= 5 and np.all(synth.t_done[done] > synth.t_alloc[done])
    assert synth.task_high.any() and (~synth.task_high).any()


def test_synthetic_trajectory_is_seeded():
    a = synthetic_trajectory(np.random.default_rng(3), robots=4, seconds=15.0, tasks=6)
    b = synthetic_trajectory(np.random.default_rng(3), robots=4, seconds=15.0, tasks=6)
    c = synthetic_trajectory(np.random.default_rng(4), robots=4, seconds=15.0, tasks=6)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.task_xy, b.task_xy)
    assert not np.array_equal(a.positions, c.positions)


def test_synthetic_trajectory_round_trips_through_npz(tmp_path):
    traj = synthetic_trajectory(np.random.default_rng(5), robots=3, seconds=10.0, tasks=5)
    traj.save(tmp_path / "t.npz")
    back = Trajectory.load(tmp_path / "t.npz")
    frame_a = render_frame(traj, 5.0, size=(128, 128))
    frame_b = render_frame(back, 5.0, size=(128, 128))
    np.testing.assert_array_equal(frame_a, frame_b)


def test_task_view(hand):
    before = task_view_at(hand, 0.5, 10.0)
    assert not any(m.any() for m in (before.waiting, before.taken, before.done, before.lost))
    during = task_view_at(hand, 3.0, 10.0)
    np.testing.assert_array_equal(during.taken, [True, False])
    np.testing.assert_array_equal(during.lost, [False, True])
    after = task_view_at(hand, 8.0, 10.0)
    np.testing.assert_array_equal(after.done, [True, False])
    assert not after.taken.any()
    later = task_view_at(hand, 13.0, 5.0)  # both events older than the window
    assert not later.done.any() and not later.lost.any()


# --- layout, sites and labels (README: the arena fills the frame) ----------------------------


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


def test_labels_never_overlap_and_are_dropped_when_no_corner_is_free():
    from sim.render.text import place_labels

    sizes = [(20, 10)] * 6
    lone = place_labels(np.array([[100.0, 100.0]]), sizes[:1], 8.0)
    assert lone.tolist() == [[106.0, 94.0]]  # upper right of the robot, as labels always sat
    crowd = np.array([[100.0, 100.0]] * 6)  # six robots on one spot: four corners, two dropped
    anchors = place_labels(crowd, sizes, 8.0)
    placed = np.flatnonzero(np.isfinite(anchors[:, 0]))
    assert placed.tolist() == [0, 1, 2, 3]
    boxes = [(x, y - 10, x + 20, y) for x, y in anchors[placed]]
    for a, b in itertools.combinations(boxes, 2):
        assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]


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
