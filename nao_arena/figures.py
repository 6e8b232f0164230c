"""The paper's geometric figures, drawn from nao_arena's own geometry.

Each figure shows the exact boundary (solid lines) over the region of
colliding accelerations found by the exact clearance on a grid (shaded), so
that the two can be compared by eye. Units: m/s^2 on the axes of
acceleration plots, m on the axes of path plots.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

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

__all__ = ["FIGURES", "write_figures"]

_COLOURS = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink"]


def _grid(extent: float, n: int = 301) -> tuple[NDArray, NDArray, NDArray]:
    xs = np.linspace(-extent, extent, n)
    gx, gy = np.meshgrid(xs, xs)
    return gx, gy, np.stack([gx.ravel(), gy.ravel()], axis=1)


def _shade(ax, extent: float, clearance_of: Callable[[NDArray], NDArray], colour: str) -> None:
    gx, gy, pts = _grid(extent)
    clear = clearance_of(pts).reshape(gx.shape)
    ax.contourf(gx, gy, clear, levels=[-1e9, 0.0], colors=[colour], alpha=0.25)


def _draw_boundary(ax, b: ObstacleBoundary, colour: str, label: str | None = None) -> None:
    ax.plot(*b.left.T, color=colour, lw=1.6, label=label)
    ax.plot(*b.right.T, color=colour, lw=1.6, ls="--")
    if len(b.arc):
        ax.plot(*b.arc.T, color=colour, lw=1.2, ls=":")
    if len(b.corners):
        ax.plot(*b.corners.T, color=colour, lw=1.0)


def _accel_axes(ax, extent: float, title: str) -> None:
    ax.set_xlim(-extent, extent)
    ax.set_ylim(-extent, extent)
    ax.set_aspect("equal")
    ax.axhline(0, color="0.7", lw=0.5)
    ax.axvline(0, color="0.7", lw=0.5)
    ax.set_xlabel("a_x (m/s^2)")
    ax.set_ylabel("a_y (m/s^2)")
    ax.set_title(title, fontsize=10)


def fig_bao(ax) -> None:
    """BAO: a cone from a_B tangent to the grown obstacle (zero velocities)."""
    q, r, a_b, ext = np.array([6.0, 2.0]), 1.5, np.array([0.5, -0.5]), 4.0
    _shade(ax, ext, lambda a: ao_clearance(a, (0, 0), q, r, obstacle_acc=a_b).clearance,
           _COLOURS[0])
    _draw_boundary(ax, bao_boundary(q, r, a_b, extent=2 * ext), _COLOURS[0], "BAO boundary")
    ax.plot(*a_b, "k^", label="a_B")
    ax.legend(fontsize=8, loc="lower left")
    _accel_axes(ax, ext, "BAO: zero velocities, obstacle accelerating at a_B")


def fig_ao_static(ax) -> None:
    """AO of a static obstacle for a moving robot: a warped cone."""
    v, q, r, ext = np.array([2.0, 0.0]), np.array([6.0, 2.0]), 1.5, 3.0
    _shade(ax, ext, lambda a: ao_clearance(a, v, q, r).clearance, _COLOURS[1])
    _draw_boundary(ax, ao_boundary(v, q, r, extent=3 * ext), _COLOURS[1], "AO boundary")
    paper = ao_boundary_paper(v, q, r, extent=3 * ext, n=400)
    ax.plot(*paper.points().T, "k.", ms=2, label="paper's construction")
    ax.annotate("", xy=v * 0.6, xytext=(0, 0), arrowprops={"arrowstyle": "->", "color": "k"})
    ax.text(*(v * 0.6 + [0.05, 0.1]), "v_A (direction)", fontsize=8)
    ax.legend(fontsize=8, loc="lower left")
    _accel_axes(ax, ext, "AO: static obstacle, robot moving at v_A")


def fig_trajectories(ax) -> None:
    """Paths of accelerations on the AO boundary: each grazes the obstacle."""
    v, q, r = np.array([2.0, 0.0]), np.array([6.0, 2.0]), 1.5
    b = ao_boundary(v, q, r, extent=6.0)
    ax.add_patch(plt.Circle(q, r, color="0.6", alpha=0.5))
    for pts, times, colour in ((b.left, b.left_times, _COLOURS[0]),
                               (b.right, b.right_times, _COLOURS[3])):
        finite = np.all(np.isfinite(pts), axis=1)
        if not np.any(finite):
            continue
        pts, times = pts[finite], times[finite]
        for t_graze in (1.5, 2.5, 4.0, 6.0):
            a = pts[int(np.argmin(np.abs(times - t_graze)))]
            t = np.linspace(0, 8, 400)
            x = v * t[:, None] + 0.5 * a * t[:, None] ** 2
            ax.plot(*x.T, color=colour, lw=1)
    ax.plot(0, 0, "ko")
    ax.set_xlim(-2, 12)
    ax.set_ylim(-5, 7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("Grazing paths of AO boundary accelerations", fontsize=10)


def fig_ao_shifted(ax) -> None:
    """AO of an obstacle with velocity v_B and acceleration a_B: shifted by a_B."""
    v, q, r, ext = np.array([2.0, 0.0]), np.array([6.0, 2.0]), 1.5, 3.0
    v_b, a_b = np.array([0.0, -0.5]), np.array([-0.8, 0.6])
    _shade(ax, ext, lambda a: ao_clearance(a, v, q, r, v_b, a_b).clearance, _COLOURS[2])
    _draw_boundary(ax, ao_boundary(v, q, r, v_b, a_b, extent=3 * ext), _COLOURS[2], "AO")
    _draw_boundary(ax, ao_boundary(v, q, r, v_b, extent=3 * ext), "0.5", "AO before shift")
    ax.plot(*a_b, "k^", label="a_B")
    ax.legend(fontsize=8, loc="lower left")
    _accel_axes(ax, ext, "AO shifted by the obstacle's acceleration a_B")


def fig_four_obstacles(ax) -> None:
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
        _shade(ax, ext, lambda a, q=q, v_b=v_b, a_b=a_b: ao_clearance(
            a, v, q, 1.0, v_b, a_b).clearance, col)
        _draw_boundary(ax, ao_boundary(v, q, 1.0, v_b, a_b, extent=3 * ext), col, f"AO B{i + 1}")
    ax.legend(fontsize=8, loc="lower left")
    _accel_axes(ax, ext, "AOs of four obstacles (B1, B3 not accelerating)")


def fig_nao(ax) -> None:
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
    for i, c in enumerate(paths):
        col = _COLOURS[i]
        _shade(ax, ext, lambda a, c=c: nao_clearance(a, v, t, c, 1.5), col)
        _draw_boundary(ax, nao_boundary(v, t, c, 1.5, extent=3 * ext), col, f"NAO B{i + 1}")
        all_clear.append(c)
    from nao_arena.geometry.clearance import sampled_path
    from nao_arena.geometry.selection import AccelLimits, select_acceleration

    path = sampled_path(t, np.stack(all_clear), 1.5)
    sel = select_acceleration((0.0, 0.0), v, path, AccelLimits(ext * 0.9))
    ax.annotate("", xy=sel.accel, xytext=(0, 0),
                arrowprops={"arrowstyle": "->", "color": "red", "lw": 2})
    ax.add_patch(plt.Circle((0, 0), ext * 0.9, fill=False, color="k", ls="--", lw=0.8))
    ax.legend(fontsize=8, loc="lower left")
    _accel_axes(ax, ext, f"NAOs (t_h = {t_h:g} s) and the selected acceleration ({sel.status})")


FIGURES: dict[str, Callable] = {
    "bao": fig_bao,
    "ao_static": fig_ao_static,
    "ao_trajectories": fig_trajectories,
    "ao_shifted": fig_ao_shifted,
    "ao_four_obstacles": fig_four_obstacles,
    "nao_paths": fig_nao,
}


def write_figures(out_dir: str | os.PathLike, names: list[str] | None = None) -> list[Path]:
    """Draw the figures as PNG files into out_dir; returns the written paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name in names or list(FIGURES):
        fig, ax = plt.subplots(figsize=(6, 6), dpi=110)
        FIGURES[name](ax)
        fig.tight_layout()
        path = out / f"{name}.png"
        tmp = out / f".{name}.png.tmp"
        fig.savefig(tmp, format="png")
        plt.close(fig)
        os.replace(tmp, path)
        written.append(path)
    return written
