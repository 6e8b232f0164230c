"""The viewer and recordings, headless (no display needed)."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import imageio.v2 as iio  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from nao_arena.arena import Arena  # noqa: E402
from nao_arena.environment import parallel_env  # noqa: E402
from nao_arena.maps import load_map  # noqa: E402
from nao_arena.render import FRAME_SIZE, Recorder, Viewer, record_episode  # noqa: E402


@pytest.mark.slow
@pytest.mark.parametrize("name", ["roundabout", "two_lane_road", "corridor"])
def test_rgb_array_frames(name):
    e = parallel_env(name, render_mode="rgb_array", time_limit=2.0, map_params={})
    e.reset(seed=0)
    for _ in range(3):
        e.step({a: np.full(2, 0.3, dtype=np.float32) for a in e.agents})
    frame = e.render()
    w, h = FRAME_SIZE
    assert frame.shape == (h, w, 3) and frame.dtype == np.uint8
    colours = np.unique(frame.reshape(-1, 3), axis=0)
    assert len(colours) > 50  # walls, lanes, bodies, panel, text: not a blank frame
    world, panel = frame[:, :h], frame[:, h:]
    assert world.std() > 5 and panel.std() > 5
    e.close()


def test_human_mode_without_display_returns_none():
    e = parallel_env("circle_swap", n=3, render_mode="human", time_limit=1.0)
    e.reset(seed=0)
    assert e.render() is None
    e.step({a: np.zeros(2, dtype=np.float32) for a in e.agents})
    e.close()


def test_viewer_size_option_and_contacts_flash():
    arena = Arena(load_map("circle_swap", n=2, radius=1.0, agent="goal"))
    arena.reset(0)
    viewer = Viewer()
    for _ in range(12):
        arena.step()
    frame = viewer.draw(arena, selected=1)
    assert len(arena.stats.contacts) > 0  # goal-only robots on a 2 m circle collide
    red = np.all(frame[:, :800] == (220, 20, 30), axis=-1).sum()
    assert red > 20


def test_record_gif_from_arena(tmp_path):
    arena = Arena(load_map("circle_swap", n=3))
    out = record_episode(arena, tmp_path / "swap.gif", max_steps=6, seed=1)
    assert out == tmp_path / "swap.gif" and out.is_file()
    frames = iio.mimread(out)
    assert len(frames) == 7  # the reset state and one frame per step at fps = 1/dt
    assert frames[0].shape[:2] == (FRAME_SIZE[1], FRAME_SIZE[0])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["swap.gif"]  # no temporary left


def test_record_env_subsampled_mp4(tmp_path):
    e = parallel_env("roundabout", time_limit=1.0)
    rng = np.random.default_rng(0)
    out = record_episode(
        e,
        tmp_path / "r.mp4",
        fps=5.0,
        seed=0,
        policy=lambda obs: {a: rng.uniform(-1, 1, 2) for a in obs},
    )
    assert out.is_file() and out.stat().st_size > 1000
    frames = iio.mimread(out, format="FFMPEG")
    assert len(frames) == 6  # 1 s at 5 fps of simulated time, plus the first frame


def test_recorder_is_atomic(tmp_path):
    target = tmp_path / "x.gif"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError), Recorder(target, fps=10) as rec:
        rec.add(np.zeros((16, 16, 3), dtype=np.uint8))
        raise RuntimeError("interrupted")
    assert target.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.gif"]
    with pytest.raises(ValueError, match=".gif or .mp4"):
        Recorder(tmp_path / "x.avi", fps=10)
