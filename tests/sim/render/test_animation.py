"""GIF and MP4 files (``sim.render.animation``): the frames asked for, deterministic and atomic
files, bad arguments raised before writing, and headless drawing that leaves the process's
matplotlib backend alone."""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from PIL import Image

from sim.render import render_frame, render_frames, render_gif, render_mp4

REPO = Path(__file__).resolve().parents[3]


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


def test_mp4_without_ffmpeg_says_so(hand, tmp_path, monkeypatch):
    monkeypatch.setattr("sim.render.animation.shutil.which", lambda name: None)
    with pytest.raises(RuntimeError, match="ffmpeg"):
        render_mp4(hand, tmp_path / "a.mp4", frames=2, size=(128, 128))
    assert not list(tmp_path.iterdir())


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
