"""The viewer's settings and what a frame showed: :class:`ViewerOptions`, the window's
:data:`KEYS`, and :class:`FrameInfo` with its legend entries and the panel's regions cut
at its edge (see :mod:`nao_arena.render.viewer`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from nao_arena.render.colours import Colour

if TYPE_CHECKING:
    from typing import TypeAlias

    from nao_arena.arena import Arena
    from nao_arena.render.replay_arena import ReplayArena

    ShownArena: TypeAlias = Arena | ReplayArena  # a live arena or a recorded episode

__all__ = ["FRAME_SIZE", "KEYS", "EdgeRun", "FrameInfo", "LegendEntry", "ViewerOptions"]

FRAME_SIZE: tuple[int, int] = (1200, 800)
"""Default frame size (width, height) px."""

KEYS: tuple[tuple[str, str], ...] = (
    ("Tab", "next robot"),
    ("Shift+Tab", "previous robot"),
    ("H or ?", "hide or show this line"),
)
"""Keys of the viewer's window (``human=True``): (key, what it does)."""


@dataclass(frozen=True)
class LegendEntry:
    """One legend item: how its symbol is drawn (``disc``, ``ring``, ``goal``, ``dotted``,
    ``line``, ``dashed``, ``arrow``, ``zero``, ``circle``, ``swatch``, ``cut``), its
    label, and the colours the symbol shows (several: one per neighbour)."""

    symbol: str
    label: str
    colours: tuple[Colour, ...] = ((0, 0, 0),)
    section: str = "world"


@dataclass(frozen=True)
class EdgeRun:
    """A region of the acceleration panel cut by the panel's edge: ``edge`` (top, bottom,
    left, right), grid cells [start, stop) along it (left to right, top to bottom), and
    the region's label (-2: walls, j >= 0: neighbour j)."""

    edge: str
    start: int
    stop: int
    label: int


@dataclass
class FrameInfo:
    """What the last frame showed: texts drawn, legend entries, regions cut at the panel's
    edge, the accelerations drawn as rings (too short for an arrow) and the scale bar's
    box (x, y, width, height) px."""

    texts: list[str] = field(default_factory=list)
    legend: list[LegendEntry] = field(default_factory=list)
    cut_edges: list[EdgeRun] = field(default_factory=list)
    short_arrows: list[str] = field(default_factory=list)
    scale_box: tuple[int, int, int, int] | None = None


@dataclass(frozen=True)
class ViewerOptions:
    """Viewer settings: size (width, height) px; trail_seconds, flash_seconds (s of
    simulated time); follow: side (m) of a view that follows the selected robot (None:
    automatic for long maps, 0: never); panel_grid: grid points per axis of the
    acceleration panel; panel_extent: half-width of the panel in units of a_max."""

    size: tuple[int, int] = FRAME_SIZE
    trail_seconds: float = 6.0
    flash_seconds: float = 0.8
    follow: float | None = None
    panel_grid: int = 101
    panel_extent: float = 1.3
    predicted_paths: bool = True
