"""Seeing the arena: a pygame viewer (window or headless frames) and recordings.

- :class:`Viewer` draws an :class:`~nao_arena.arena.Arena` to frames of
  :data:`FRAME_SIZE` (1200 x 800 px by default; see :mod:`.viewer` for what
  is drawn), in a window (``human=True``) or off-screen.
- :class:`Recorder` and :func:`record_episode` write GIF or MP4 files
  atomically (see :mod:`.recording`).
"""

from nao_arena.render.recording import Recorder, record_episode
from nao_arena.render.viewer import AGENT_COLOURS, FRAME_SIZE, Viewer, ViewerOptions

__all__ = ["AGENT_COLOURS", "FRAME_SIZE", "Recorder", "Viewer", "ViewerOptions", "record_episode"]
