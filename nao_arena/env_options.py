"""The settings of the PettingZoo environments (:mod:`nao_arena.environment`): the
options and reward weights, the observation's features and layout, and the agents'
names."""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from nao_arena.arena import ArenaOptions

__all__ = [
    "NEIGHBOUR_FEATURES",
    "OWN_FEATURES",
    "EnvOptions",
    "RewardWeights",
    "grouped_names",
    "nao_candidates",
    "observation_layout",
]

OWN_FEATURES: tuple[str, ...] = (
    "goal_dx",
    "goal_dy",
    "vx",
    "vy",
    "ax",
    "ay",
    "cmd_ax",
    "cmd_ay",
    "a_max",
    "v_max",
    "radius",
    "x",
    "y",
    "goal_x",
    "goal_y",
    "time_left",
)
"""Names of the ``own`` block, in order (m, m/s, m/s^2, s; world frame)."""

NEIGHBOUR_FEATURES: tuple[str, ...] = (
    "mask",
    "dx",
    "dy",
    "dvx",
    "dvy",
    "ax",
    "ay",
    "radius",
    "is_traffic",
)
"""Names of one neighbour row, in order (relative = neighbour - own, world frame)."""

_KINEMATIC_PREDICTORS = ("constant_velocity", "constant_acceleration", "turn_rate")


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the terms of each agent's reward (see "Rewards" in
    :mod:`nao_arena.environment`)."""

    progress: float = 1.0
    """Per m the robot came closer to its goal in the step (negative when it moved away)."""
    collision: float = 10.0
    """Subtracted per contact episode of the robot that started in the step."""
    accel_change: float = 0.1
    """Subtracted per unit of |a_t - a_(t-1)| / a_max, the change of the commanded
    acceleration as a fraction of the robot's a_max."""
    goal: float = 10.0
    """Added in the step the robot reaches its goal (its agent then terminates)."""
    step: float = 0.0
    """Subtracted every control step (a time penalty)."""


@dataclass(frozen=True)
class EnvOptions:
    """Settings of the environment (see :mod:`nao_arena.environment`); every field is also a
    keyword of :func:`parallel_env` and :func:`env`."""

    controlled: str | Sequence[str | int] = "all"
    """The robots driven by the env's actions: ``"all"`` or robot names / indices (every
    other robot is driven by its own agent inside ``step``)."""
    max_neighbours: int = 6
    """K, the number of neighbour rows of the observation (the K nearest bodies within
    the arena's sensing range)."""
    nao_features: bool = False
    """Whether the observation holds the NAO clearance block (``nao``)."""
    nao_rings: tuple[float, ...] = (0.0, 0.5, 1.0)
    """Magnitudes of the NAO block's candidate accelerations, as fractions of a_max."""
    nao_angles: int = 8
    """Directions per non-zero ring of the NAO block, from +x counter-clockwise (world
    frame)."""
    nao_horizon: float = 3.0
    """Horizon of the NAO block's predicted paths (s)."""
    nao_samples: int = 31
    """Time samples of the NAO block's predicted paths over the horizon."""
    nao_predictor: str = "turn_rate"
    """Predictor of the neighbours' paths for the NAO block: ``constant_velocity``,
    ``constant_acceleration`` or ``turn_rate``."""
    nao_margin: float = 0.0
    """Safety margin added to the sum of the radii in the NAO block (m)."""
    nao_walls: bool = True
    """Whether the NAO block counts the map's nearby walls as obstacles."""
    nao_clip: float = 10.0
    """The NAO block's clearances are clipped to [-nao_clip, nao_clip] (m)."""
    rewards: RewardWeights = field(default_factory=RewardWeights)
    """The reward's weights (:class:`RewardWeights`, or a dict of its fields)."""
    terminate_on_collision: bool = False
    """Whether an agent terminates at its robot's first contact."""
    time_limit: float | None = None
    """Episode length (s) after which every live agent is truncated; None: the map's
    ``time_limit``."""
    after_done: Literal["agent", "hold"] = "agent"
    """What drives a robot whose agent is done: ``"agent"``, its own built-in agent (the
    NAO agent holds it at its goal); ``"hold"``, braking to a stop."""
    reseed_map: bool = True
    """Whether ``reset(seed=s)`` also passes s to the map (a map with random placement
    then changes with the seed)."""
    arena: ArenaOptions = field(default_factory=ArenaOptions)
    """Options of the control loop (:class:`~nao_arena.arena.ArenaOptions`, or a dict of
    its fields)."""
    render_size: tuple[int, int] = (1200, 800)
    """Size (width, height) of rendered frames (px)."""
    selected: str | int | None = None
    """The robot (name or index) shown in the viewer's acceleration panel; None: the
    first controlled one."""
    keep_finished: bool = False
    """Whether agents stay in ``agents`` until the episode ends (see "Agents that
    finish"); vector envs need it."""
    position_margin: float | None = None
    """None, or positions in the observation are clipped to the map's bounds grown by
    this margin (m) (see "Observation bounds")."""
    trust_map: bool = False
    """Whether the map may name code (``FILE.py:Class``, ``module:Class``) as its robots'
    agents (see :func:`nao_arena.maps.load_map`)."""
    named_agents: Mapping[str, str] = field(default_factory=dict)
    """Agent names the map may use, name -> agent reference (see
    :func:`nao_arena.maps.load_map`)."""
    agent_names: Literal["map", "grouped"] = "map"
    """``"map"``: the robots' names (e.g. ``east0``); ``"grouped"``: ``<group>_<k>``, the
    name without its trailing digits, then the robot's index in that group (e.g.
    ``east_0``): what TorchRL and BenchMARL group agents by, so that the robots of one
    group share a policy."""

    def __post_init__(self) -> None:
        if self.position_margin is not None and not (
            math.isfinite(self.position_margin) and self.position_margin >= 0
        ):
            raise ValueError(
                f"position_margin: expected None or a finite number of m >= 0, "
                f"got {self.position_margin}"
            )
        if self.max_neighbours < 0:
            raise ValueError(f"max_neighbours: expected >= 0, got {self.max_neighbours}")
        if self.agent_names not in ("map", "grouped"):
            raise ValueError(f"agent_names: expected 'map' or 'grouped', got {self.agent_names!r}")
        if self.after_done not in ("agent", "hold"):
            raise ValueError(f"after_done: expected 'agent' or 'hold', got {self.after_done!r}")
        if self.nao_predictor not in _KINEMATIC_PREDICTORS:
            raise ValueError(
                f"nao_predictor: expected one of {', '.join(_KINEMATIC_PREDICTORS)}"
                f", got {self.nao_predictor!r}"
            )
        if self.nao_angles < 1 or self.nao_samples < 2 or not self.nao_horizon > 0:
            raise ValueError("expected nao_angles >= 1, nao_samples >= 2, nao_horizon > 0")
        if self.time_limit is not None and not self.time_limit > 0:
            raise ValueError(f"time_limit: expected a positive number of s, got {self.time_limit}")


def nao_candidates(options: EnvOptions) -> NDArray[np.float64]:
    """Candidate accelerations (M, 2) of the NAO block as fractions of a_max (world frame)."""
    ang = 2.0 * np.pi * np.arange(options.nao_angles) / options.nao_angles
    unit = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    rows = [np.zeros((1, 2)) if f == 0 else f * unit for f in options.nao_rings]
    return np.concatenate(rows) if rows else np.zeros((0, 2))


def observation_layout(options: EnvOptions | None = None) -> dict[str, slice]:
    """Slices of the observation vector: "own", "neighbours" (reshape to (K, 9)), "nao",
    "finished" (one entry with ``keep_finished``, else empty)."""
    options = options or EnvOptions()
    n_own = len(OWN_FEATURES)
    n_nb = options.max_neighbours * len(NEIGHBOUR_FEATURES)
    n_nao = len(nao_candidates(options)) if options.nao_features else 0
    end = n_own + n_nb + n_nao
    return {
        "own": slice(0, n_own),
        "neighbours": slice(n_own, n_own + n_nb),
        "nao": slice(n_own + n_nb, end),
        "finished": slice(end, end + (1 if options.keep_finished else 0)),
    }


def _split_kwargs(
    options: EnvOptions | None, map_params: Mapping[str, Any] | None, kwargs: Mapping[str, Any]
) -> tuple[EnvOptions, dict[str, Any]]:
    names = {f.name for f in dataclasses.fields(EnvOptions)}
    opt_kw = {k: v for k, v in kwargs.items() if k in names}
    params = {k: v for k, v in kwargs.items() if k not in names}
    params.update(map_params or {})
    if isinstance(opt_kw.get("rewards"), Mapping):
        opt_kw["rewards"] = RewardWeights(**opt_kw["rewards"])
    if isinstance(opt_kw.get("arena"), Mapping):
        opt_kw["arena"] = ArenaOptions(**opt_kw["arena"])
    base = options or EnvOptions()
    return dataclasses.replace(base, **opt_kw) if opt_kw else base, params


def grouped_names(names: Sequence[str]) -> list[str]:
    """``["east0", "east1", "west0", "car"]`` -> ``["east_0", "east_1", "west_0", "car_0"]``:
    each name without its trailing digits (and a trailing ``_``; ``robot`` if nothing is
    left), then ``_`` and the robot's index among the names of that group (in order)."""
    out: list[str] = []
    counts: dict[str, int] = {}
    for name in names:
        base = re.sub(r"_?\d+$", "", name) or "robot"
        k = counts.get(base, 0)
        counts[base] = k + 1
        out.append(f"{base}_{k}")
    if len(set(out)) != len(out):  # a name such as "a_0" beside "a0": keep the map's
        return list(names)
    return out
