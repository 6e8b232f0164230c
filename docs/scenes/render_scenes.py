"""Render the pictures of the walled scenes (README.md, docs/results/scenes.md): the frame
at a given time of a ``nao`` episode (seed 0) of each scene, 1000 x 600 px, headless.

    python docs/scenes/render_scenes.py            # writes docs/scenes/<scene>.png
"""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")

import numpy as np  # noqa: E402
import pygame  # noqa: E402

from nao_arena.arena import Arena  # noqa: E402
from nao_arena.maps import load_map  # noqa: E402
from nao_arena.render import Viewer, ViewerOptions  # noqa: E402

FRAMES = {"doorway": 4.0, "intersection": 5.0, "warehouse_aisles": 5.0, "pillar_corridor": 4.0}
"""Scene -> the simulated time (s) of its picture."""


def render(name: str, at: float, out: Path) -> None:
    """Write the frame at ``at`` s of scene ``name`` (seed 0) to ``out`` (PNG)."""
    arena = Arena(load_map(name))
    arena.reset(0)
    viewer = Viewer(ViewerOptions(size=(1000, 600)))
    while arena.time < at - 1e-9:
        arena.step()
        viewer.track(arena)
    frame = np.asarray(viewer.draw(arena))
    pygame.image.save(pygame.surfarray.make_surface(frame.transpose(1, 0, 2)), str(out))


if __name__ == "__main__":
    here = Path(__file__).resolve().parent
    for scene, t in FRAMES.items():
        render(scene, t, here / f"{scene}.png")
        print(here / f"{scene}.png")
