"""Drawing an arena with pygame: the world view and the acceleration-space panel.

A frame is ``ViewerOptions.size`` pixels (default 1200 x 800, width x
height): on the left a square world view (height x height px), on the
right a side panel (the rest of the width) with the HUD, the selected
robot's acceleration space and a legend.

World view (world frame, x right, y up, metres): walls (dark), traffic
lanes (light grey bands as wide as their vehicles, dashed centrelines),
goals (rings with a cross, in the robot's colour), trails of the robots
(the last ``trail_seconds`` s), robots coloured by agent type (externally
controlled robots in red), traffic in brown, the selected robot ringed in
black with a line to its goal; the predicted paths of its neighbours
(the selected robot's own predictor and horizon when its agent has them,
else turn-rate predictions over 3 s), one colour per neighbour, and its
own path under its last command (dashed); contacts flashed as red rings
for ``flash_seconds`` s of simulated time. Maps much longer than wide are
followed: the view is a square of ``follow`` m (auto: 60 m or the map's
short side, at least 40 m) around the selected robot, looking ahead towards its
goal.

Acceleration panel (m/s^2, world axes, origin at the centre): the NAO of
every neighbour of the selected robot that some acceleration within the
panel can reach, as the set of constant accelerations whose exact
clearance (:func:`nao_arena.geometry.path_clearance`, radii grown by the
robot's radius and its agent's margin) is negative over the horizon,
evaluated on a grid and coloured like the neighbour's path; the walls'
region (grey): the accelerations whose path comes closer to a wall segment
than its grown half-thickness (the exact minimum over the horizon,
:func:`~nao_arena.geometry._kernel.segment.segment_min_distance`); each grid
point shows the obstacle of least clearance (labels compiled in
:mod:`nao_arena.render._panel_kernel`); the acceleration-limit circle
|a| = a_max; the desired (goal-seeking) acceleration as a green arrow and the
last commanded one as a black arrow.

Every symbol is explained in the panel's legend (:meth:`Viewer.legend_entries`):
a neighbour's predicted path, its position at the horizon (hollow ring) and
its NAO share one colour; trails are dotted; the walls' region is grey; a
region that continues beyond the panel's edge gets a dashed band outside
the frame; an acceleration too short for an arrow (e.g. none needed at
v_max) is drawn as a ring.

Headless: ``Viewer(human=False)`` draws on an off-screen surface and needs
no display; its frames depend on the simulation only (no wall-clock rate).
``human=True`` opens a window (``SDL_VIDEODRIVER=dummy`` is set first when
there is no display, so that it never fails on a server) that shows the
steps per second and the keys (:data:`KEYS`): Tab / Shift+Tab cycle the
selected robot, H or ? hides / shows the keys line.
"""

from __future__ import annotations

import math
import os
import time
from collections import deque
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, cast, runtime_checkable

import numpy as np
from numpy.typing import NDArray

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame  # noqa: E402

from nao_arena.agent import PanelAgent, ShowsPanel  # noqa: E402
from nao_arena.agents.goal import goal_seeking_accel  # noqa: E402
from nao_arena.geometry.clearance import PiecewisePath  # noqa: E402
from nao_arena.geometry.kernels import (
    piece_sweep,  # noqa: E402
    relevant_obstacles,  # noqa: E402
)
from nao_arena.maps import PolygonWall, SegmentWall  # noqa: E402
from nao_arena.obstacles import obstacle_paths, relative_walls  # noqa: E402
from nao_arena.predictors import get_predictor  # noqa: E402
from nao_arena.render._panel_kernel import panel_labels  # noqa: E402
from nao_arena.render.colours import (  # noqa: E402
    AGENT_COLOURS,
    BACKGROUND,
    CONTACT_COLOUR,
    GOOD_COLOUR,
    LANE_COLOUR,
    PALETTE,
    PANEL_BACKGROUND,
    TEXT_COLOUR,
    WALL_COLOUR,
    WALL_REGION_COLOUR,
    Colour,
    agent_colour,
    body_colour,
    mix,
)
from nao_arena.sensing import Observation  # noqa: E402
from nao_arena.traffic import CircleLane, PolylineLane  # noqa: E402
from nao_arena.world import speed_limit_time  # noqa: E402

if TYPE_CHECKING:
    from typing import TypeAlias

    from nao_arena.arena import Arena
    from nao_arena.render.replay import ReplayArena

    ShownArena: TypeAlias = Arena | ReplayArena  # a live arena or a recorded episode

__all__ = [
    "AGENT_COLOURS",
    "FRAME_SIZE",
    "KEYS",
    "EdgeRun",
    "FrameInfo",
    "LegendEntry",
    "PanelAgent",
    "PanelSource",
    "Viewer",
    "ViewerOptions",
    "edge_runs",
    "panel_agent",
]

FRAME_SIZE: tuple[int, int] = (1200, 800)
"""Default frame size (width, height) px."""

_MIN_ARROW_PX = 10.0
"""Accelerations shorter than this on the panel (px) are drawn as rings, not arrows."""

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


@runtime_checkable
class PanelSource(Protocol):
    """An arena that answers itself what the panel shows of each robot's agent (a replay,
    which has no agents)."""

    def panel_agent(self, k: int) -> PanelAgent: ...


def panel_agent(arena: Arena | PanelSource, k: int) -> PanelAgent:
    """What the panel shows of robot k's agent: ``arena.panel_agent(k)`` where the arena
    answers it itself (:class:`PanelSource`), else the agent's ``panel()``
    (:class:`~nao_arena.agent.ShowsPanel`; the defaults for an agent without one)."""
    if isinstance(arena, PanelSource):
        return arena.panel_agent(k)
    agent = arena.agents[k] if k < len(arena.agents) else None
    return agent.panel() if isinstance(agent, ShowsPanel) else PanelAgent()


def _own_paths_xy(
    v: NDArray[np.float64], accels: NDArray[np.float64], v_max: float, times: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Displacements under constant accelerations (K, 2), speed saturating at v_max (the
    world's model, see :func:`nao_arena.world.speed_limit_time`): x and y (K, T) m, each
    contiguous (one component at a time, with the arithmetic of :func:`_own_paths`)."""
    vv = np.broadcast_to(v, accels.shape)
    tau = speed_limit_time(vv, accels, np.full(len(accels), v_max))
    t = np.minimum(times[None, :], tau[:, None])
    v_sat = v + accels * np.where(np.isfinite(tau), tau, 0.0)[:, None]
    extra = np.maximum(times[None, :] - tau[:, None], 0.0)
    half = 0.5 * accels
    out = []
    for c in (0, 1):
        x = v[c] * t
        tail = half[:, c, None] * t
        tail *= t
        x += tail
        tail = v_sat[:, c, None] * extra
        x += tail
        out.append(x)
    return out[0], out[1]


def _own_paths(
    v: NDArray[np.float64], accels: NDArray[np.float64], v_max: float, times: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Displacements (K, T, 2) m under constant accelerations (K, 2), speed saturating at
    v_max (the world's model, see :func:`nao_arena.world.speed_limit_time`)."""
    return np.stack(_own_paths_xy(v, accels, v_max, times), axis=-1)


def label_position(
    centre: tuple[int, int], radius: int, size: tuple[int, int], bounds: tuple[int, int]
) -> tuple[int, int]:
    """Where a robot's label (``size`` px) goes: up and to the right of its disc (centre,
    radius px), or to its left or below where that would leave the view (``bounds``
    px), so that the label is never cut."""
    w, h = size
    x, y = centre[0] + radius + 5, centre[1] - radius - 14
    if x + w > bounds[0]:
        x = centre[0] - radius - 5 - w
    if y < 0:
        y = centre[1] + radius + 2
    return max(0, min(x, bounds[0] - w)), max(0, min(y, bounds[1] - h))


def edge_runs(labels: NDArray[np.int_]) -> list[EdgeRun]:
    """Runs of region cells (label != -1) along the four edges of a panel's label grid
    (g, g): row 0 is the top, column 0 the left edge."""
    runs = []
    for edge, line in (
        ("top", labels[0]),
        ("bottom", labels[-1]),
        ("left", labels[:, 0]),
        ("right", labels[:, -1]),
    ):
        k = 0
        while k < len(line):
            if line[k] == -1:
                k += 1
                continue
            start = k
            while k < len(line) and line[k] == line[start]:
                k += 1
            runs.append(EdgeRun(edge, start, k, int(line[start])))
    return runs


def _trail_colour(c: Colour) -> Colour:
    """A robot's trail: its colour darkened towards grey (dotted, unlike predicted paths)."""
    return mix(c, 0.6, (165, 165, 165))


class Viewer:
    """Draws arenas to frames (H, W, 3) uint8; optionally shows them in a window."""

    def __init__(self, options: ViewerOptions | None = None, human: bool = False) -> None:
        self.options = options or ViewerOptions()
        self.human = human
        w, h = self.options.size
        if w < h + 200 or h < 400:
            raise ValueError(
                f"size: expected width >= height + 200 and height >= 400 px, got {w}x{h}"
            )
        if not pygame.font.get_init():
            pygame.font.init()
        self._window: Any = None
        if human:
            if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
                os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
            pygame.display.init()
            self._window = pygame.display.set_mode((w, h))
            pygame.display.set_caption("nao_arena")
        self.surface = pygame.Surface((w, h))
        self._font = pygame.font.Font(None, 22)
        self._small = pygame.font.Font(None, 18)
        self._big = pygame.font.Font(None, 28)
        self.selected_offset = 0
        self._episode_key: Any = None
        self._trails: list[deque[NDArray[np.float64]]] = []
        self._last_time = -1.0
        self._contacts_seen = 0
        self._flashes: list[tuple[float, int, int, str]] = []
        self._rate = 0.0
        self._wall_clock: tuple[float, int] | None = None
        self._steps = 0
        self.show_keys = True
        self.info = FrameInfo()
        self._horizon = 3.0

    # ------------------------------------------------------------------ public

    def close(self) -> None:
        """Close the window (if any)."""
        if self._window is not None:
            pygame.display.quit()
            self._window = None

    def draw(
        self,
        arena: ShownArena,
        selected: int = 0,
        controlled: Sequence[int] = (),
        result: Any = None,
    ) -> NDArray[np.uint8]:
        """Draw the arena's current state; returns the frame (H, W, 3) uint8.

        selected: robot index (robot order) of the acceleration panel;
        controlled: robot indices driven from outside (coloured as such);
        result: unused beyond API symmetry with the env (contacts are read from
        the arena's statistics).
        """
        assert arena.state is not None, "reset the arena first"
        n_robots = len(arena.robots)
        if self.human:
            self._events(n_robots)
        selected = (int(selected) + self.selected_offset) % max(n_robots, 1)
        self.info = FrameInfo()
        self._track(arena)
        surf = self.surface
        surf.fill(BACKGROUND)
        w, h = self.options.size
        view = pygame.Rect(0, 0, h, h)
        panel = pygame.Rect(h, 0, w - h, h)
        transform = self._transform(arena, selected, view)
        surf.set_clip(view)
        obs = arena.observations()[selected] if n_robots else None
        self._draw_world(arena, transform, selected, set(controlled), obs)
        surf.set_clip(None)
        pygame.draw.rect(surf, PANEL_BACKGROUND, panel)
        pygame.draw.line(surf, (180, 180, 180), panel.topleft, panel.bottomleft, 2)
        self._draw_panel(arena, panel, selected, set(controlled), obs)
        if self._window is not None:
            self._window.blit(surf, (0, 0))
            pygame.display.flip()
        rgb = bytearray(pygame.image.tobytes(surf, "RGB"))  # writable, rows top to bottom
        return np.frombuffer(rgb, dtype=np.uint8).reshape(h, w, 3)

    def forget(self) -> None:
        """Drop the trails and contact flashes: the next draw starts afresh (a replay
        that jumps to another time)."""
        self._episode_key = None

    def track(self, arena: ShownArena) -> None:
        """Take in the arena's current state without drawing it (trails, contact flashes)."""
        self._track(arena)

    # ------------------------------------------------------------------ state

    def _events(self, n_robots: int) -> None:
        """The window's keys (:data:`KEYS`)."""
        for event in pygame.event.get():
            if event.type != pygame.KEYDOWN:
                continue
            if event.key == pygame.K_TAB:
                step = -1 if getattr(event, "mod", 0) & pygame.KMOD_SHIFT else 1
                self.selected_offset = (self.selected_offset + step) % max(n_robots, 1)
            elif event.key == pygame.K_h or getattr(event, "unicode", "") == "?":
                self.show_keys = not self.show_keys

    def _track(self, arena: ShownArena) -> None:
        """Trails, contact flashes and the step rate, reset on a new episode."""
        state = arena.state
        assert state is not None and arena.stats is not None  # a reset arena
        key = (id(arena), id(arena.stats))
        if key != self._episode_key or state.time < self._last_time:
            self._episode_key = key
            maxlen = max(2, int(self.options.trail_seconds / arena.world.dt) + 1)
            self._trails = [deque(maxlen=maxlen) for _ in range(arena.world.n)]
            self._contacts_seen = 0
            self._flashes = []
            self._wall_clock = None
            self._rate = 0.0
            self._last_time = -1.0
        if state.time > self._last_time:
            for trail, p in zip(self._trails, state.positions, strict=True):
                trail.append(p.copy())
            self._last_time = state.time
        contacts = arena.stats.contacts
        for ev in contacts[self._contacts_seen :]:
            self._flashes.append((ev.time, ev.a, ev.b, ev.kind_b))
        self._contacts_seen = len(contacts)
        self._flashes = [
            f for f in self._flashes if state.time - f[0] <= self.options.flash_seconds
        ]
        steps = arena.stats.steps
        now = time.perf_counter()
        if self._wall_clock is not None and steps > self._wall_clock[1]:
            dt = now - self._wall_clock[0]
            rate = (steps - self._wall_clock[1]) / max(dt, 1e-9)
            self._rate = rate if self._rate == 0 else 0.8 * self._rate + 0.2 * rate
        self._wall_clock = (now, steps)
        self._steps = steps

    # ------------------------------------------------------------------ world view

    def _transform(self, arena: ShownArena, selected: int, view: pygame.Rect) -> tuple[float, ...]:
        """(scale px/m, x0, y0) of the world -> pixel map x_px = (x - x0) s, y_px = (y0 - y) s."""
        (bx0, by0), (bx1, by1) = arena.spec.bounds.min, arena.spec.bounds.max
        bw, bh = bx1 - bx0, by1 - by0
        follow = self.options.follow
        if follow is None:
            follow = max(min(bw, bh), 40.0) if max(bw, bh) > 2.5 * min(bw, bh) else 0.0
        if follow and follow < max(bw, bh):
            side = float(follow)
            c = np.array([(bx0 + bx1) / 2, (by0 + by1) / 2])
            if len(arena.robots):
                assert arena.state is not None  # draw() checked it
                body = arena.robot_ids[selected]
                to_goal = arena.goals[selected] - arena.state.positions[body]
                dist = float(np.hypot(*to_goal))
                ahead = 0.25 * side * to_goal / dist if dist > 1e-6 else np.zeros(2)
                c = arena.state.positions[body] + ahead
            cx = (
                float(np.clip(c[0], bx0 + side / 2, bx1 - side / 2))
                if bw > side
                else (bx0 + bx1) / 2
            )
            cy = (
                float(np.clip(c[1], by0 + side / 2, by1 - side / 2))
                if bh > side
                else (by0 + by1) / 2
            )
            x0, x1, y0, y1 = cx - side / 2, cx + side / 2, cy - side / 2, cy + side / 2
        else:
            pad = 0.03 * max(bw, bh)
            x0, x1, y0, y1 = bx0 - pad, bx1 + pad, by0 - pad, by1 + pad
        s = min(view.width / (x1 - x0), view.height / (y1 - y0))
        ox = (x0 + x1) / 2 - view.width / (2 * s)
        oy = (y0 + y1) / 2 + view.height / (2 * s)
        return s, ox, oy

    @staticmethod
    def _px(tr: tuple[float, ...], p: NDArray[np.float64]) -> NDArray[np.float64]:
        s, ox, oy = tr
        p = np.asarray(p, dtype=float)
        return np.stack([(p[..., 0] - ox) * s, (oy - p[..., 1]) * s], axis=-1)

    def _pt(self, tr: tuple[float, ...], p: NDArray[np.float64]) -> tuple[int, int]:
        q = self._px(tr, p)
        return int(round(q[0])), int(round(q[1]))

    def _draw_world(
        self,
        arena: ShownArena,
        tr: tuple[float, ...],
        selected: int,
        controlled: set[int],
        obs: Observation | None,
    ) -> None:
        surf = self.surface
        s = tr[0]
        state = arena.state
        assert state is not None  # draw() checked it
        spec = arena.spec
        # bounds
        (bx0, by0), (bx1, by1) = spec.bounds.min, spec.bounds.max
        corners = self._px(tr, np.array([[bx0, by1], [bx1, by0]]))
        rect = pygame.Rect(
            int(corners[0, 0]),
            int(corners[0, 1]),
            int(corners[1, 0] - corners[0, 0]),
            int(corners[1, 1] - corners[0, 1]),
        )
        pygame.draw.rect(surf, (255, 255, 255), rect)
        pygame.draw.rect(surf, (200, 200, 200), rect, 1)
        # lanes
        for grp, lane in zip(spec.traffic, arena.traffic.lanes, strict=True):
            width = max(2, int(2 * grp.radius * s))
            if isinstance(lane, CircleLane):
                c = self._pt(tr, np.asarray(lane.center))
                r = int(lane.radius * s)
                pygame.draw.circle(surf, LANE_COLOUR, c, r + width // 2, width)
                n = max(24, int(2 * math.pi * lane.radius * s / 12))
                ang = np.linspace(0, 2 * math.pi, n, endpoint=False)
                pts = np.asarray(lane.center) + lane.radius * np.stack(
                    [np.cos(ang), np.sin(ang)], 1
                )
                self._dashed(self._px(tr, pts), (190, 190, 186), closed=True)
            else:
                assert isinstance(lane, PolylineLane)  # a map's lanes: circles or polylines
                pts = np.asarray(lane.points, float)
                if lane.closed:
                    pts = np.vstack([pts, pts[:1]])
                q = self._px(tr, pts)
                pygame.draw.lines(surf, LANE_COLOUR, False, q.tolist(), width)
                for p in q:
                    pygame.draw.circle(surf, LANE_COLOUR, p.tolist(), width // 2)
                self._dashed(q, (190, 190, 186), closed=False)
        # walls
        for wall in spec.walls:
            if isinstance(wall, SegmentWall):
                self._capsule(tr, np.array([wall.a, wall.b]), wall.thickness / 2, WALL_COLOUR)
            elif isinstance(wall, PolygonWall):
                pygame.draw.polygon(surf, WALL_COLOUR, self._px(tr, np.array(wall.points)).tolist())
        for end_a, end_b in spec.bound_wall_segments():
            self._capsule(tr, np.array([end_a, end_b]), spec.bounds.wall_thickness / 2, WALL_COLOUR)
        colours = self._robot_colours(arena, controlled)
        # goals
        for k, goal in enumerate(arena.goals):
            g = self._pt(tr, goal)
            r = max(4, int(arena.world.radii[arena.robot_ids[k]] * s * 0.6))
            pygame.draw.circle(surf, mix(colours[k], 0.8), g, r, 2)
            pygame.draw.line(surf, mix(colours[k], 0.8), (g[0] - r, g[1]), (g[0] + r, g[1]), 1)
            pygame.draw.line(surf, mix(colours[k], 0.8), (g[0], g[1] - r), (g[0], g[1] + r), 1)
        # trails (dotted, unlike the solid predicted paths)
        for k, body in enumerate(arena.robot_ids):
            trail = self._trails[int(body)]
            if len(trail) >= 2:
                self._dotted(self._px(tr, np.array(trail)), _trail_colour(colours[k]))
        # selected robot: line to goal, predicted paths
        if obs is not None:
            body = int(arena.robot_ids[selected])
            pygame.draw.line(
                surf,
                (170, 170, 170),
                self._pt(tr, state.positions[body]),
                self._pt(tr, arena.goals[selected]),
                1,
            )
            if self.options.predicted_paths:
                self._draw_predictions(arena, tr, selected, obs)
        # bodies
        flashing = set()
        for _, a, b, kind_b in self._flashes:
            flashing.add(a)
            if kind_b != "wall":
                flashing.add(b)
        robot_of = {int(b): k for k, b in enumerate(arena.robot_ids)}
        for i in range(arena.world.n):
            p = self._pt(tr, state.positions[i])
            r = max(2, int(round(state.radii[i] * s)))
            if i in robot_of:
                col = colours[robot_of[i]]
            else:
                col = body_colour(state.kinds[i])
            pygame.draw.circle(surf, col, p, r)
            pygame.draw.circle(surf, mix(col, 0.6, (0, 0, 0)), p, r, 1)
            v = state.velocities[i]
            sp = float(np.hypot(*v))
            if sp > 1e-6 and r >= 4:
                tip = state.positions[i] + v / sp * state.radii[i]
                pygame.draw.line(surf, (255, 255, 255), p, self._pt(tr, tip), 2)
            if i in flashing:
                pygame.draw.circle(surf, CONTACT_COLOUR, p, r + 4, 3)
        # contact flashes
        for t0, a, b, kind_b in self._flashes:
            age = (state.time - t0) / self.options.flash_seconds
            if kind_b == "wall":
                where = state.positions[a]
            else:
                where = 0.5 * (state.positions[a] + state.positions[b])
            rr = int(8 + 30 * age)
            pygame.draw.circle(
                surf, mix(CONTACT_COLOUR, 1.0 - 0.6 * age), self._pt(tr, where), rr, 3
            )
        if obs is not None:
            body = int(arena.robot_ids[selected])
            p = self._pt(tr, state.positions[body])
            r = max(3, int(round(state.radii[body] * s)))
            pygame.draw.circle(surf, (0, 0, 0), p, r + 3, 2)
            label = self._small.render(
                arena.robots[selected].name or f"robot{selected}", True, TEXT_COLOUR
            )
            surf.blit(label, label_position(p, r, label.get_size(), surf.get_size()))
        # scale bar on a light box, readable over walls and lanes
        bar_m = self._nice(80 / s)
        bar_px = int(bar_m * s)
        label = self._small.render(f"{bar_m:g} m", True, TEXT_COLOUR)
        x0, y0 = 16, self.options.size[1] - 20
        box = pygame.Rect(
            x0 - 6,
            y0 - label.get_height() - 6,
            max(bar_px, label.get_width()) + 12,
            label.get_height() + 12,
        )
        backing = pygame.Surface(box.size, pygame.SRCALPHA)
        backing.fill((255, 255, 255, 225))
        surf.blit(backing, box.topleft)
        pygame.draw.rect(surf, (150, 150, 150), box, 1)
        pygame.draw.line(surf, TEXT_COLOUR, (x0, y0), (x0 + bar_px, y0), 3)
        surf.blit(label, (x0, y0 - label.get_height() - 2))
        self.info.texts.append(f"{bar_m:g} m")
        self.info.scale_box = (box.x, box.y, box.width, box.height)

    @staticmethod
    def _nice(x: float) -> float:
        e = 10 ** math.floor(math.log10(max(x, 1e-9)))
        for m in (1, 2, 5, 10):
            if m * e >= x:
                return m * e
        return 10 * e

    def _dotted(self, q: NDArray[np.float64], colour: Colour, spacing: float = 6.0) -> None:
        """Dots every ``spacing`` px along the polyline q (n, 2) px."""
        seg = np.hypot(*np.diff(q, axis=0).T)
        arc = np.concatenate([[0.0], np.cumsum(seg)])
        if arc[-1] <= 0:
            return
        at = np.arange(0.0, arc[-1], spacing)
        xs = np.interp(at, arc, q[:, 0])
        ys = np.interp(at, arc, q[:, 1])
        for x, y in zip(xs, ys, strict=True):
            pygame.draw.circle(self.surface, colour, (int(round(x)), int(round(y))), 2)

    def _dashed(self, q: NDArray[np.float64], colour: Colour, closed: bool) -> None:
        pts = np.vstack([q, q[:1]]) if closed else q
        for k in range(0, len(pts) - 1, 2):
            pygame.draw.line(self.surface, colour, pts[k].tolist(), pts[k + 1].tolist(), 1)

    def _capsule(
        self, tr: tuple[float, ...], seg: NDArray[np.float64], half: float, colour: Colour
    ) -> None:
        q = self._px(tr, seg)
        width = max(2, int(round(2 * half * tr[0])))
        pygame.draw.line(self.surface, colour, q[0].tolist(), q[1].tolist(), width)
        for p in q:
            pygame.draw.circle(self.surface, colour, p.tolist(), width / 2)

    def _robot_colours(self, arena: ShownArena, controlled: set[int]) -> list[Colour]:
        return [
            AGENT_COLOURS["controlled"] if k in controlled else agent_colour(name)
            for k, name in enumerate(arena.agent_labels)
        ]

    # ------------------------------------------------------------------ predictions

    def _predictions(
        self, arena: ShownArena, selected: int, obs: Observation
    ) -> tuple[
        NDArray[np.float64],
        NDArray[np.float64],
        PiecewisePath,
        tuple[NDArray[np.float64], NDArray[np.float64]] | None,
    ]:
        """(times (T,) s, predicted neighbour centres (n, T, 2) world m, their paths
        robot-relative with grown radii, the nearby walls (robot-relative segments (W, 2, 2)
        m, grown half-thicknesses (W,) m) or None)."""
        agent = panel_agent(arena, selected)
        nb = obs.neighbours
        times, predict = agent.times, agent.predict
        if times is None or predict is None:
            times = np.linspace(0.0, 3.0, 31)
            predict = get_predictor("turn_rate")
        grow = obs.radius + agent.margin
        centres = predict(times, nb) if len(nb) else np.zeros((0, len(times), 2))
        # the neighbours as the agent sees them (its radius cut included)
        path = obstacle_paths(times, centres, nb.radii + grow, obs.position)
        walls = None
        if len(obs.walls):
            # the walls within reach as the agent sees them (its radius cut included)
            h = float(times[-1])
            segs, grown = relative_walls(
                obs.walls,
                obs.wall_radius + grow,
                obs.position,
                obs.v_max * h + 0.5 * obs.a_max * h * h,
            )
            if len(segs):
                walls = (segs, grown)
        return times, centres, path, walls

    def _draw_predictions(
        self, arena: ShownArena, tr: tuple[float, ...], selected: int, obs: Observation
    ) -> None:
        times, centres, _, _ = self._predictions(arena, selected, obs)
        self._horizon = float(times[-1])
        surf = self.surface
        for j in range(len(centres)):
            col = PALETTE[j % len(PALETTE)]
            q = self._px(tr, centres[j])
            pygame.draw.lines(surf, col, False, q.tolist(), 2)
            end = q[-1]
            pygame.draw.circle(
                surf, col, end.tolist(), max(2, int(obs.neighbours.radii[j] * tr[0])), 1
            )
        body = int(arena.robot_ids[selected])
        a = arena.commanded[body]
        a_n = float(np.hypot(*a))
        if a_n > obs.a_max:
            a = a * obs.a_max / a_n
        own = obs.position + _own_paths(obs.velocity, a[None], obs.v_max, times)[0]
        self._dashed(self._px(tr, own), (0, 0, 0), closed=False)

    # ------------------------------------------------------------------ panel

    def _text(
        self, text: str, pos: tuple[int, int], font: Any = None, colour: Colour = TEXT_COLOUR
    ) -> None:
        self.surface.blit((font or self._font).render(text, True, colour), pos)
        self.info.texts.append(text)

    def keys_line(self) -> str:
        """The keys line shown at the bottom of the window (:data:`KEYS`)."""
        if not self.show_keys:
            return "H or ?: show keys"
        return "  ".join(f"{k}: {what}" for k, what in KEYS[:2]) + f"  {KEYS[2][0]}: hide"

    def _draw_panel(
        self,
        arena: ShownArena,
        panel: pygame.Rect,
        selected: int,
        controlled: set[int],
        obs: Observation | None,
    ) -> None:
        x = panel.left + 14
        state = arena.state
        stats = arena.stats
        assert state is not None and stats is not None  # draw() checked the state
        limit = arena.spec.episode.time_limit
        robot_contacts = sum(1 for c in stats.contacts if "robot" in (c.kind_a, c.kind_b))
        self._text(f"{arena.spec.name}", (x, 8), self._big)
        self._text(f"t = {state.time:6.1f} s  / {limit:g} s     step {self._steps}", (x, 38))
        y = 58
        if self.human:  # the wall-clock rate: in the live window only, never in frames
            rate = (
                f"{self._rate:6.0f} steps/s ({self._rate * arena.world.dt:.1f}x real time)"
                if self._rate > 0
                else "-- steps/s"
            )
            self._text(rate, (x, y))
            y += 20
        reached = int(np.sum(stats.reached[arena.robot_ids])) if len(arena.robots) else 0
        self._text(
            f"collisions: {robot_contacts} involving robots ({len(stats.contacts)} total)",
            (x, y),
            colour=CONTACT_COLOUR if robot_contacts else TEXT_COLOUR,
        )
        self._text(f"robots at goal: {reached} / {len(arena.robots)}", (x, y + 20))
        keys_h = 22 if self.human else 0
        if self.human:
            self._text(self.keys_line(), (x, panel.bottom - 20), self._small, (70, 70, 70))
        if obs is None:
            return
        body = int(arena.robot_ids[selected])
        name = arena.robots[selected].name or f"robot{selected}"
        who = "controlled" if selected in controlled else arena.agent_labels[selected]
        self._text(f"selected: {name} ({who})", (x, y + 46), self._font)
        speed = float(np.hypot(*state.velocities[body]))
        self._text(
            f"|v| = {speed:.2f} / {obs.v_max:g} m/s   a_max = {obs.a_max:g} m/s^2",
            (x, y + 68),
            self._small,
        )
        entries = self.legend_entries(arena, controlled)
        col_w = (panel.right - 14 - x) // 2
        rows = self._legend_rows(entries, col_w)
        legend_h = 19 * len(rows)
        top = 188
        left = x + 40
        size = min(panel.right - 14 - left, panel.height - top - 64 - legend_h - keys_h)
        plot = pygame.Rect(left, top, max(size, 60), max(size, 60))
        self._draw_accel_space(arena, plot, selected, controlled, obs)
        self._draw_legend(rows, (x, plot.bottom + 64), col_w)
        self.info.legend = entries

    def _draw_accel_space(
        self,
        arena: ShownArena,
        plot: pygame.Rect,
        selected: int,
        controlled: set[int],
        obs: Observation,
    ) -> None:
        surf = self.surface
        ext = self.options.panel_extent * obs.a_max
        g = self.options.panel_grid
        xs = np.linspace(-ext, ext, g)
        gx, gy = np.meshgrid(xs, xs[::-1])
        grid = np.stack([gx.ravel(), gy.ravel()], axis=1)
        _, _, path, walls = self._predictions(arena, selected, obs)
        img = np.full((g * g, 3), 255, dtype=np.uint8)
        # label per grid point: -1 free, -2 walls, j >= 0 the neighbour with least clearance
        lab, shown = self._panel_labels(grid, obs, path, walls, ext * math.sqrt(2))
        hit = lab != -1
        grid_lab = lab.reshape(g, g)
        if np.any(hit):
            img[hit] = self._region_colours()[
                np.where(lab[hit] >= 0, lab[hit] % len(PALETTE), len(PALETTE))
            ]
            edge = np.zeros((g, g), dtype=bool)
            edge[:-1] |= grid_lab[:-1] != grid_lab[1:]
            edge[1:] |= grid_lab[1:] != grid_lab[:-1]
            edge[:, :-1] |= grid_lab[:, :-1] != grid_lab[:, 1:]
            edge[:, 1:] |= grid_lab[:, 1:] != grid_lab[:, :-1]
            edge = (edge & (grid_lab != -1)).ravel()
            img[edge] = (img[edge] * 0.6).astype(np.uint8)
        n_obs = path.n_obstacles + (len(walls[1]) if walls is not None else 0)
        status = f"{shown} of {n_obs} obstacles within reach" if n_obs else "no obstacles"
        image = pygame.surfarray.make_surface(img.reshape(g, g, 3).transpose(1, 0, 2))
        surf.blit(pygame.transform.smoothscale(image, plot.size), plot.topleft)
        pygame.draw.rect(surf, (120, 120, 120), plot, 1)
        self._draw_cut_edges(plot, edge_runs(grid_lab), g)
        s = plot.width / (2 * ext)
        cx, cy = plot.center

        def to_px(a: NDArray[np.float64]) -> tuple[int, int]:
            return int(round(cx + a[0] * s)), int(round(cy - a[1] * s))

        self._draw_axes(plot, ext)
        pygame.draw.circle(surf, (60, 60, 60), (cx, cy), int(round(obs.a_max * s)), 2)
        agent = panel_agent(arena, selected)
        desired = goal_seeking_accel(obs, agent.v_pref, heading_offset=agent.detour)
        body = int(arena.robot_ids[selected])
        chosen = np.asarray(arena.commanded[body], dtype=float)
        n = float(np.hypot(*chosen))
        if n > obs.a_max:
            chosen = chosen * obs.a_max / n
        self._arrow(to_px(np.zeros(2)), to_px(desired), GOOD_COLOUR, "desired")
        self._arrow(to_px(np.zeros(2)), to_px(chosen), (0, 0, 0), "commanded")
        self._text(
            "acceleration space (m/s^2), world axes", (plot.left - 40, plot.top - 24), self._small
        )
        if selected not in controlled and agent.status is not None:
            status = f"last selection: {agent.status}; " + status
        self._text(status, (plot.left - 40, plot.bottom + 42), self._small, (70, 70, 70))

    @staticmethod
    def _panel_labels(
        grid: NDArray[np.float64],
        obs: Observation,
        path: PiecewisePath,
        walls: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
        reach: float,
    ) -> tuple[NDArray[np.int64], int]:
        """Per panel acceleration (G, 2) m/s^2: its label (G,) (-1 free, -2 walls, j >= 0 the
        neighbour j of ``path`` with the least clearance, see
        :mod:`nao_arena.render._panel_kernel`) and how many obstacles were within reach.
        Neighbours count when some acceleration of norm <= ``reach`` m/s^2 can reach them
        (:func:`relevant_obstacles`); walls: robot-relative segments (W, 2, 2) m with grown
        half-thicknesses (W,) m, or None."""
        idx = np.zeros(0, dtype=np.int64)
        if path.n_obstacles:
            idx = np.flatnonzero(
                relevant_obstacles(obs.velocity, reach, obs.v_max, *path.moving_arrays, 0.0)
            )
        segs, grown = walls if walls is not None else (np.zeros((0, 2, 2)), np.zeros(0))
        shown = len(idx) + len(grown)
        if not shown:
            return np.full(len(grid), -1, dtype=np.int64), 0
        c, w, b = (np.ascontiguousarray(x[idx]) for x in path.arrays[1:4])
        t = np.ascontiguousarray(path.t)
        lab = panel_labels(
            np.ascontiguousarray(grid),
            np.ascontiguousarray(obs.velocity, float),
            float(obs.v_max),
            t,
            c,
            w,
            b,
            np.ascontiguousarray(path.radius[idx]),
            piece_sweep(t, w, b),
            np.ascontiguousarray(segs, float),
            np.ascontiguousarray(grown, float),
        )
        own = lab >= 0
        lab[own] = idx[lab[own]]
        return lab, shown

    @staticmethod
    def _region_colours() -> NDArray[np.uint8]:
        """Fill colours of the panel's regions: one per palette entry, then the walls'."""
        return np.array([mix(c, 0.55) for c in PALETTE] + [WALL_REGION_COLOUR], dtype=np.uint8)

    def _draw_cut_edges(self, plot: pygame.Rect, runs: list[EdgeRun], g: int) -> None:
        """A dashed band outside the panel's frame where a region reaches its edge."""
        cols = self._region_colours()
        cell = plot.width / g
        for run in runs:
            c = cols[len(PALETTE) if run.label < 0 else run.label % len(PALETTE)]
            colour = tuple(int(v * 0.6) for v in c)
            a = int(round(run.start * cell))
            b = int(round(run.stop * cell))
            for k in range(a, b, 9):
                k1 = min(k + 6, b)
                if run.edge in ("top", "bottom"):
                    y = plot.top - 6 if run.edge == "top" else plot.bottom + 1
                    rect = pygame.Rect(plot.left + k, y, k1 - k, 5)
                else:
                    xx = plot.left - 6 if run.edge == "left" else plot.right + 1
                    rect = pygame.Rect(xx, plot.top + k, 5, k1 - k)
                pygame.draw.rect(self.surface, colour, rect)
        self.info.cut_edges = runs

    def _draw_axes(self, plot: pygame.Rect, ext: float) -> None:
        """Axes through the origin, ticks on every side, labelled below and left, and the
        axis names a_x, a_y (m/s^2)."""
        surf = self.surface
        s = plot.width / (2 * ext)
        cx, cy = plot.center
        grey, tick_col = (170, 170, 170), (90, 90, 90)
        pygame.draw.line(surf, grey, (plot.left, cy), (plot.right, cy), 1)
        pygame.draw.line(surf, grey, (cx, plot.top), (cx, plot.bottom), 1)
        step = self._nice(ext / 3)
        k_max = int(ext / step + 1e-9)
        for k in range(-k_max, k_max + 1):
            v = k * step
            px = int(round(cx + v * s))
            py = int(round(cy - v * s))
            if k:
                pygame.draw.line(surf, tick_col, (px, cy - 3), (px, cy + 3), 1)
                pygame.draw.line(surf, tick_col, (cx - 3, py), (cx + 3, py), 1)
            for y0, y1 in ((plot.top, plot.top + 4), (plot.bottom - 5, plot.bottom - 1)):
                pygame.draw.line(surf, tick_col, (px, y0), (px, y1), 1)
            for x0, x1 in ((plot.left, plot.left + 4), (plot.right - 5, plot.right - 1)):
                pygame.draw.line(surf, tick_col, (x0, py), (x1, py), 1)
            label = f"{v:g}"
            img = self._small.render(label, True, tick_col)
            surf.blit(img, (px - img.get_width() // 2, plot.bottom + 8))
            surf.blit(img, (plot.left - 9 - img.get_width(), py - img.get_height() // 2))
            self.info.texts.append(label)
        name_x = self._small.render("a_x (m/s^2)", True, TEXT_COLOUR)
        surf.blit(name_x, (plot.right - name_x.get_width(), plot.bottom + 24))
        name_y = pygame.transform.rotate(self._small.render("a_y (m/s^2)", True, TEXT_COLOUR), 90)
        surf.blit(name_y, (plot.left - 40, plot.top))
        self.info.texts += ["a_x (m/s^2)", "a_y (m/s^2)"]

    def _arrow(
        self, p0: tuple[int, int], p1: tuple[int, int], colour: Colour, name: str = ""
    ) -> None:
        """An arrow p0 -> p1 (px); shorter than ``_MIN_ARROW_PX``: a ring around p1 (the
        desired one larger, so that both show when they coincide)."""
        surf = self.surface
        dx, dy = p1[0] - p0[0], p1[1] - p0[1]
        n = math.hypot(dx, dy)
        if n < _MIN_ARROW_PX:
            radius = 8 if colour == GOOD_COLOUR else 4
            pygame.draw.circle(surf, colour, p1, radius, 2)
            if name:
                self.info.short_arrows.append(name)
            return
        pygame.draw.line(surf, colour, p0, p1, 3)
        ux, uy = dx / n, dy / n
        head = min(12.0, 0.5 * n)
        left = (p1[0] - head * (ux - 0.5 * uy), p1[1] - head * (uy + 0.5 * ux))
        right = (p1[0] - head * (ux + 0.5 * uy), p1[1] - head * (uy - 0.5 * ux))
        pygame.draw.polygon(surf, colour, [p1, left, right])

    # ------------------------------------------------------------------ legend

    def legend_entries(
        self, arena: ShownArena, controlled: Collection[int] = ()
    ) -> list[LegendEntry]:
        """The legend of a frame of ``arena``: every kind of robot, then each symbol of the
        world view (section ``world``) and of the acceleration panel (``panel``)."""
        entries = []
        kinds: list[str] = []
        for k, name in enumerate(arena.agent_labels):
            label = "controlled" if k in set(controlled) else name
            if label not in kinds:
                kinds.append(label)
        if len(arena.traffic.indices):
            kinds.append("traffic")
        if arena.spec.recorded:
            kinds.append("person")
        entries += [
            LegendEntry(
                "disc",
                "recorded people" if kind == "person" else kind,
                (agent_colour(kind),),
                "kinds",
            )
            for kind in kinds
        ]
        robot = agent_colour(kinds[0]) if kinds else TEXT_COLOUR
        per_neighbour = tuple(PALETTE[:4])
        entries += [
            LegendEntry("ring", "selected robot", ((0, 0, 0),)),
            LegendEntry("goal", "goal", (mix(robot, 0.8),)),
            LegendEntry(
                "dotted", f"trail (last {self.options.trail_seconds:g} s)", (_trail_colour(robot),)
            ),
            LegendEntry("ring", "contact (flashed)", (CONTACT_COLOUR,)),
        ]
        if self.options.predicted_paths:
            entries += [
                LegendEntry(
                    "line", "neighbour's predicted path (colour = neighbour)", per_neighbour
                ),
                LegendEntry(
                    "ring", f"hollow ring: its position in {self._horizon:g} s", per_neighbour
                ),
                LegendEntry("dashed", "own path under the command", ((0, 0, 0),)),
            ]
        entries += [
            LegendEntry("arrow", "desired", (GOOD_COLOUR,), "panel"),
            LegendEntry("arrow", "commanded", ((0, 0, 0),), "panel"),
            LegendEntry("circle", "|a| = a_max", ((60, 60, 60),), "panel"),
            LegendEntry("zero", "ring: |a| ~ 0, no arrow", (GOOD_COLOUR, (0, 0, 0)), "panel"),
            LegendEntry(
                "swatch",
                "NAO of a neighbour (colour = neighbour, as its path)",
                tuple(mix(c, 0.55) for c in per_neighbour),
                "panel",
            ),
        ]
        if arena.spec.walls or arena.spec.bounds.walls:  # drawn only where there are walls
            entries.append(LegendEntry("swatch", "walls' region", (WALL_REGION_COLOUR,), "panel"))
        entries += [
            LegendEntry(
                "cut",
                "region cut by the edge",
                (cast("Colour", tuple(int(v * 0.6) for v in mix(PALETTE[0], 0.55))),),
                "panel",
            ),
        ]
        return entries

    def _legend_rows(self, entries: list[LegendEntry], col_w: int) -> list[list[LegendEntry]]:
        """Entries in rows: robot kinds three to a row, others two (one if the label is long),
        each section starting a new row."""
        rows: list[list[LegendEntry]] = []
        full = True
        for e in entries:
            per_row = 3 if e.section == "kinds" else 2
            wide = e.section != "kinds" and self._small.size(e.label)[0] > col_w - 40
            if full or wide or e.section != rows[-1][0].section or len(rows[-1]) >= per_row:
                rows.append([])
            rows[-1].append(e)
            full = wide
        return rows

    def _draw_legend(self, rows: list[list[LegendEntry]], at: tuple[int, int], col_w: int) -> None:
        x, y = at
        for row in rows:
            per_row = 3 if row[0].section == "kinds" else 2
            w = (2 * col_w) // per_row
            for i, e in enumerate(row):
                self._symbol(e, (x + i * w, y))
                self._text(e.label, (x + i * w + 36, y + 1), self._small)
            y += 19

    def _symbol(self, e: LegendEntry, at: tuple[int, int]) -> None:
        """Draw a legend entry's symbol in the 30 x 16 px box at ``at``."""
        surf = self.surface
        x, y = at
        cols = e.colours
        mid = y + 8
        if e.symbol == "disc":
            pygame.draw.circle(surf, cols[0], (x + 7, mid), 7)
        elif e.symbol == "ring":
            n = len(cols)
            for i, c in enumerate(cols):
                r = 7 if n == 1 else 4
                cx = x + 15 if n == 1 else x + 4 + i * 8
                pygame.draw.circle(
                    surf, c, (cx, mid), r, 3 if c == CONTACT_COLOUR else 2 if n == 1 else 1
                )
        elif e.symbol == "goal":
            pygame.draw.circle(surf, cols[0], (x + 15, mid), 6, 2)
            pygame.draw.line(surf, cols[0], (x + 9, mid), (x + 21, mid), 1)
            pygame.draw.line(surf, cols[0], (x + 15, mid - 6), (x + 15, mid + 6), 1)
        elif e.symbol == "dotted":
            for k in range(0, 31, 6):
                pygame.draw.circle(surf, cols[0], (x + k, mid), 2)
        elif e.symbol == "line":
            w = 30 / len(cols)
            for i, c in enumerate(cols):
                pygame.draw.line(surf, c, (x + i * w, mid), (x + (i + 1) * w, mid), 2)
        elif e.symbol == "dashed":
            self._dashed(np.array([[x + 2.0 * k, mid] for k in range(16)]), cols[0], False)
        elif e.symbol == "arrow":
            self._arrow((x, mid), (x + 30, mid), cols[0])
        elif e.symbol == "zero":
            pygame.draw.circle(surf, cols[0], (x + 15, mid), 8, 2)
            pygame.draw.circle(surf, cols[1], (x + 15, mid), 4, 2)
        elif e.symbol == "circle":
            pygame.draw.circle(surf, cols[0], (x + 15, mid), 8, 2)
        elif e.symbol == "swatch":
            w = 30 / len(cols)
            for i, c in enumerate(cols):
                pygame.draw.rect(surf, c, (int(x + i * w), y + 1, int(math.ceil(w)), 14))
        elif e.symbol == "cut":
            pygame.draw.rect(surf, (120, 120, 120), (x, y + 6, 30, 10), 1)
            for k in (0, 9, 18, 27):
                pygame.draw.rect(surf, cols[0], (x + k, y, min(6, 30 - k), 5))
