"""Replay: a logged episode drawn again equals the live run frame by frame (headless)."""

from __future__ import annotations

import itertools
import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import imageio.v2 as iio  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

import nao_arena.render.viewer as viewer_module  # noqa: E402
from nao_arena.arena import Arena  # noqa: E402
from nao_arena.cli import main  # noqa: E402
from nao_arena.episode_log import EpisodeRecorder, read_log, write_log  # noqa: E402
from nao_arena.render import FRAME_SIZE, Viewer  # noqa: E402
from nao_arena.render.replay import Replayer, play  # noqa: E402
from nao_arena.trials import make_map  # noqa: E402

STEPS = 14


class StepClock:
    """A wall clock that advances 10 ms per reading: the HUD's steps/s line (the only
    thing the viewer draws from the wall clock) reads the same in both runs."""

    def __init__(self) -> None:
        self._count = itertools.count()

    def perf_counter(self) -> float:
        return next(self._count) * 0.01


def live_frames(map_name: str, seed: int, params: dict, selected: int, tmp_path, monkeypatch):
    """Frames of the live run (reset state, then every step) and the log it wrote."""
    monkeypatch.setattr(viewer_module, "time", StepClock())
    arena = Arena(make_map(map_name, seed, params))
    arena.recorder = EpisodeRecorder()
    arena.reset(seed)
    viewer = Viewer()
    frames = [viewer.draw(arena, selected=selected)]
    for _ in range(STEPS):
        arena.step()
        frames.append(viewer.draw(arena, selected=selected))
    path = write_log(arena.recorder.finish(), tmp_path / f"{map_name}.parquet")
    return frames, read_log(path)


SCENES = [
    # goal seekers that touch at step 10 (the contact flashes), panel of robot 1
    ("circle_swap", 0, {"n": 2, "radius": 1.0, "agent": "goal"}, 1),
    # NAO robots among traffic: predictions, NAO regions, lanes
    ("roundabout", 4, {"predictor": "turn_rate"}, 1),
]


@pytest.mark.parametrize("scene", SCENES, ids=[s[0] for s in SCENES])
def test_replayed_frames_equal_the_live_frames(scene, tmp_path, monkeypatch):
    map_name, seed, params, selected = scene
    live, log = live_frames(map_name, seed, params, selected, tmp_path, monkeypatch)
    monkeypatch.setattr(viewer_module, "time", StepClock())
    replayer = Replayer(log)
    for step, frame in enumerate(live):
        replayed = replayer.frame(step, selected)
        assert replayed.shape == (FRAME_SIZE[1], FRAME_SIZE[0], 3)
        assert np.array_equal(replayed, frame), f"step {step}"
    if map_name == "circle_swap":
        assert log.contact_steps.tolist() == [10]
        red = np.all(live[10][:, :800] == (220, 20, 30), axis=-1).sum()
        assert red > 20  # the flashed contact is in the compared frames


@pytest.mark.slow
def test_a_frame_reached_by_a_jump_is_the_live_frame(tmp_path, monkeypatch):
    """After a jump (back and forth) the trails are rebuilt from the logged rows: pixel for
    pixel the live frame (headless frames carry no wall-clock line)."""
    live, log = live_frames("roundabout", 4, {"predictor": "turn_rate"}, 0, tmp_path, monkeypatch)
    replayer = Replayer(log)
    for step in (12, 3, 13, 0):
        frame = replayer.frame(step, 0)
        assert np.array_equal(frame, live[step]), f"step {step}"


def test_the_decision_view_shows_the_next_command(tmp_path, monkeypatch):
    _, log = live_frames(
        "circle_swap", 0, {"n": 2, "radius": 1.0, "agent": "goal"}, 0, tmp_path, monkeypatch
    )
    replayer = Replayer(log)
    replayer.frame(9, 0, decision=True)
    arena = replayer.arena
    assert arena.state.time == log.time[9]
    assert np.array_equal(arena.commanded, log.commanded[10])
    with pytest.raises(ValueError, match="last row"):
        arena.seek(log.n_steps - 1, decision=True)


@pytest.mark.slow
def test_cli_writes_a_frame_and_a_video(tmp_path, monkeypatch, capsys):
    live, log = live_frames(
        "circle_swap", 0, {"n": 2, "radius": 1.0, "agent": "goal"}, 1, tmp_path, monkeypatch
    )
    path = str(log.path)
    png = tmp_path / "frame.png"
    assert main(["replay", path, "--at", "0.5", "--robot", "swap1", "--png", str(png)]) == 0
    frame = iio.imread(png)
    expected = Replayer(log).frame(5, 1)
    assert np.array_equal(frame, expected)
    gif = tmp_path / "span.gif"
    assert (
        main(["replay", path, "--render", "gif", "--out", str(gif), "--from", "0.3", "--to", "0.8"])
        == 0
    )
    assert len(iio.mimread(gif)) == 6  # 0.3 .. 0.8 s at one frame per step
    assert f"wrote {gif}" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--png", "f.png"], "--at"),
        (["--at", "0.2", "--png", "f.png", "--render", "gif"], "drop --render"),
        (["--render", "gif"], "--out"),
        (["--render", "mp4", "--out", "x.gif"], ".mp4"),
        (["--out", "x.gif"], "--render gif|mp4"),
        (["--at", "99", "--png", "f.png"], "within the episode"),
        (["--robot", "nobody", "--at", "0", "--png", "f.png"], "robots: swap0, swap1"),
        ([], "cannot open a window"),
    ],
)
def test_replay_option_errors(argv, message, tmp_path, monkeypatch, capsys):
    _, log = live_frames(
        "circle_swap", 0, {"n": 2, "radius": 1.0, "agent": "goal"}, 0, tmp_path, monkeypatch
    )
    monkeypatch.chdir(tmp_path)
    assert main(["replay", str(log.path), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nao-arena: error: ") and message in err and err.count("\n") == 1


def test_the_window_jumps_to_the_next_contact_and_explains_it(tmp_path, monkeypatch):
    import pygame

    _, log = live_frames(
        "circle_swap", 0, {"n": 2, "radius": 1.0, "agent": "goal"}, 0, tmp_path, monkeypatch
    )
    asked = []

    def explain(number):
        asked.append(number)
        return "text", np.zeros((90, 160, 3), dtype=np.uint8)

    def press(*keys):
        pygame.display.init()  # the window of the last play closed it
        for key, char in keys:
            pygame.event.post(pygame.event.Event(pygame.KEYDOWN, key=key, unicode=char))

    quiet = open(os.devnull, "w")
    press((pygame.K_n, "n"))
    assert play(log, explain=explain, max_frames=3, out=quiet) == 10  # the contact's row
    press((pygame.K_e, "e"))
    assert play(log, explain=explain, max_frames=2, out=quiet) == 9  # the step before it
    assert asked == [1]
    press((pygame.K_0, "0"), (pygame.K_PERIOD, "."), (pygame.K_4, "4"), (pygame.K_RETURN, "\r"))
    assert play(log, max_frames=2, out=quiet) == 4  # typed 0.4 s
    press((pygame.K_END, ""), (pygame.K_LEFT, ""), (pygame.K_q, "q"))
    assert play(log, max_frames=5, out=quiet) == log.n_steps - 2
    quiet.close()
