"""What an agent sees: its own state and its neighbours within sensing range.

All positions, velocities and accelerations are in the world frame (m,
m/s, m/s^2); times in s. Known paths (the true future centres of scripted
traffic) and shared plans (the acceleration a cooperative agent committed
to) are included where the map provides them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["Neighbours", "Observation", "neighbours_in_range"]


def _vec(n: int = 0) -> NDArray[np.float64]:
    return np.zeros((n, 2))


@dataclass(frozen=True)
class Neighbours:
    """The other bodies an agent senses, one row each.

    ids: body indices in the world; kinds: "robot" or "traffic";
    positions, velocities, accelerations: (n, 2); radii: (n,) m.
    known_paths: (n, T, 2) true future centres at ``path_times`` (NaN rows
    where unknown); plans: (n, 2) committed accelerations (NaN where the
    neighbour shares none).
    """

    ids: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    kinds: tuple[str, ...] = ()
    positions: NDArray[np.float64] = field(default_factory=_vec)
    velocities: NDArray[np.float64] = field(default_factory=_vec)
    accelerations: NDArray[np.float64] = field(default_factory=_vec)
    radii: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    path_times: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    known_paths: NDArray[np.float64] | None = None
    plans: NDArray[np.float64] | None = None

    def __len__(self) -> int:
        return len(self.ids)


@dataclass(frozen=True)
class Observation:
    """One agent's view at one control step.

    time: simulated time (s); dt: control period (s); own state in the world
    frame; goal (2,) m or None; route (M, 2) waypoints or None; limits
    a_max (m/s^2) and v_max (m/s); walls: (W, 2, 2) segment end points (m)
    within range, with their half-thickness ``wall_radius`` (W,) m.
    """

    time: float
    dt: float
    robot_id: int
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    radius: float
    a_max: float
    v_max: float
    goal: NDArray[np.float64] | None = None
    route: NDArray[np.float64] | None = None
    neighbours: Neighbours = field(default_factory=Neighbours)
    walls: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2, 2)))
    wall_radius: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    own_path: NDArray[np.float64] | None = None


def neighbours_in_range(
    me: int,
    positions: NDArray[np.float64],
    sensing_range: float,
    max_neighbours: int | None = None,
) -> NDArray[np.int64]:
    """Indices of bodies within ``sensing_range`` (m) of body ``me``, nearest first.

    Ties are broken by index so the order is deterministic.
    """
    d = np.hypot(*(positions - positions[me]).T)
    d[me] = np.inf
    idx = np.flatnonzero(d <= sensing_range)
    idx = idx[np.lexsort((idx, d[idx]))]
    if max_neighbours is not None:
        idx = idx[:max_neighbours]
    return idx.astype(np.int64)
