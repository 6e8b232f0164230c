"""The viewer's side panel: the HUD, the selected robot's acceleration space (the NAO of
its neighbours and the walls' region, the desired and commanded accelerations) and the
legend (see :mod:`nao_arena.render.viewer`). :class:`AccelerationPanel` draws them for
:class:`~nao_arena.render.viewer.Viewer`, on its surface."""

from __future__ import annotations

import math
from collections.abc import Collection
from typing import TYPE_CHECKING, Any, Protocol, cast, runtime_checkable

import numpy as np
import pygame
from numpy.typing import NDArray

from nao_arena.agent import PanelAgent, ShowsPanel
from nao_arena.agents.goal import goal_seeking_accel
from nao_arena.geometry.clearance import PiecewisePath
from nao_arena.geometry.kernels import piece_sweep, relevant_obstacles
from nao_arena.render._panel_kernel import panel_labels
from nao_arena.render.colours import (
    CONTACT_COLOUR,
    GOOD_COLOUR,
    PALETTE,
    TEXT_COLOUR,
    WALL_REGION_COLOUR,
    Colour,
    agent_colour,
    mix,
)
from nao_arena.render.frame import KEYS, EdgeRun, FrameInfo, LegendEntry, ViewerOptions
from nao_arena.sensing import Observation

if TYPE_CHECKING:
    from nao_arena.arena import Arena
    from nao_arena.render.frame import ShownArena

__all__ = ["AccelerationPanel", "PanelSource", "edge_runs", "panel_agent"]

_MIN_ARROW_PX = 10.0
"""Accelerations shorter than this on the panel (px) are drawn as rings, not arrows."""


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


class AccelerationPanel:
    """The side panel of :class:`~nao_arena.render.viewer.Viewer` (a base class of it):
    what it draws there, on the viewer's ``surface`` with its fonts, recording what it
    drew in ``info``."""

    options: ViewerOptions
    human: bool
    surface: pygame.Surface
    info: FrameInfo
    show_keys: bool
    _font: pygame.font.Font
    _small: pygame.font.Font
    _big: pygame.font.Font
    _steps: int
    _rate: float
    _horizon: float

    if TYPE_CHECKING:  # drawn by the viewer, which the panel's drawing reuses

        def _predictions(
            self, arena: ShownArena, selected: int, obs: Observation
        ) -> tuple[
            NDArray[np.float64],
            NDArray[np.float64],
            PiecewisePath,
            tuple[NDArray[np.float64], NDArray[np.float64]] | None,
        ]: ...

        @staticmethod
        def _nice(x: float) -> float: ...

        def _dashed(self, q: NDArray[np.float64], colour: Colour, closed: bool) -> None: ...

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
