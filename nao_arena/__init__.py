"""nao_arena: a physics-simulated multi-robot testbed built around the
Nonlinear Acceleration Obstacle (NAO).

Units everywhere: metres, seconds, m/s, m/s^2; angles in radians.

The front door: the names in ``__all__``, each imported from its module on
first use, so that ``import nao_arena`` stays light (no pymunk, numba,
pettingzoo or pygame until a name needs them)::

    from nao_arena import Arena, load_map
    summary = Arena(load_map("circle_swap", n=4)).run(seed=0)

- :class:`Arena`, :class:`ArenaOptions`: the control loop (:mod:`nao_arena.arena`);
- :func:`load_map`, :func:`available_maps`: map files (:mod:`nao_arena.maps`);
- :func:`parallel_env`, :func:`env`: the PettingZoo envs (:mod:`nao_arena.environment`);
  :class:`VectorEnv`: K copies of one stepped together (:mod:`nao_arena.vector`);
- :class:`Agent`, :class:`Observation`: the agent protocol and what an agent
  senses (:mod:`nao_arena.agent`, :mod:`nao_arena.sensing`);
- the geometry functions and :class:`AccelLimits` (:mod:`nao_arena.geometry`).
"""

from pathlib import Path as _Path
from typing import TYPE_CHECKING

from nao_arena import _checkout

__version__ = "0.1.0"

_checkout.install(_Path(__file__).resolve().parent)
del _Path

if TYPE_CHECKING:
    from nao_arena.agent import Agent, AgentFault, BatchAgent
    from nao_arena.arena import Arena, ArenaOptions, StepResult
    from nao_arena.env_step import StepArrays
    from nao_arena.environment import env, parallel_env
    from nao_arena.geometry import (
        AccelLimits,
        Clearance,
        ObstacleBoundary,
        PiecewisePath,
        Selection,
        ao_boundary,
        ao_boundary_paper,
        ao_clearance,
        ao_path,
        bao_boundary,
        grown_with_time,
        nao_boundary,
        nao_clearance,
        nao_query,
        path_boundary,
        path_clearance,
        repair_acceleration,
        sampled_path,
        select_acceleration,
        vo_clearance,
        vo_cone,
    )
    from nao_arena.maps import MapError, MapSpec, RobotSpec, available_maps, load_map
    from nao_arena.sensing import Neighbours, Observation, SensingBatch
    from nao_arena.stats import ContactEvent, EpisodeSummary
    from nao_arena.vector import VectorEnv
    from nao_arena.world import WorldState

del TYPE_CHECKING

__all__ = [
    "AccelLimits",
    "Agent",
    "AgentFault",
    "Arena",
    "ArenaOptions",
    "BatchAgent",
    "Clearance",
    "ContactEvent",
    "EpisodeSummary",
    "MapError",
    "MapSpec",
    "Neighbours",
    "Observation",
    "ObstacleBoundary",
    "PiecewisePath",
    "RobotSpec",
    "Selection",
    "SensingBatch",
    "StepArrays",
    "StepResult",
    "VectorEnv",
    "WorldState",
    "__version__",
    "ao_boundary",
    "ao_boundary_paper",
    "ao_clearance",
    "ao_path",
    "available_maps",
    "bao_boundary",
    "env",
    "grown_with_time",
    "load_map",
    "nao_boundary",
    "nao_clearance",
    "nao_query",
    "parallel_env",
    "path_boundary",
    "path_clearance",
    "repair_acceleration",
    "sampled_path",
    "select_acceleration",
    "vo_clearance",
    "vo_cone",
]

_GEOMETRY = (
    "AccelLimits",
    "Clearance",
    "ObstacleBoundary",
    "PiecewisePath",
    "Selection",
    "ao_boundary",
    "ao_boundary_paper",
    "ao_clearance",
    "ao_path",
    "bao_boundary",
    "grown_with_time",
    "nao_boundary",
    "nao_clearance",
    "nao_query",
    "path_boundary",
    "path_clearance",
    "repair_acceleration",
    "sampled_path",
    "select_acceleration",
    "vo_clearance",
    "vo_cone",
)

_EXPORTS: dict[str, str] = {
    "Agent": "nao_arena.agent",
    "AgentFault": "nao_arena.agent",
    "BatchAgent": "nao_arena.agent",
    "ContactEvent": "nao_arena.stats",
    "EpisodeSummary": "nao_arena.stats",
    "MapError": "nao_arena.maps",
    "MapSpec": "nao_arena.maps",
    "Neighbours": "nao_arena.sensing",
    "RobotSpec": "nao_arena.maps",
    "SensingBatch": "nao_arena.sensing",
    "StepArrays": "nao_arena.env_step",
    "StepResult": "nao_arena.arena",
    "VectorEnv": "nao_arena.vector",
    "WorldState": "nao_arena.world",
    "Arena": "nao_arena.arena",
    "ArenaOptions": "nao_arena.arena",
    "Observation": "nao_arena.sensing",
    "available_maps": "nao_arena.maps",
    "env": "nao_arena.environment",
    "load_map": "nao_arena.maps",
    "parallel_env": "nao_arena.environment",
    **dict.fromkeys(_GEOMETRY, "nao_arena.geometry"),
}
"""Public name -> the module that defines it (imported on first use)."""


_SUBPACKAGES = ("envs",)
"""Sub-packages reachable as attributes after ``import nao_arena`` (``nao_arena.envs``, the
versioned envs), imported on first use."""


def __getattr__(name: str) -> object:
    """Import an exported name from its module on first use (then it is a global); the
    sub-packages of :data:`_SUBPACKAGES` likewise."""
    from importlib import import_module

    if name in _SUBPACKAGES:
        return import_module(f"nao_arena.{name}")
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'nao_arena' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The exported names and the module's dunder attributes (not its submodules)."""
    return sorted({*__all__, *(n for n in globals() if n.startswith("__"))})
