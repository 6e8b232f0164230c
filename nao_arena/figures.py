"""The paper's geometric figures, drawn from nao_arena's own geometry.

Each figure shows the exact boundary (lines) over the region of colliding
accelerations found by the exact clearance on a grid (shaded), so that the
two can be compared by eye. Colour = obstacle; line style = the side on
which the robot grazes the obstacle (solid: the obstacle on the robot's
right, dashed: on its left, judged along the robot's velocity relative to
the obstacle and computed from the boundary's grazing times, see
:func:`grazing_side`); dotted: grazing at the horizon; thin: at a kink of a
sampled path. A legend and a caption (the scene: velocities, radii, horizon)
sit under the axes. Units: m/s^2 on the axes of acceleration plots, m on
the axes of path plots.
"""

from __future__ import annotations

import os
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.legend_handler import HandlerPatch  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import FancyArrow, Patch  # noqa: E402
from numpy.typing import ArrayLike, NDArray  # noqa: E402

from nao_arena.atomic import atomic_write_with  # noqa: E402
from nao_arena.geometry.boundary import (  # noqa: E402
    ObstacleBoundary,
    ao_boundary,
    ao_boundary_paper,
    bao_boundary,
    nao_boundary,
)
from nao_arena.geometry.clearance import (  # noqa: E402
    ao_clearance,
    nao_clearance,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["FIGURES", "SOLID_SIDE", "grazing_side", "moving", "sampled", "write_figures"]

_COLOURS = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink"]

Centre = Callable[[NDArray[np.float64]], NDArray[np.float64]]
"""An obstacle's centre (T, 2) m at times (T,) s, robot at the origin at t = 0."""

SOLID_SIDE = "right"
"""Boundary branches are drawn solid where the robot grazes the obstacle with the obstacle on
its right (seen along the robot's velocity relative to the obstacle), dashed where on its
left."""

_STYLE = {"right": "-", "left": "--"}


def _grid(extent: float, n: int = 301) -> tuple[NDArray, NDArray, NDArray]:
    xs = np.linspace(-extent, extent, n)
    gx, gy = np.meshgrid(xs, xs)
    return gx, gy, np.stack([gx.ravel(), gy.ravel()], axis=1)


def _shade(ax, extent: float, clearance_of: Callable[[NDArray], NDArray], colour: str) -> None:
    gx, gy, pts = _grid(extent)
    clear = clearance_of(pts).reshape(gx.shape)
    ax.contourf(gx, gy, clear, levels=[-1e9, 0.0], colors=[colour], alpha=0.25)


def moving(q: ArrayLike, v_b: ArrayLike = (0.0, 0.0), a_b: ArrayLike = (0.0, 0.0)) -> Centre:
    """The centre of an obstacle starting at q (m) with velocity v_b (m/s) and constant
    acceleration a_b (m/s^2)."""
    q, v_b, a_b = (np.asarray(x, dtype=float) for x in (q, v_b, a_b))
    return lambda t: q + v_b * t[:, None] + 0.5 * a_b * t[:, None] ** 2


def sampled(times: NDArray[np.float64], centres: NDArray[np.float64]) -> Centre:
    """The centre of an obstacle on a sampled path: centres (T, 2) m at times (T,) s,
    linear in between."""
    return lambda t: np.stack(
        [np.interp(t, times, centres[:, 0]), np.interp(t, times, centres[:, 1])], axis=1
    )


def grazing_side(
    accels: NDArray[np.float64], times: NDArray[np.float64], v: ArrayLike, centre: Centre
) -> str | None:
    """On which side of the robot ("left" or "right") the obstacle is when the robot, starting
    at the origin with velocity v (m/s) and constant accelerations accels (K, 2) m/s^2,
    grazes it at times (K,) s: the majority over the finite points, judged along the robot's
    velocity relative to the obstacle; None without a finite point."""
    ok = np.all(np.isfinite(accels), axis=1) & np.isfinite(times) & (times > 0)
    if not np.any(ok):
        return None
    a, t = accels[ok], times[ok]
    v = np.asarray(v, dtype=float)
    x = v * t[:, None] + 0.5 * a * t[:, None] ** 2
    dt = 1e-4
    c = centre(t)
    rel_vel = v + a * t[:, None] - (centre(t + dt) - centre(t - dt)) / (2 * dt)
    rel = c - x
    left = rel_vel[:, 0] * rel[:, 1] - rel_vel[:, 1] * rel[:, 0] > 0
    return "left" if np.mean(left) > 0.5 else "right"


def _draw_boundary(
    ax,
    b: ObstacleBoundary,
    colour: str,
    label: str | None,
    v: ArrayLike,
    centre: Centre,
    extent: float,
) -> tuple[bool, bool]:
    """The exact boundary: each branch solid or dashed by the side on which the robot grazes
    the obstacle (:data:`SOLID_SIDE`), the horizon arc dotted, corner arcs thin; a legend
    entry (the region's colour) with ``label``. Returns whether an arc and corner arcs show
    within ``extent`` (m/s^2)."""
    for pts, times in ((b.left, b.left_times), (b.right, b.right_times)):
        if not len(pts):
            continue
        side = grazing_side(pts, times, v, centre) or "right"
        ax.plot(*pts.T, color=colour, lw=1.6, ls=_STYLE[side])
    if label:
        ax.fill([], [], facecolor=colour, edgecolor=colour, alpha=0.4, label=label)
    if len(b.arc):
        ax.plot(*b.arc.T, color=colour, lw=1.2, ls=":")
    if len(b.corners):
        ax.plot(*b.corners.T, color=colour, lw=1.0)

    def shows(pts: NDArray[np.float64]) -> bool:
        return bool(len(pts)) and bool(np.any(np.all(np.abs(pts) <= extent, axis=1)))

    return shows(b.arc), shows(b.corners)


def _style_handles(arc: bool = False, corners: bool = False) -> list[Any]:
    """Legend entries for the line styles and the shading (black proxies)."""
    handles: list[Line2D | Patch] = [
        Line2D(
            [],
            [],
            color="k",
            lw=1.6,
            ls=_STYLE["right"],
            label="boundary: obstacle on the robot's right when grazing",
        ),
        Line2D(
            [],
            [],
            color="k",
            lw=1.6,
            ls=_STYLE["left"],
            label="boundary: obstacle on the robot's left when grazing",
        ),
    ]
    if arc:
        handles.append(
            Line2D([], [], color="k", lw=1.2, ls=":", label="boundary: grazing at the horizon t_h")
        )
    if corners:
        handles.append(
            Line2D([], [], color="k", lw=1.0, label="boundary: at a kink of the sampled path")
        )
    handles.append(
        Patch(facecolor="0.5", alpha=0.25, label="colliding accelerations (exact clearance < 0)")
    )
    return handles


def _legend(ax, extra: Sequence[Any] = (), arc: bool = False, corners: bool = False) -> None:
    """One legend under the axes: the plotted items, then ``extra``, then the styles."""
    handles, _ = ax.get_legend_handles_labels()
    handles = [*handles, *extra, *_style_handles(arc, corners)]
    ax.legend(
        handles=handles,
        fontsize=7.5,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.1),
        ncol=2,
        frameon=False,
        handler_map={FancyArrow: _ArrowHandler()},
    )


class _ArrowHandler(HandlerPatch):
    """Draws a FancyArrow legend entry as a small arrow."""

    def create_artists(
        self, legend, orig_handle, xdescent, ydescent, width, height, fontsize, trans
    ):
        arrow = FancyArrow(
            0,
            height / 2,
            width,
            0,
            width=0.5,
            length_includes_head=True,
            head_width=0.75 * height,
            head_length=0.35 * width,
            color=orig_handle.get_facecolor(),
        )
        arrow.set_transform(trans)
        return [arrow]


def _arrow_handle(colour: str, label: str) -> FancyArrow:
    return FancyArrow(0, 0, 1, 0, color=colour, label=label)


def _accel_axes(ax, extent: float, title: str) -> None:
    ax.set_xlim(-extent, extent)
    ax.set_ylim(-extent, extent)
    ax.set_aspect("equal")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.axvline(0, color="0.7", lw=0.5)
    ax.set_xlabel("a_x (m/s^2)")
    ax.set_ylabel("a_y (m/s^2)")
    ax.set_title(title, fontsize=10)


def fig_bao(ax) -> str:
    """BAO: a cone from a_B tangent to the grown obstacle (zero velocities)."""
    q, r, a_b, ext = np.array([6.0, 2.0]), 1.5, np.array([0.5, -0.5]), 4.0
    _shade(
        ax, ext, lambda a: ao_clearance(a, (0, 0), q, r, obstacle_acc=a_b).clearance, _COLOURS[0]
    )
    _draw_boundary(
        ax,
        bao_boundary(q, r, a_b, extent=2 * ext),
        _COLOURS[0],
        "BAO",
        (0.0, 0.0),
        moving(q, a_b=a_b),
        ext,
    )
    ax.plot(*a_b, "k^", label="a_B (obstacle's acceleration)")
    _legend(ax)
    _accel_axes(ax, ext, "BAO: zero velocities, obstacle accelerating at a_B")
    return (
        "Robot and obstacle at rest at t = 0; obstacle (radius 1.5 m, grown by the robot's) "
        "at (6, 2) m, accelerating at a_B = (0.5, -0.5) m/s^2; no horizon."
    )


def fig_ao_static(ax) -> str:
    """AO of a static obstacle for a moving robot: a warped cone."""
    v, q, r, ext = np.array([2.0, 0.0]), np.array([6.0, 2.0]), 1.5, 3.0
    _shade(ax, ext, lambda a: ao_clearance(a, v, q, r).clearance, _COLOURS[1])
    _draw_boundary(ax, ao_boundary(v, q, r, extent=3 * ext), _COLOURS[1], "AO", v, moving(q), ext)
    paper = ao_boundary_paper(v, q, r, extent=3 * ext, n=400)
    ax.plot(*paper.points().T, "k.", ms=2, label="paper's construction")
    ax.annotate("", xy=v * 0.6, xytext=(0, 0), arrowprops={"arrowstyle": "->", "color": "k"})
    ax.text(*(v * 0.6 + [0.05, 0.1]), "v_A (direction)", fontsize=8)
    _legend(ax)
    _accel_axes(ax, ext, "AO: static obstacle, robot moving at v_A")
    return (
        "Robot at the origin moving at v_A = (2, 0) m/s; static obstacle (radius 1.5 m) at "
        "(6, 2) m; no horizon. Dots: the boundary by the paper's construction."
    )


def fig_trajectories(ax) -> str:
    """Paths of accelerations on the AO boundary: each grazes the obstacle."""
    v, q, r = np.array([2.0, 0.0]), np.array([6.0, 2.0]), 1.5
    b = ao_boundary(v, q, r, extent=6.0)
    # matplotlib's stubs take the centre as a tuple only; any (2,) sequence works
    centre = cast("tuple[float, float]", q)
    ax.add_patch(plt.Circle(centre, r, color="0.6", alpha=0.5, label="obstacle (grown, 1.5 m)"))
    colour_of = {"right": _COLOURS[0], "left": _COLOURS[3]}
    for pts, times in ((b.left, b.left_times), (b.right, b.right_times)):
        finite = np.all(np.isfinite(pts), axis=1)
        if not np.any(finite):
            continue
        pts, times = pts[finite], times[finite]
        side = grazing_side(pts, times, v, moving(q)) or "right"
        colour = colour_of[side]
        for k, t_graze in enumerate((1.5, 2.5, 4.0, 6.0)):
            i = int(np.argmin(np.abs(times - t_graze)))
            a = pts[i]
            t = np.linspace(0, 8, 400)
            x = v * t[:, None] + 0.5 * a * t[:, None] ** 2
            label = (
                f"path of an AO boundary point: obstacle on the robot's {side}" if k == 0 else None
            )
            ax.plot(*x.T, color=colour, lw=1, label=label)
            ax.plot(
                *(v * times[i] + 0.5 * a * times[i] ** 2),
                "o",
                color=colour,
                ms=3,
                label="where it grazes the obstacle" if k == 0 and side == "right" else None,
            )
    ax.plot(0, 0, "ko", label="robot at t = 0")
    ax.set_xlim(-2, 12)
    ax.set_ylim(-5, 7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("Grazing paths of AO boundary accelerations", fontsize=10)
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=1, frameon=False)
    return (
        "Robot starting at the origin at v = (2, 0) m/s with a constant acceleration taken "
        "on the AO boundary of fig. ao_static, at the points grazing at t = 1.5, 2.5, 4 and "
        "6 s; each path drawn for 8 s."
    )


def fig_ao_shifted(ax) -> str:
    """AO of an obstacle with velocity v_B and acceleration a_B: shifted by a_B."""
    v, q, r, ext = np.array([2.0, 0.0]), np.array([6.0, 2.0]), 1.5, 3.0
    v_b, a_b = np.array([0.0, -0.5]), np.array([-0.8, 0.6])
    _shade(ax, ext, lambda a: ao_clearance(a, v, q, r, v_b, a_b).clearance, _COLOURS[2])
    _draw_boundary(
        ax,
        ao_boundary(v, q, r, v_b, a_b, extent=3 * ext),
        _COLOURS[2],
        "AO",
        v,
        moving(q, v_b, a_b),
        ext,
    )
    _draw_boundary(
        ax,
        ao_boundary(v, q, r, v_b, extent=3 * ext),
        "0.5",
        "AO before the shift (a_B = 0; boundary only)",
        v,
        moving(q, v_b),
        ext,
    )
    ax.plot(*a_b, "k^", label="a_B (obstacle's acceleration)")
    _legend(ax)
    _accel_axes(ax, ext, "AO shifted by the obstacle's acceleration a_B")
    return (
        "Robot at v = (2, 0) m/s; obstacle (radius 1.5 m) at (6, 2) m moving at "
        "v_B = (0, -0.5) m/s and accelerating at a_B = (-0.8, 0.6) m/s^2; no horizon."
    )


def fig_four_obstacles(ax) -> str:
    """AOs of four obstacles with their own velocities and accelerations."""
    v, ext = np.array([1.5, 0.5]), 4.0
    obstacles = [
        ((7.0, 3.0), (0.0, -1.0), (0.0, 0.0)),
        ((5.0, -4.0), (0.5, 1.0), (0.8, 0.4)),
        ((-4.0, 6.0), (1.0, 0.0), (0.0, 0.0)),
        ((-6.0, -3.0), (1.5, 0.5), (-0.6, 0.9)),
    ]
    for i, (q, v_b, a_b) in enumerate(obstacles):
        col = _COLOURS[i]

        def clearance_of(
            a: NDArray,
            q: tuple[float, float] = q,
            v_b: tuple[float, float] = v_b,
            a_b: tuple[float, float] = a_b,
        ) -> NDArray:
            return ao_clearance(a, v, q, 1.0, v_b, a_b).clearance

        _shade(ax, ext, clearance_of, col)
        _draw_boundary(
            ax,
            ao_boundary(v, q, 1.0, v_b, a_b, extent=3 * ext),
            col,
            f"AO B{i + 1}",
            v,
            moving(q, v_b, a_b),
            ext,
        )
    _legend(ax)
    _accel_axes(ax, ext, "AOs of four obstacles (B1, B3 not accelerating)")
    return (
        "Robot at v = (1.5, 0.5) m/s; four obstacles of radius 1 m with their own "
        "velocities and constant accelerations; colour = obstacle; no horizon."
    )


def fig_nao(ax) -> str:
    """NAOs of obstacles on circular and straight paths, with a chosen acceleration."""
    v, ext, t_h = np.array([3.0, 0.0]), 4.0, 6.0
    t = np.linspace(0.0, t_h, 61)
    paths = [
        np.stack([10 + 6 * np.cos(0.5 * t + 2.5), 6 * np.sin(0.5 * t + 2.5)], axis=1),
        np.stack([12 + 9 * np.cos(-0.4 * t + 3.6), 2 + 9 * np.sin(-0.4 * t + 3.6)], axis=1),
        np.stack([14 - 2.0 * t, -3 + 0.5 * t], axis=1),
        np.stack([4 + 0.0 * t, 8 - 2.5 * t], axis=1),
    ]
    all_clear = []
    arc = corners = False
    for i, c in enumerate(paths):
        col = _COLOURS[i]

        def clearance_of(a: NDArray, c: NDArray[np.float64] = c) -> NDArray:
            return nao_clearance(a, v, t, c, 1.5)

        _shade(ax, ext, clearance_of, col)
        b = nao_boundary(v, t, c, 1.5, extent=3 * ext)
        shows = _draw_boundary(ax, b, col, f"NAO B{i + 1}", v, sampled(t, c), ext)
        arc |= shows[0]
        corners |= shows[1]
        all_clear.append(c)
    from nao_arena.geometry.clearance import sampled_path
    from nao_arena.geometry.selection import AccelLimits, select_acceleration

    a_lim = ext * 0.9
    path = sampled_path(t, np.stack(all_clear), 1.5)
    sel = select_acceleration((0.0, 0.0), v, path, AccelLimits(a_lim))
    ax.annotate(
        "", xy=sel.accel, xytext=(0, 0), arrowprops={"arrowstyle": "->", "color": "red", "lw": 2}
    )
    ax.add_patch(plt.Circle((0, 0), a_lim, fill=False, color="k", ls="--", lw=0.8))
    extra = [
        _arrow_handle("red", "selected: admissible acceleration nearest a = 0"),
        Line2D([], [], color="k", ls="--", lw=0.8, label=f"limit |a| = {a_lim:g} m/s^2"),
    ]
    _legend(ax, extra, arc=arc, corners=corners)
    _accel_axes(ax, ext, f"NAOs (t_h = {t_h:g} s) and the selected acceleration ({sel.status})")
    return (
        "Robot at v = (3, 0) m/s; four obstacles (radius 1.5 m, grown) on circular (B1, B2) "
        f"and straight (B3, B4) paths sampled every 0.1 s up to t_h = {t_h:g} s; "
        "colour = obstacle."
    )


FIGURES: dict[str, Callable] = {
    "bao": fig_bao,
    "ao_static": fig_ao_static,
    "ao_trajectories": fig_trajectories,
    "ao_shifted": fig_ao_shifted,
    "ao_four_obstacles": fig_four_obstacles,
    "nao_paths": fig_nao,
}


def write_figures(out_dir: str | os.PathLike, names: list[str] | None = None) -> list[Path]:
    """Draw the figures as PNG files into out_dir, each with its legend and caption under
    the axes; returns the written paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in names or list(FIGURES):
        fig, ax = plt.subplots(figsize=(6, 6), dpi=110)
        caption = FIGURES[name](ax)
        fig.tight_layout()
        if caption:
            fig.canvas.draw()
            # the Agg canvas (matplotlib.use above); matplotlib types it FigureCanvasBase
            below = ax.get_tightbbox(fig.canvas.get_renderer())  # type: ignore[attr-defined]
            assert below is not None  # the axes are visible
            y = fig.transFigure.inverted().transform((0.0, below.y0))[1]
            fig.text(
                0.5,
                y - 0.01,
                "\n".join(textwrap.wrap(caption, 100)),
                ha="center",
                va="top",
                fontsize=7.5,
                color="0.25",
            )
        path = out / f"{name}.png"

        def write_png(tmp: str, fig: Figure = fig) -> None:
            fig.savefig(tmp, format="png", bbox_inches="tight", pad_inches=0.15)

        try:
            atomic_write_with(path, write_png)
        finally:
            plt.close(fig)
        written.append(path)
    return written
