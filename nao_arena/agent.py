"""The agent protocol and plug-in loading.

An agent drives one robot::

    class MyAgent:
        def reset(self, spec, rng):       # spec: the robot's map entry; rng: numpy Generator
            self.gain = 1.5
        def act(self, obs):               # obs: nao_arena.sensing.Observation
            to_goal = obs.goal - obs.position
            return self.gain * to_goal - 2.0 * obs.velocity   # acceleration (2,) m/s^2

Agents are named by a built-in name (``nao``, ``ao``, ``vo``, ``orca``,
``goal``, ``lane``), by ``path/to/file.py:ClassName``, by
``package.module:ClassName``, or by an entry point in the group
``nao_arena.agents``. Agent classes take keyword options in their
constructor (e.g. ``horizon=4.0``).

Containment: an agent that raises or returns something that is not a
finite (2,) acceleration gets zero acceleration for that step, and the
fault is recorded (see :func:`safe_act`).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from dataclasses import dataclass
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from nao_arena.sensing import Observation

__all__ = ["BUILTIN_AGENTS", "Agent", "AgentFault", "available_agents", "load_agent", "safe_act"]

ENTRY_POINT_GROUP = "nao_arena.agents"

BUILTIN_AGENTS: dict[str, str] = {
    "nao": "nao_arena.agents.nao:NAOAgent",
    "ao": "nao_arena.agents.nao:AOAgent",
    "vo": "nao_arena.agents.vo:VOAgent",
    "orca": "nao_arena.agents.orca:ORCAAgent",
    "goal": "nao_arena.agents.goal:GoalAgent",
    "lane": "nao_arena.agents.lane:LaneAgent",
}


@runtime_checkable
class Agent(Protocol):
    """Drives one robot: ``reset`` once per episode, ``act`` once per control step."""

    def reset(self, spec: Any, rng: np.random.Generator) -> None: ...

    def act(self, obs: Observation) -> NDArray[np.float64]: ...


@dataclass(frozen=True)
class AgentFault:
    """An agent's failure at one step: time (s), robot index and what went wrong."""

    time: float
    robot: int
    agent: str
    message: str


def _load_from_file(path: str, cls: str) -> type:
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"agent {path}:{cls}: no such file {file}")
    name = f"nao_arena_plugin_{abs(hash(str(file.resolve())))}"
    spec = importlib.util.spec_from_file_location(name, file)
    if spec is None or spec.loader is None:
        raise ValueError(f"agent {path}:{cls}: cannot import {file}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    try:
        return getattr(module, cls)
    except AttributeError:
        raise ValueError(f"agent {path}:{cls}: {file} defines no {cls!r}") from None


def _load_from_module(module_name: str, cls: str) -> type:
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"agent {module_name}:{cls}: cannot import {module_name}: {exc}") from exc
    try:
        return getattr(module, cls)
    except AttributeError:
        raise ValueError(f"agent {module_name}:{cls}: {module_name} defines no {cls!r}") from None


def _plugins() -> dict[str, Any]:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def available_agents() -> dict[str, str]:
    """Name -> reference of every agent available: built-ins, then entry points."""
    found = dict(BUILTIN_AGENTS)
    for name, ep in sorted(_plugins().items()):
        found.setdefault(name, ep.value)
    return found


def load_agent(ref: str) -> type:
    """The agent class named by ``ref`` (built-in name, FILE.py:Class, module:Class, plug-in)."""
    if ref in BUILTIN_AGENTS:
        module_name, cls = BUILTIN_AGENTS[ref].split(":")
        return _load_from_module(module_name, cls)
    if ":" in ref:
        target, cls = ref.rsplit(":", 1)
        if target.endswith(".py") or "/" in target or "\\" in target:
            return _load_from_file(target, cls)
        return _load_from_module(target, cls)
    plugins = _plugins()
    if ref in plugins:
        return plugins[ref].load()
    raise ValueError(
        f"unknown agent {ref!r}; expected one of {', '.join(available_agents())}, "
        "a path/to/file.py:ClassName or a package.module:ClassName"
    )


def safe_act(
    agent: Agent, obs: Observation, name: str
) -> tuple[NDArray[np.float64], AgentFault | None]:
    """Call ``agent.act``; on an exception or a non-finite/wrong-shape result return zero
    acceleration and the fault."""
    try:
        out = np.asarray(agent.act(obs), dtype=np.float64)
    except Exception as exc:  # noqa: BLE001 - any agent failure is contained
        return np.zeros(2), AgentFault(obs.time, obs.robot_id, name,
                                       f"{type(exc).__name__}: {exc}")
    if out.shape != (2,):
        return np.zeros(2), AgentFault(obs.time, obs.robot_id, name,
                                       f"expected an acceleration of shape (2,), got {out.shape}")
    if not np.all(np.isfinite(out)):
        return np.zeros(2), AgentFault(obs.time, obs.robot_id, name,
                                       f"non-finite acceleration {out.tolist()}")
    return out, None
