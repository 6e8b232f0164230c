"""Episode recordings: GIF or MP4 via imageio, written atomically.

:class:`Recorder` collects frames and writes them to a temporary file in
the destination's folder, which replaces the destination
(:func:`nao_arena.atomic.replace_synced`) only when the recording is
complete. :func:`record_episode` plays an episode of an
:class:`~nao_arena.arena.Arena` or of a nao_arena env and records it (or shows it in a window).

Frame rate: the video's clock is simulated time. By default fps = 1 / dt
(one frame per control step); with ``fps`` given, frame k shows the state
at the latest step with time <= k / fps, so a lower fps subsamples the
steps and a higher one repeats frames; the video always plays in real time.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.atomic import replace_synced, temporary_sibling
from nao_arena.render.viewer import Viewer, ViewerOptions

__all__ = ["Recorder", "record_episode"]

_FORMATS = (".gif", ".mp4")


class Recorder:
    """Frames -> a GIF or MP4 file (by the path's suffix) at ``fps`` frames per second.

    Use as a context manager, or call :meth:`add` then :meth:`close`; the
    file appears (atomically) at close. On an exception inside the context the
    partial file is removed and the destination left untouched.
    """

    def __init__(self, path: str | Path, fps: float) -> None:
        self.path = Path(path)
        suffix = self.path.suffix.lower()
        if suffix not in _FORMATS:
            raise ValueError(f"{self.path}: expected a file name ending in .gif or .mp4")
        if not fps > 0:
            raise ValueError(f"fps: expected a positive number, got {fps}")
        self.fps = float(fps)
        self.frames = 0
        fd, tmp = temporary_sibling(self.path, suffix=f".tmp{suffix}")
        os.close(fd)
        self._tmp = Path(tmp)
        self._writer: Any = None
        self._suffix = suffix

    def _open(self) -> Any:
        import imageio.v2 as iio

        if self._suffix == ".gif":
            # the pillow plugin takes the frame duration in ms; loop forever
            return iio.get_writer(
                self._tmp, format="GIF", mode="I", duration=1000.0 / self.fps, loop=0
            )
        return iio.get_writer(
            self._tmp,
            format="FFMPEG",
            mode="I",
            fps=self.fps,
            codec="libx264",
            quality=7,
            macro_block_size=8,
            ffmpeg_log_level="error",
        )

    def add(self, frame: NDArray[np.uint8]) -> None:
        """Append one frame (H, W, 3) uint8."""
        if self._writer is None:
            self._writer = self._open()
        self._writer.append_data(np.asarray(frame, dtype=np.uint8))
        self.frames += 1

    def close(self) -> Path:
        """Finish the file and move it into place; returns its path."""
        if self._writer is None:
            self._tmp.unlink(missing_ok=True)
            raise ValueError(f"{self.path}: no frames were recorded")
        self._writer.close()
        self._writer = None
        replace_synced(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the partial recording."""
        if self._writer is not None:
            try:
                self._writer.close()
            finally:
                self._writer = None
        self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


Policy = Callable[[Mapping[str, NDArray[np.float32]]], Mapping[str, Any]]


def record_episode(
    source: Any,
    path: str | Path | None,
    fps: float | None = None,
    max_steps: int | None = None,
    *,
    seed: int | None = None,
    policy: Policy | None = None,
    selected: int | str | None = None,
    options: ViewerOptions | None = None,
) -> Path | None:
    """Play one episode and record it to ``path`` (.gif or .mp4); None: show it in a window.

    source: an :class:`~nao_arena.arena.Arena` (stepped with its own agents) or a
    nao_arena env (parallel or AEC; stepped with ``policy(observations) ->
    actions``, default zero actions, until no agent is left). The episode
    continues from the current state if the source has been reset, else it is
    reset with ``seed``. Stops at the end of the episode or after ``max_steps``
    steps. fps: frames per second of simulated time (default 1 / dt). selected:
    robot (index or name) of the acceleration panel. Returns the written path.
    """
    env: Any = getattr(source, "unwrapped", None)  # a nao_arena env, duck-typed
    is_env = env is not None and hasattr(env, "arena") and hasattr(env, "possible_agents")
    arena = env.arena if is_env else source
    if is_env:
        if arena.state is None or arena.stats is None or seed is not None:
            obs, _ = env.reset(seed=seed)
        else:
            obs = {}
        controlled = list(env.controlled_robots)
    else:
        if arena.stats is None:
            arena.reset(seed)
        controlled = []
    names = [r.name for r in arena.robots]
    if isinstance(selected, str):
        if selected not in names:
            raise ValueError(f"selected: unknown robot {selected!r} (robots: {', '.join(names)})")
        sel = names.index(selected)
    elif selected is None:
        sel = controlled[0] if controlled else 0
    else:
        sel = int(selected)
    dt = arena.world.dt
    rate = float(fps) if fps is not None else 1.0 / dt
    viewer = Viewer(options, human=path is None)
    recorder = Recorder(path, rate) if path is not None else None
    clock = None
    if path is None:
        import pygame

        clock = pygame.time.Clock()
    next_frame = arena.time
    steps = 0

    def emit() -> None:
        nonlocal next_frame
        frame = None
        while next_frame <= arena.time + 1e-9:
            if frame is None:
                frame = viewer.draw(arena, selected=sel, controlled=controlled)
            if recorder is not None:
                recorder.add(frame)
            elif clock is not None:
                clock.tick(rate)
            next_frame += 1.0 / rate

    try:
        emit()
        while max_steps is None or steps < max_steps:
            if is_env:
                if not env.agents:
                    break
                if policy is None:
                    actions = {a: np.zeros(2, dtype=np.float32) for a in env.agents}
                else:
                    if not obs:
                        obs = env.observations()
                    actions = dict(policy(obs))
                obs = env.step(actions)[0]
            else:
                if arena.done:
                    break
                arena.step()
            steps += 1
            emit()
    except BaseException:
        if recorder is not None:
            recorder.abort()
        viewer.close()
        raise
    viewer.close()
    return recorder.close() if recorder is not None else None
