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
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame  # noqa: E402

from nao_arena.agent import PanelAgent  # noqa: E402
from nao_arena.geometry.clearance import PiecewisePath  # noqa: E402
from nao_arena.maps import PolygonWall, SegmentWall  # noqa: E402
from nao_arena.obstacles import obstacle_paths, relative_walls  # noqa: E402
from nao_arena.predictors import get_predictor  # noqa: E402
from nao_arena.render.colours import (  # noqa: E402
    AGENT_COLOURS,
    BACKGROUND,
    CONTACT_COLOUR,
    LANE_COLOUR,
    PALETTE,
    PANEL_BACKGROUND,
    TEXT_COLOUR,
    WALL_COLOUR,
    Colour,
    agent_colour,
    body_colour,
    mix,
)
from nao_arena.render.frame import (  # noqa: E402
    FRAME_SIZE,
    KEYS,
    EdgeRun,
    FrameInfo,
    LegendEntry,
    ViewerOptions,
)
from nao_arena.render.panel import (  # noqa: E402
    AccelerationPanel,
    PanelSource,
    _trail_colour,
    edge_runs,
    panel_agent,
)
from nao_arena.sensing import Observation  # noqa: E402
from nao_arena.traffic import CircleLane, PolylineLane  # noqa: E402
from nao_arena.world import speed_limit_time  # noqa: E402

if TYPE_CHECKING:
    from nao_arena.render.frame import ShownArena

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


class Viewer(AccelerationPanel):
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
