"""PettingZoo environments over the arena's control loop.

``parallel_env(map="roundabout", **kwargs)`` returns a
:class:`pettingzoo.ParallelEnv`; ``env(...)`` the AEC version (PettingZoo's
``parallel_to_aec`` converter). Keyword arguments that name a field of
:class:`EnvOptions` set that option (``rewards`` and ``arena`` also accept
plain dicts); every other keyword is a map parameter (``n=20``, ``seed=3``,
see :mod:`nao_arena.maps`), as is everything in ``map_params={...}``.
Unknown map parameters raise :class:`~nao_arena.maps.MapError` naming the
declared ones.

Agents
------
One agent per *controlled* robot (option ``controlled``: ``"all"`` or a list
of robot names or indices), named by the robot's name. Every other robot is
driven by its own agent (the map's, or ``arena.agent``) and traffic by its
lane followers, inside :meth:`nao_arena.arena.Arena.step`; the env has no
control loop of its own. An agent is removed from ``agents`` when it
terminates (goal reached, or a collision with ``terminate_on_collision``)
or is truncated (time limit). Its robot stays in the world: with
``after_done="agent"`` (default) the robot's own built-in agent drives it
from then on (e.g. the NAO agent holding it at its goal); with
``after_done="hold"`` it brakes to a stop (acceleration -v/dt, clipped to
a_max) and stays there.

Agents that finish
------------------
With ``keep_finished=True`` every agent stays in ``agents`` until the
episode ends, which vector envs (SuperSuit's ``pettingzoo_env_to_vec_env_v1``)
need. An agent finishes when it terminates as above; from then on its
actions are still required and checked but ignored, its robot is driven as
``after_done`` says (by default its own built-in agent: the NAO agent holds
it at its goal), its observation's ``finished`` entry is 1, its reward is 0
and its terminated and truncated flags stay False. The episode ends at the
time limit or when every agent has finished: then every agent leaves
``agents``, the finished ones terminated, the others truncated. Infos get
``finished`` (bool); :attr:`NaoArenaParallelEnv.finished_agents` lists them.

Actions
-------
A float32 Box of shape (2,) in [-1, 1]: the acceleration command in the
world frame, normalized by the robot's a_max. Components outside [-1, 1]
are clipped to it; the command a_max * action (m/s^2) is then scaled by the
world to |a| <= a_max (a corner such as (1, 1) gives a_max in the diagonal
direction), and the speed limit v_max applies as in :mod:`nao_arena.world`.
An action of the wrong shape, NaN or inf, or not made of real numbers
(booleans, complex numbers, strings) raises ``ValueError``, as does a
missing action for a live agent, an unknown agent name, or actions that are
not a dict; actions for agents that are no longer live are ignored (the AEC
converter sends None).

Observations
------------
A float32 vector per agent (layout from :func:`observation_layout`), world
frame, units m, m/s, m/s^2, s:

- ``own`` (16): goal - position (2, m), velocity (2, m/s), measured
  acceleration (2, m/s^2, mean over the last control period, contacts
  included), last commanded acceleration (2, m/s^2, after clipping to a_max),
  a_max (m/s^2), v_max (m/s), radius (m), position (2, m), goal (2, m),
  time left until the time limit (s);
- ``neighbours`` (K x 9, K = ``max_neighbours``): the K nearest bodies
  within the arena's sensing range, nearest first (ties by body index), one
  row each: mask (1 = present), relative position (2, m), relative velocity
  (2, m/s), acceleration (2, m/s^2), radius (m), is_traffic (0/1: 1 for
  traffic and people, the bodies that are not robots); absent rows are all
  zero;
- ``nao`` (optional, ``nao_features=True``): the exact clearance (m, see
  :func:`nao_arena.geometry.nao_clearance`) of fixed candidate accelerations
  against the K neighbours' predicted paths (``nao_predictor``, default
  turn rate, over ``nao_horizon`` s; radii grown by the robot's radius and
  ``nao_margin``) and the nearby walls, the minimum over obstacles, clipped
  to [-nao_clip, nao_clip]; candidates on a polar grid in the world frame:
  for each ring fraction f of ``nao_rings`` (a = f a_max), ``nao_angles``
  directions starting at +x counter-clockwise (a single candidate for f =
  0). Negative clearance: that constant acceleration collides within the
  horizon if the predictions hold; nao_clip: nothing within reach;
- ``finished`` (1, only with ``keep_finished``): 1 once the agent has
  finished, else 0.

Observation bounds
------------------
The observation Box is finite wherever the quantity is bounded, with bounds
common to all agents (the maxima over the controlled robots, or over all
bodies for neighbour rows): velocities |v| <= v_max and relative velocities
<= v_max + the neighbour's v_max (speeds are capped at the end of every
period), measured accelerations <= 2 v_max / dt, commanded ones <= a_max,
a_max, v_max, radius >= 0, time left in [0, time limit], neighbour offsets
within the sensing range, goals within the map's bounds, masks and flags in
[0, 1], the NAO block in [-nao_clip, nao_clip]; dynamic bounds are widened
by a relative 1e-6 against rounding. Positions (x, y, and the goal offset)
are bounded by the map's bounds when walls close them (``bounds.walls``);
on open maps they are unbounded (inf) unless ``position_margin`` (m) is
set: then they are clipped to the bounds grown by that margin. Every
observation is clipped to its Box (a no-op except for positions clipped by
``position_margin``), so ``observation_space(a).contains(obs)`` always
holds. SuperSuit's ``normalize_obs_v0`` needs every bound finite: a walled
map, or ``position_margin``.

Rewards, terminations, truncations, infos
-----------------------------------------
Per step, with the weights of :class:`RewardWeights`: ``progress`` x the
decrease of the distance to the goal (m) - ``collision`` x the contact
episodes the robot started this step (bodies and walls) - ``accel_change``
x |a_t - a_(t-1)| / a_max of the commanded accelerations - ``step`` +
``goal`` on the step the goal is reached. Terminated: goal reached (within
the map's goal tolerance), or a collision if ``terminate_on_collision``.
Truncated: the time limit (``time_limit`` s, default the map's). Infos hold
numbers only, so that every RL library can stack them (TorchRL, RLlib,
SB3's VecEnv): ``collisions`` (int: the contact events of this robot that
started in the step), ``reached`` (bool), ``time`` (s), ``faults`` (int: its
agent's faults in the step), and with ``keep_finished`` ``finished`` (bool).
The events themselves, as dicts (see :class:`nao_arena.stats.ContactEvent`),
are in :attr:`NaoArenaParallelEnv.events` after each reset and step: agent ->
``{"collisions": [...], "faults": [...]}``.

Seeding
-------
``reset(seed=s)`` loads the map with ``seed=s`` when it declares a ``seed``
parameter (unless ``reseed_map=False``) and calls ``Arena.reset(s)``; a
reset without a seed draws the episode's seed from a generator seeded by
the last seeded reset (fresh entropy if never seeded). Same seed, same
actions: identical observations, rewards and infos.

``state()`` is the global state (layout in :meth:`NaoArenaParallelEnv.state`).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from gymnasium import spaces
from numba import njit
from numpy.typing import NDArray
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec

from nao_arena.arena import Arena, ArenaOptions, StepResult
from nao_arena.geometry.clearance import path_clearance
from nao_arena.maps import MapSpec, load_map, with_time_limit
from nao_arena.obstacles import obstacle_paths
from nao_arena.predictors import get_predictor
from nao_arena.sensing import Neighbours, neighbour_lists
from nao_arena.world import clip_accelerations

__all__ = [
    "NEIGHBOUR_FEATURES",
    "OWN_FEATURES",
    "EnvOptions",
    "NaoArenaParallelEnv",
    "RewardWeights",
    "env",
    "nao_candidates",
    "observation_layout",
    "parallel_env",
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

_BOUND_SLACK = 1e-6
"""Relative widening of the observation bounds that rounding could otherwise cross."""


@dataclass(frozen=True)
class RewardWeights:
    """Weights of the terms of each agent's reward (see "Rewards" in the module docstring)."""

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
    """Settings of the environment (see the module docstring); every field is also a
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


@njit(cache=True)
def _observation_rows(
    p: NDArray[np.float64],
    v: NDArray[np.float64],
    acc: NDArray[np.float64],
    rad: NDArray[np.float64],
    is_traffic: NDArray[np.float64],
    a_max: NDArray[np.float64],
    v_max: NDArray[np.float64],
    bodies: NDArray[np.int64],
    goals: NDArray[np.float64],
    prev_cmd: NDArray[np.float64],
    time_left: float,
    nb_start: NDArray[np.int64],
    nb_index: NDArray[np.int64],
    out: NDArray[np.float64],
    idx: NDArray[np.int64],
    present: NDArray[np.bool_],
) -> None:
    """Fill the own and neighbour blocks of ``out`` (m, D, zeroed) for the robots ``bodies``
    (goals (m, 2) m, last commands (m, 2) m/s^2) with the first K = idx.shape[1]
    neighbours of each in the lists ``nb_index[nb_start[i]:nb_start[i + 1]]``
    (:func:`~nao_arena.sensing.neighbour_lists`: nearest first; the robot itself, listed
    last with an infinite range, is skipped; absent rows stay zero); ``idx`` /
    ``present`` (m, K) get the neighbours' body indices and the row mask."""
    k = idx.shape[1]
    n_own = 16
    for i in range(bodies.shape[0]):
        b = bodies[i]
        o = out[i]
        o[0] = goals[i, 0] - p[b, 0]
        o[1] = goals[i, 1] - p[b, 1]
        o[2] = v[b, 0]
        o[3] = v[b, 1]
        o[4] = acc[b, 0]
        o[5] = acc[b, 1]
        o[6] = prev_cmd[i, 0]
        o[7] = prev_cmd[i, 1]
        o[8] = a_max[b]
        o[9] = v_max[b]
        o[10] = rad[b]
        o[11] = p[b, 0]
        o[12] = p[b, 1]
        o[13] = goals[i, 0]
        o[14] = goals[i, 1]
        o[15] = time_left
        r = 0
        for e in range(nb_start[i], nb_start[i + 1]):
            j = nb_index[e]
            if j == b or r == k:
                continue
            idx[i, r] = j
            present[i, r] = True
            c = n_own + 9 * r
            o[c] = 1.0
            o[c + 1] = p[j, 0] - p[b, 0]
            o[c + 2] = p[j, 1] - p[b, 1]
            o[c + 3] = v[j, 0] - v[b, 0]
            o[c + 4] = v[j, 1] - v[b, 1]
            o[c + 5] = acc[j, 0]
            o[c + 6] = acc[j, 1]
            o[c + 7] = rad[j]
            o[c + 8] = is_traffic[j]
            r += 1


_REAL_KINDS = frozenset("iuf")
"""numpy dtype kinds accepted in actions: signed and unsigned integers, floats."""


def _check_real(name: str, action: Any) -> None:
    """ValueError unless ``action`` is made of real numbers (not bool, complex, str, object)."""
    if type(action) is np.ndarray and action.dtype.kind in _REAL_KINDS:
        return  # the common case
    if isinstance(action, (list, tuple)) and any(isinstance(x, (bool, np.bool_)) for x in action):
        kind = "b"
    else:
        try:
            kind = np.asarray(action).dtype.kind
        except (TypeError, ValueError):
            return  # not an array at all: the shape check explains it
    if kind not in _REAL_KINDS:
        what = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes"}.get(
            kind, "objects"
        )
        raise ValueError(
            f"action of {name!r}: expected real numbers (a float array of shape "
            f"(2,)), got {what}: {action!r}"
        )


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


class NaoArenaParallelEnv(ParallelEnv):
    """A map's arena as a PettingZoo parallel env (see the module docstring)."""

    metadata: dict[str, Any] = {
        "name": "nao_arena_v0",
        "render_modes": ["human", "rgb_array"],
        "is_parallelizable": True,
        "render_fps": 10,
    }

    def __init__(
        self,
        map: str | Path = "roundabout",  # noqa: A002 - the issue's public keyword
        render_mode: str | None = None,
        options: EnvOptions | None = None,
        map_params: Mapping[str, Any] | None = None,
        **kwargs: Any,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode: expected one of {self.metadata['render_modes']} "
                f"or None, got {render_mode!r}"
            )
        self.options, self.map_params = _split_kwargs(options, map_params, kwargs)
        self.map_source = map
        self.render_mode = render_mode
        spec = self._load(self.map_params)
        self._declared = frozenset(spec.parameters)
        self._install(spec)
        # the robots under test (people, after them, keep their own agents)
        robot_names = [r.name or f"robot{i}" for i, r in enumerate(spec.robots[: spec.n_robots])]
        self._controlled = self._resolve_controlled(self.options.controlled, robot_names)
        names = [robot_names[k] for k in self._controlled]
        self.possible_agents: list[str] = (
            grouped_names(names) if self.options.agent_names == "grouped" else names
        )
        self._row = {name: i for i, name in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        self.metadata = {**self.metadata, "render_fps": 1.0 / spec.physics.dt}
        self._cand = nao_candidates(self.options) if self.options.nao_features else None
        self._build_spaces()
        self._rng = np.random.default_rng()
        self._viewer: Any = None
        self.last_result: StepResult | None = None
        self.events: dict[str, dict[str, list[dict[str, Any]]]] = {}
        """The last reset's or step's events by agent: ``{"collisions": [contact event
        dicts], "faults": [fault dicts]}`` (the infos hold their counts)."""

    def __getstate__(self) -> dict[str, Any]:
        """Everything but the viewer (pygame objects; a copy opens its own on render)."""
        state = self.__dict__.copy()
        state["_viewer"] = None
        return state

    # ------------------------------------------------------------------ setup

    def _load(self, params: Mapping[str, Any]) -> MapSpec:
        spec = load_map(
            self.map_source,
            trusted=self.options.trust_map,
            agents=self.options.named_agents,
            **params,
        )
        if self.options.time_limit is not None:
            spec = with_time_limit(spec, self.options.time_limit)
        return spec

    def _install(self, spec: MapSpec) -> None:
        """A fresh arena for ``spec`` and the per-robot constants derived from it."""
        self.spec = spec
        self.arena = Arena(spec, self.options.arena)
        world = self.arena.world
        # is_traffic: 1 for the bodies that are not robots (traffic and people)
        self._kinds = np.array([k != "robot" for k in world.kinds], dtype=float)
        self._world_a_max = np.ascontiguousarray(world.a_max, dtype=np.float64)
        self._world_v_max = np.ascontiguousarray(world.v_max, dtype=np.float64)
        self._sensing_range = float(self.arena.sensing_range)
        k = min(self.options.max_neighbours, world.n - 1)
        if self.arena.max_neighbours is not None:
            k = min(k, int(self.arena.max_neighbours))
        self._k = max(k, 0)
        self._walls = None
        if self.options.nao_features and self.options.nao_walls and len(self.arena.walls):
            self._walls = (
                np.ascontiguousarray(self.arena.walls, dtype=np.float64),
                np.ascontiguousarray(self.arena.wall_radius, dtype=np.float64),
            )

    @staticmethod
    def _resolve_controlled(controlled: str | Sequence[str | int], names: list[str]) -> list[int]:
        if isinstance(controlled, str):
            if controlled == "all":
                out = list(range(len(names)))
            elif controlled in names:
                out = [names.index(controlled)]
            else:
                raise ValueError(
                    f"controlled: expected 'all', robot names or indices; unknown "
                    f"robot {controlled!r} (robots: {', '.join(names)})"
                )
        else:
            out = []
            for c in controlled:
                if isinstance(c, int | np.integer) and not isinstance(c, bool):
                    if not 0 <= int(c) < len(names):
                        raise ValueError(
                            f"controlled: robot index {c} out of range (0..{len(names) - 1})"
                        )
                    out.append(int(c))
                elif isinstance(c, str) and c in names:
                    out.append(names.index(c))
                else:
                    raise ValueError(
                        f"controlled: unknown robot {c!r} (robots: {', '.join(names)})"
                    )
            out = sorted(set(out))
        if not out:
            raise ValueError(
                "controlled: expected at least one robot; the map has none"
                if not names
                else "controlled: expected at least one robot"
            )
        return out

    def _build_spaces(self) -> None:
        lay = observation_layout(self.options)
        self._layout = lay
        dim = lay["finished"].stop
        low, high = self._observation_bounds(lay)
        self._obs_dim = dim
        self._observation_spaces = {
            a: spaces.Box(
                low.astype(np.float32), high.astype(np.float32), shape=(dim,), dtype=np.float32
            )
            for a in self.possible_agents
        }
        box = self._observation_spaces[self.possible_agents[0]]
        # observations are clipped to the float32 bounds themselves (see _observe)
        self._obs_low = box.low.astype(np.float64)
        self._obs_high = box.high.astype(np.float64)
        self._action_spaces = {
            a: spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32) for a in self.possible_agents
        }
        n, r = self.arena.world.n, len(self.arena.robots)
        sdim = 1 + 8 * n + 2 * r
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(sdim,), dtype=np.float32)

    def _observation_bounds(
        self, lay: dict[str, slice]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper bounds (D,) of the observation entries (module docstring,
        "Observation bounds"); dynamic bounds widened by a relative _BOUND_SLACK."""
        world = self.arena.world
        ctl = self.arena.robot_ids[self._controlled]
        wide = 1.0 + _BOUND_SLACK
        v_all, v_own = float(np.max(world.v_max)), float(np.max(world.v_max[ctl]))
        a_own = float(np.max(world.a_max[ctl]))
        r_all, r_own = float(np.max(world.radii)), float(np.max(world.radii[ctl]))
        bounds = self.spec.bounds
        lo, hi = np.array(bounds.min, dtype=float), np.array(bounds.max, dtype=float)
        if self.options.position_margin is not None:
            p_lo, p_hi = lo - self.options.position_margin, hi + self.options.position_margin
        elif bounds.walls:
            p_lo, p_hi = lo, hi
        else:
            p_lo, p_hi = np.full(2, -np.inf), np.full(2, np.inf)
        v, acc, dv = v_own * wide, 2.0 * v_own / world.dt * wide, (v_all + v_own) * wide
        own = {
            "goal_dx": ((lo[0] - p_hi[0]) * wide, (hi[0] - p_lo[0]) * wide),
            "goal_dy": ((lo[1] - p_hi[1]) * wide, (hi[1] - p_lo[1]) * wide),
            "vx": (-v, v),
            "vy": (-v, v),
            "ax": (-acc, acc),
            "ay": (-acc, acc),
            "cmd_ax": (-a_own * wide, a_own * wide),
            "cmd_ay": (-a_own * wide, a_own * wide),
            "a_max": (0.0, a_own),
            "v_max": (0.0, v_own),
            "radius": (0.0, r_own),
            "x": (p_lo[0], p_hi[0]),
            "y": (p_lo[1], p_hi[1]),
            "goal_x": (lo[0], hi[0]),
            "goal_y": (lo[1], hi[1]),
            "time_left": (0.0, self.time_limit),
        }
        reach = self._sensing_range * wide
        reach_xy = [reach if math.isfinite(reach) else p_hi[i] - p_lo[i] for i in (0, 1)]
        acc_all = 2.0 * v_all / world.dt * wide
        row = {
            "mask": (0.0, 1.0),
            "dx": (-reach_xy[0], reach_xy[0]),
            "dy": (-reach_xy[1], reach_xy[1]),
            "dvx": (-dv, dv),
            "dvy": (-dv, dv),
            "ax": (-acc_all, acc_all),
            "ay": (-acc_all, acc_all),
            "radius": (0.0, r_all),
            "is_traffic": (0.0, 1.0),
        }
        k = self.options.max_neighbours
        pairs = (
            [own[f] for f in OWN_FEATURES]
            + [row[f] for f in NEIGHBOUR_FEATURES] * k
            + [(-self.options.nao_clip, self.options.nao_clip)]
            * (lay["nao"].stop - lay["nao"].start)
            + [(0.0, 1.0)] * (lay["finished"].stop - lay["finished"].start)
        )
        out = np.array(pairs, dtype=np.float64).reshape(-1, 2)
        return out[:, 0].copy(), out[:, 1].copy()

    def observation_space(self, agent: str) -> spaces.Box:
        """The agent's observation space (the same object on every call)."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        """The agent's action space: normalized acceleration (2,) in [-1, 1]."""
        return self._action_spaces[agent]

    # ------------------------------------------------------------------ episode

    @property
    def time_limit(self) -> float:
        """The episode's time limit (s)."""
        return float(self.spec.episode.time_limit)

    @property
    def max_steps(self) -> int:
        """The control steps of an episode that runs to its time limit (every agent is
        truncated in that step at the latest)."""
        return math.ceil(self.time_limit / self.arena.world.dt - 1e-9)

    def reset(
        self, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float32]], dict[str, dict[str, Any]]]:
        """Start an episode; ``options`` is accepted for API compatibility and ignored."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
            episode_seed = int(seed)
        else:
            episode_seed = int(self._rng.integers(2**31 - 1))
        if self.options.reseed_map and "seed" in self._declared:
            if self.spec.parameters.get("seed") != episode_seed:
                spec = self._load({**self.map_params, "seed": episode_seed})
                old = [r.name for r in self.spec.robots]
                if [r.name for r in spec.robots] != old:
                    raise ValueError(
                        "the map's robots changed with its seed; expected the same "
                        "robot names in every episode"
                    )
                self._install(spec)
        self.arena.reset(episode_seed)
        self.agents = list(self.possible_agents)
        self._alive = np.ones(len(self.possible_agents), dtype=bool)
        self._bodies = self.arena.robot_ids[self._controlled].astype(np.int64)
        self._goals = self.arena.goals[self._controlled]
        self._a_max = self.arena.world.a_max[self._bodies]
        self._prev_cmd = np.zeros((len(self._controlled), 2))
        state = self.arena.state
        assert state is not None
        self._dist = np.hypot(*(state.positions[self._bodies] - self._goals).T)
        self.last_result = None
        rows = np.arange(len(self.possible_agents))
        obs = self._observe(rows)
        infos: dict[str, dict[str, Any]] = {
            a: {"collisions": 0, "reached": False, "time": 0.0, "faults": 0} for a in self.agents
        }
        self.events = {a: {"collisions": [], "faults": []} for a in self.agents}
        if self.options.keep_finished:
            for info in infos.values():
                info["finished"] = False
        if self.render_mode == "human":
            self.render()
        return {a: obs[i] for i, a in enumerate(self.agents)}, infos

    def _actions_array(self, actions: Mapping[str, Any], live: list[str]) -> NDArray[np.float64]:
        """Validated actions (m, 2) of the live agents, in ``live`` order, clipped to [-1, 1].

        Each action must be real numbers (ints or floats; not booleans, complex numbers,
        strings or objects) of shape (2,), finite; else ValueError naming the agent."""
        if not isinstance(actions, Mapping):
            raise ValueError(
                f"actions: expected a dict of agent name -> action of shape (2,), "
                f"got {type(actions).__name__}"
            )
        if not self._row.keys() >= actions.keys():
            name = next(a for a in actions if a not in self._row)
            raise ValueError(
                f"action for unknown agent {name!r}; expected one of "
                f"{', '.join(self.possible_agents)}"
            )
        if len(actions) < len(live) or not actions.keys() >= set(live):
            missing = [a for a in live if a not in actions]
            raise ValueError(f"missing actions for live agents: {', '.join(missing)}")
        for a in live:
            _check_real(a, actions[a])
        try:
            arr = np.array([actions[a] for a in live], dtype=np.float64)
        except (TypeError, ValueError):
            arr = None
        if arr is None or arr.shape != (len(live), 2):
            for a in live:
                try:
                    one = np.asarray(actions[a], dtype=np.float64)
                except (TypeError, ValueError):
                    raise ValueError(
                        f"action of {a!r}: expected a numeric array of shape "
                        f"(2,), got {actions[a]!r}"
                    ) from None
                if one.shape != (2,):
                    raise ValueError(f"action of {a!r}: expected shape (2,), got {one.shape}")
            raise ValueError("expected actions of shape (2,)")
        if not np.all(np.isfinite(arr)):
            bad = [a for a, row in zip(live, arr, strict=True) if not np.all(np.isfinite(row))]
            raise ValueError(
                f"action of {bad[0]!r}: expected finite values, got "
                f"{np.asarray(actions[bad[0]]).tolist()}"
            )
        return np.clip(arr, -1.0, 1.0)

    def step(
        self, actions: Mapping[str, Any]
    ) -> tuple[
        dict[str, NDArray[np.float32]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """One control period: the live agents' normalized accelerations -> the usual five dicts
        over the agents live at the start of the step."""
        if self.arena.stats is None:
            raise RuntimeError("call reset() before step()")
        live = self.agents
        if not live:
            return {}, {}, {}, {}, {}
        live_rows = np.fromiter((self._row[a] for a in live), dtype=np.intp, count=len(live))
        cmd = self._actions_array(actions, live) * self._a_max[live_rows, None]
        keep = self.options.keep_finished
        if keep:
            # finished agents stay live; their actions are ignored
            acting = self._alive[live_rows]
            rows, cmd = live_rows[acting], cmd[acting]
        else:
            rows = live_rows
        arena_actions: dict[int, NDArray[np.float64]] = dict(
            zip(np.asarray(self._controlled)[rows].tolist(), cmd, strict=True)
        )
        if self.options.after_done == "hold" and not np.all(self._alive):
            dead = np.flatnonzero(~self._alive)
            assert self.arena.state is not None  # reset() set it, with the stats
            v = self.arena.state.velocities[self._bodies[dead]]
            brake = clip_accelerations(-v / self.arena.world.dt, self._a_max[dead])
            for i, a in zip(dead.tolist(), brake, strict=True):
                arena_actions[self._controlled[i]] = a
        res = self.arena.step(arena_actions)
        self.last_result = res
        state = res.state
        opts = self.options
        w = opts.rewards
        bodies = self._bodies[rows]
        # reward terms
        dist = np.hypot(*(state.positions[bodies] - self._goals[rows]).T)
        applied = clip_accelerations(cmd, self._a_max[rows])
        change = np.hypot(*(applied - self._prev_cmd[rows]).T) / self._a_max[rows]
        self._prev_cmd[rows] = applied
        reached = self.arena.stats.reached[bodies]
        reward = w.progress * (self._dist[rows] - dist) - w.accel_change * change - w.step
        reward = reward + w.goal * reached
        self._dist[rows] = dist
        events: dict[int, list[dict[str, Any]]] = {}
        for ev in res.contacts:
            events.setdefault(ev.a, []).append(ev.to_dict())
            if ev.kind_b != "wall":
                events.setdefault(ev.b, []).append(ev.to_dict())
        n_col = np.array([len(events.get(int(b), ())) for b in bodies]) if events else None
        if n_col is not None:
            reward = reward - w.collision * n_col
        faults: dict[int, list[dict[str, Any]]] = {}
        for f in res.faults:
            faults.setdefault(int(self.arena.robot_ids[f.robot]), []).append(dataclasses.asdict(f))
        terminated = reached.copy()
        if opts.terminate_on_collision and n_col is not None:
            terminated |= n_col > 0
        time_up = res.time >= self.time_limit - 1e-9
        if keep:
            return self._step_keep(
                live, live_rows, rows, reward, terminated, time_up, events, faults, res
            )
        obs = self._observe(rows)
        out_obs, out_rew, out_term, out_trunc, out_info = {}, {}, {}, {}, {}
        out_events: dict[str, dict[str, list[dict[str, Any]]]] = {}
        reached_l = reached.tolist()
        term_l = terminated.tolist()
        rew_l = reward.tolist()
        t = float(res.time)
        for i, a in enumerate(live):
            b = int(bodies[i])
            out_obs[a] = obs[i]
            out_rew[a] = rew_l[i]
            out_term[a] = term_l[i]
            out_trunc[a] = time_up
            out_info[a] = {
                "collisions": len(events.get(b, ())),
                "reached": reached_l[i],
                "time": t,
                "faults": len(faults.get(b, ())),
            }
            out_events[a] = {"collisions": events.get(b, []), "faults": faults.get(b, [])}
        self.events = out_events
        done = terminated | time_up
        if np.any(done):
            self._alive[rows[done]] = False
            self.agents = [a for a, d in zip(live, done.tolist(), strict=True) if not d]
        if self.render_mode == "human":
            self.render()
        return out_obs, out_rew, out_term, out_trunc, out_info

    def _step_keep(
        self,
        live: list[str],
        live_rows: NDArray[np.intp],
        rows: NDArray[np.intp],
        reward: NDArray[np.float64],
        terminated: NDArray[np.bool_],
        time_up: bool,
        events: dict[int, list[dict[str, Any]]],
        faults: dict[int, list[dict[str, Any]]],
        res: StepResult,
    ) -> tuple[
        dict[str, NDArray[np.float32]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """The end of :meth:`step` with ``keep_finished``: ``rows`` (the acting agents among
        ``live_rows``) got ``reward`` and ``terminated``; every live agent stays live until
        the time limit or until all have finished."""
        finished_before = ~self._alive[live_rows]
        self._alive[rows[terminated]] = False
        # what drove the finished robots (their agent, or braking), as the world applied it
        held = live_rows[finished_before]
        self._prev_cmd[held] = clip_accelerations(
            res.commanded[self._bodies[held]], self._a_max[held]
        )
        obs = self._observe(live_rows)
        end = time_up or not np.any(self._alive)
        finished = ~self._alive[live_rows]
        rew = np.zeros(len(live_rows))
        rew[~finished_before] = reward
        assert self.arena.stats is not None  # step() checked it
        reached = self.arena.stats.reached[self._bodies[live_rows]].tolist()
        t = float(res.time)
        out_obs, out_rew, out_term, out_trunc, out_info = {}, {}, {}, {}, {}
        out_events: dict[str, dict[str, list[dict[str, Any]]]] = {}
        for i, a in enumerate(live):
            b = int(self._bodies[live_rows[i]])
            fin = bool(finished[i])
            out_obs[a] = obs[i]
            out_rew[a] = float(rew[i])
            out_term[a] = end and fin
            out_trunc[a] = end and time_up and not fin
            out_info[a] = {
                "collisions": len(events.get(b, ())),
                "reached": reached[i],
                "time": t,
                "faults": len(faults.get(b, ())),
                "finished": fin,
            }
            out_events[a] = {"collisions": events.get(b, []), "faults": faults.get(b, [])}
        self.events = out_events
        if end:
            self._alive[live_rows] = False
            self.agents = []
        if self.render_mode == "human":
            self.render()
        return out_obs, out_rew, out_term, out_trunc, out_info

    @property
    def finished_agents(self) -> list[str]:
        """The agents in ``agents`` that have finished (``keep_finished``: their actions
        are ignored; always empty without it, as finished agents leave ``agents``)."""
        return [a for a in self.agents if not self._alive[self._row[a]]]

    # ------------------------------------------------------------------ observations

    def observations(self) -> dict[str, NDArray[np.float32]]:
        """The live agents' observations of the current state (as returned by the last
        reset or step)."""
        if self.arena.state is None:
            raise RuntimeError("call reset() first")
        rows = np.fromiter(
            (self._row[a] for a in self.agents), dtype=np.intp, count=len(self.agents)
        )
        obs = self._observe(rows)
        return {a: obs[i] for i, a in enumerate(self.agents)}

    def _observe(self, rows: NDArray[np.intp]) -> NDArray[np.float32]:
        """Observation vectors (len(rows), D) of the controlled robots ``rows``."""
        state = self.arena.state
        assert state is not None
        opts = self.options
        m = len(rows)
        out = np.zeros((m, self._obs_dim), dtype=np.float64)
        if m == 0:
            return out.astype(np.float32)
        bodies = self._bodies[rows]
        p, v, acc, rad = state.positions, state.velocities, state.accelerations, state.radii
        k = self._k
        idx = np.zeros((m, k), dtype=np.int64)
        present = np.zeros((m, k), dtype=np.bool_)
        # the sensing's neighbour search, with the env's distances (math.hypot)
        nb_start, nb_index = neighbour_lists(bodies, p, self._sensing_range, k, hypot=True)
        _observation_rows(
            p,
            v,
            acc,
            rad,
            self._kinds,
            self._world_a_max,
            self._world_v_max,
            bodies,
            self._goals[rows],
            self._prev_cmd[rows],
            max(self.time_limit - state.time, 0.0),
            nb_start,
            nb_index,
            out,
            idx,
            present,
        )
        if self._cand is not None:
            out[:, self._layout["nao"]] = self._nao_block(bodies, idx, present)
        if opts.keep_finished:
            out[:, self._layout["finished"]] = ~self._alive[rows, None]
        np.clip(out, self._obs_low, self._obs_high, out=out)
        return out.astype(np.float32)

    def _nao_block(
        self, bodies: NDArray[np.intp], idx: NDArray[np.intp], present: NDArray[np.bool_]
    ) -> NDArray[np.float64]:
        """Clipped clearance (m, M) of the candidate accelerations for each robot."""
        state = self.arena.state
        assert state is not None and self._cand is not None
        opts = self.options
        world = self.arena.world
        times = np.linspace(0.0, opts.nao_horizon, opts.nao_samples)
        flat = idx[present]
        predicted = np.zeros((0, len(times), 2))
        if len(flat):
            nb = Neighbours(
                ids=flat.astype(np.int64),
                kinds=tuple(world.kinds[i] for i in flat.tolist()),
                positions=state.positions[flat],
                velocities=state.velocities[flat],
                accelerations=state.accelerations[flat],
                radii=state.radii[flat],
            )
            predicted = get_predictor(opts.nao_predictor)(times, nb)
        counts = present.sum(axis=1)
        starts = np.concatenate([[0], np.cumsum(counts)])
        out = np.full((len(bodies), len(self._cand)), opts.nao_clip)
        h = opts.nao_horizon
        for i, b in enumerate(bodies.tolist()):
            r_own = float(state.radii[b])
            a_max, v_max = float(world.a_max[b]), float(world.v_max[b])
            grow = r_own + opts.nao_margin
            walls, half = self._walls if self._walls is not None else (None, None)
            # the agent's obstacles, without its radius cut: the walls within reach
            path = obstacle_paths(
                times,
                predicted[starts[i] : starts[i + 1]],
                state.radii[flat[starts[i] : starts[i + 1]]] + grow,
                state.positions[b],
                walls,
                None if half is None else half + grow,
                v_max * h + 0.5 * a_max * h * h,
                cut=False,
            )
            if path.n_obstacles == 0:
                continue
            clear = path_clearance(self._cand * a_max, state.velocities[b], path, v_max=v_max)
            out[i] = np.min(clear.clearance, axis=1)
        return np.clip(out, -opts.nao_clip, opts.nao_clip)

    def state(self) -> NDArray[np.float32]:
        """Global state (float32): time (s); per body in world order x, y (m), vx, vy (m/s),
        ax, ay (m/s^2), radius (m), is_traffic; per robot goal x, y (m)."""
        st = self.arena.state
        if st is None:
            raise RuntimeError("call reset() before state()")
        bodies = np.column_stack(
            [st.positions, st.velocities, st.accelerations, st.radii, self._kinds]
        )
        return np.concatenate([[st.time], bodies.ravel(), self.arena.goals.ravel()]).astype(
            np.float32
        )

    # ------------------------------------------------------------------ rendering

    @property
    def controlled_robots(self) -> list[int]:
        """Robot indices (robot order) of the controlled robots, as ``possible_agents``."""
        return list(self._controlled)

    def _selected_robot(self) -> int:
        sel = self.options.selected
        names = [r.name for r in self.spec.robots]
        if sel is None:
            live = [self._controlled[self._row[a]] for a in self.agents]
            return live[0] if live else self._controlled[0]
        if isinstance(sel, str):
            if sel not in names:
                raise ValueError(
                    f"selected: unknown robot {sel!r} (robots: {', '.join(map(str, names))})"
                )
            return names.index(sel)
        return int(sel)

    def render(self) -> NDArray[np.uint8] | None:
        """rgb_array: a (H, W, 3) uint8 frame (``render_size``); human: draw in a window."""
        if self.render_mode is None:
            return None
        if self.arena.state is None:
            raise RuntimeError("call reset() before render()")
        from nao_arena.render import Viewer, ViewerOptions

        if self._viewer is None:
            self._viewer = Viewer(
                ViewerOptions(size=self.options.render_size), human=self.render_mode == "human"
            )
        frame = self._viewer.draw(
            self.arena,
            selected=self._selected_robot(),
            controlled=self._controlled,
            result=self.last_result,
        )
        return frame if self.render_mode == "rgb_array" else None

    def close(self) -> None:
        """Close the viewer's window, if any."""
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None

    def __str__(self) -> str:
        return f"nao_arena({self.spec.name})"


def parallel_env(
    map: str | Path = "roundabout",  # noqa: A002 - the issue's public keyword
    render_mode: str | None = None,
    **kwargs: Any,
) -> NaoArenaParallelEnv:
    """The map's PettingZoo parallel env; keywords: :class:`EnvOptions` fields, ``options=``,
    ``map_params=``, and map parameters (see the module docstring)."""
    return NaoArenaParallelEnv(map, render_mode=render_mode, **kwargs)


def env(
    map: str | Path = "roundabout",  # noqa: A002 - the issue's public keyword
    render_mode: str | None = None,
    **kwargs: Any,
) -> AECEnv:
    """The AEC version of :func:`parallel_env` (PettingZoo's ``parallel_to_aec``)."""
    return parallel_to_aec(parallel_env(map, render_mode=render_mode, **kwargs))
