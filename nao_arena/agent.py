"""The agent protocol and plug-in loading.

An agent drives one robot::

    class MyAgent:
        def reset(self, spec, rng):       # spec: the robot's map entry; rng: numpy Generator
            self.gain = 1.5
        def act(self, obs):               # obs: nao_arena.sensing.Observation
            to_goal = obs.goal - obs.position
            return self.gain * to_goal - 2.0 * obs.velocity   # acceleration (2,) m/s^2

Agents are named by a built-in name (``nao``, ``ao``, ``vo``, ``orca``, ``cbf``,
``goal``, ``lane``, ``social_force``), by ``path/to/file.py:ClassName``, by
``package.module:ClassName``, or by an entry point in the group
``nao_arena.agents``. Agent classes take keyword options in their
constructor (e.g. ``horizon=4.0``).

Containment: an agent that raises (any exception, SystemExit included;
not KeyboardInterrupt nor :class:`~nao_arena.watchdog.EpisodeTimeout`) or
returns something that is not a finite (2,) acceleration gets zero
acceleration for that step, and the fault is recorded (see
:func:`safe_act`). What an agent senses is read-only (see
:class:`~nao_arena.sensing.SensingBatch`): writing into it raises
ValueError, a fault like any other. An agent whose constructor or ``reset``
raises fails the episode with :class:`AgentError`.

A plug-in file (``path/to/file.py:Class``) is imported once per process
(per resolved path): every robot and every episode get the same class, so
robots of one plug-in class act together through its ``act_batch``.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from nao_arena import agent_names
from nao_arena.agent_names import BUILTIN_AGENTS, BUILTIN_DESCRIPTIONS, available_agents
from nao_arena.predictors import Predictor
from nao_arena.sensing import Observation, SensingBatch
from nao_arena.watchdog import EpisodeTimeout

if TYPE_CHECKING:
    from nao_arena.maps import RobotSpec

__all__ = [
    "BUILTIN_AGENTS",
    "BUILTIN_DESCRIPTIONS",
    "UNCONTAINED",
    "Agent",
    "AgentError",
    "AgentFault",
    "BatchAgent",
    "PanelAgent",
    "ShowsPanel",
    "TooManyFaults",
    "available_agents",
    "check_agent_class",
    "describe",
    "load_agent",
    "safe_act",
    "safe_act_batch",
]

UNCONTAINED: tuple[type[BaseException], ...] = (KeyboardInterrupt, EpisodeTimeout)
"""What an agent may raise that the loop does not contain: the user's interrupt and the
episode's wall-clock budget (every other exception, SystemExit included, is a fault)."""


@runtime_checkable
class Agent(Protocol):
    """Drives one robot: ``reset`` once per episode, ``act`` once per control step."""

    def reset(self, spec: RobotSpec, rng: np.random.Generator) -> None: ...

    def act(self, obs: Observation) -> NDArray[np.float64]: ...


@runtime_checkable
class BatchAgent(Agent, Protocol):
    """An agent whose class also acts for all its robots at once: the arena calls
    ``act_batch`` once per step with that class's agents, the step's
    :class:`~nao_arena.sensing.SensingBatch` and their robots' rows (robot order), in
    place of ``act`` robot by robot. It returns one result per row, each an acceleration
    (2,) m/s^2 or an exception instance (that robot's fault), or an array (rows, 2);
    they must be what ``act`` would give (see :class:`~nao_arena.arena.Arena`)."""

    @classmethod
    def act_batch(cls, agents: Sequence[Any], batch: SensingBatch, rows: Sequence[int]) -> Any: ...


@dataclass(frozen=True, eq=False)
class PanelAgent:
    """What the viewer's acceleration panel shows of a robot's agent: its time grid (s)
    and predictor (None: turn-rate predictions over 3 s), safety margin (m), preferred
    speed (m/s; None: v_max), detour (rad; its goal direction is turned by it) and the
    status of its last full selection (None: it reports none). Equal where every field
    is, the time grids element by element (a dataclass's own comparison of an array
    field raises from Python 3.13 on)."""

    times: NDArray[np.float64] | None = None
    predict: Predictor | None = None
    margin: float = 0.0
    v_pref: float | None = None
    detour: float = 0.0
    status: str | None = None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PanelAgent):
            return NotImplemented
        if self.times is None or other.times is None:
            if self.times is not other.times:
                return False
        elif not np.array_equal(self.times, other.times):
            return False
        mine = (self.predict, self.margin, self.v_pref, self.detour, self.status)
        return mine == (other.predict, other.margin, other.v_pref, other.detour, other.status)

    __hash__ = None  # type: ignore[assignment]  # equal by value, and an array is unhashable


@runtime_checkable
class ShowsPanel(Protocol):
    """An agent that tells the viewer's acceleration panel how it plans (agents without
    ``panel`` are shown with the defaults of :class:`PanelAgent`)."""

    def panel(self) -> PanelAgent: ...


@dataclass(frozen=True)
class AgentFault:
    """An agent's failure at one step: time (s), robot index and what went wrong."""

    time: float
    robot: int
    agent: str
    message: str


class AgentError(RuntimeError):
    """An agent could not be made ready for an episode (its constructor or ``reset``
    raised), or its faults failed the episode (:class:`TooManyFaults`)."""


class TooManyFaults(AgentError):
    """The agents of an episode faulted more often than its ``max_faults`` allows."""


def describe(exc: BaseException) -> str:
    """``Type: message`` of an exception, as faults and errors report it."""
    return f"{type(exc).__name__}: {exc}"


_FILE_MODULES: dict[Path, ModuleType] = {}
"""Plug-in files imported so far in this process, by resolved path."""


def _load_from_file(path: str, cls: str) -> type:
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"agent {path}:{cls}: no such file {file}")
    resolved = file.resolve()
    module = _FILE_MODULES.get(resolved)
    if module is None:
        digest = hashlib.sha1(str(resolved).encode("utf-8")).hexdigest()[:16]
        name = f"nao_arena_plugin_{digest}"
        spec = importlib.util.spec_from_file_location(name, file)
        if spec is None or spec.loader is None:
            raise ValueError(f"agent {path}:{cls}: cannot import {file}")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except UNCONTAINED:
            sys.modules.pop(name, None)
            raise
        except BaseException as exc:  # noqa: BLE001 - a plug-in's import error is reported
            sys.modules.pop(name, None)
            first = (describe(exc).splitlines() or [""])[0]
            raise ValueError(f"agent {path}:{cls}: cannot be loaded ({first})") from exc
        _FILE_MODULES[resolved] = module
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


def load_agent(ref: str) -> type:
    """The agent class named by ``ref`` (built-in name, FILE.py:Class, module:Class,
    plug-in); ValueError if there is none, or if what it names is not a class with
    ``reset`` and ``act`` methods (checked before anything is constructed)."""
    if ref in BUILTIN_AGENTS:
        module_name, cls = BUILTIN_AGENTS[ref].split(":")
        return _load_from_module(module_name, cls)
    if ":" in ref:
        target, cls = ref.rsplit(":", 1)
        if target.endswith(".py") or "/" in target or "\\" in target:
            return check_agent_class(ref, _load_from_file(target, cls))
        return check_agent_class(ref, _load_from_module(target, cls))
    plugins = agent_names.plugins()
    if ref in plugins:
        return check_agent_class(ref, plugins[ref].load())
    raise ValueError(
        f"unknown agent {ref!r}; expected one of {', '.join(available_agents())}, "
        "a path/to/file.py:ClassName or a package.module:ClassName"
    )


def check_agent_class(ref: str, cls: object) -> type:
    """``cls`` if it is a class with callable ``reset`` and ``act`` (the agent protocol);
    else ValueError naming ``ref`` and what is missing."""
    if not isinstance(cls, type):
        raise ValueError(
            f"agent {ref}: expected a class with reset(spec, rng) and act(obs) "
            f"methods, got {type(cls).__name__} {cls!r}"
        )
    missing = [m for m in ("reset", "act") if not callable(getattr(cls, m, None))]
    if missing:
        raise ValueError(
            f"agent {ref}: class {cls.__name__} is not an agent: it has no "
            f"{' and no '.join(missing)} method (an agent needs "
            "reset(spec, rng) and act(obs))"
        )
    return cls


def safe_act(
    agent: Agent, obs: Observation, name: str
) -> tuple[NDArray[np.float64], AgentFault | None]:
    """Call ``agent.act``; on an exception (any but :data:`UNCONTAINED`, which propagate)
    or a non-finite/wrong-shape result return zero acceleration and the fault."""
    try:
        out = np.asarray(agent.act(obs), dtype=np.float64)
    except UNCONTAINED:
        raise
    except BaseException as exc:  # noqa: BLE001 - any agent failure is contained
        return np.zeros(2), AgentFault(obs.time, obs.robot_id, name, describe(exc))
    if out.shape != (2,):
        return np.zeros(2), AgentFault(
            obs.time, obs.robot_id, name, f"expected an acceleration of shape (2,), got {out.shape}"
        )
    if not np.all(np.isfinite(out)):
        return np.zeros(2), AgentFault(
            obs.time, obs.robot_id, name, f"non-finite acceleration {out.tolist()}"
        )
    return out, None


def safe_act_batch(
    cls: type[BatchAgent],
    agents: list[Any],
    batch: SensingBatch,
    rows: list[int],
    names: Sequence[str],
) -> tuple[NDArray[np.float64], dict[int, AgentFault]]:
    """``cls.act_batch(agents, batch, rows)`` checked like :func:`safe_act`: each
    result must be a finite (2,) acceleration (an exception instance is that
    agent's failure; it gets zero acceleration); a failing call fails every agent
    of the group. ``names``: every robot's agent name (robot order). Returns the
    accelerations (len(rows), 2) m/s^2 and the faults by robot."""
    try:
        results = cls.act_batch(agents, batch, rows)
        if (
            type(results) is np.ndarray
            and results.shape == (len(rows), 2)
            and results.dtype == np.float64
            and np.isfinite(results).all()
        ):
            return results.copy(), {}  # the common case of an array of them
        results = list(results)
        if len(results) != len(rows):
            raise ValueError(f"act_batch returned {len(results)} results for {len(rows)} agents")
    except UNCONTAINED:
        raise
    except BaseException as exc:  # noqa: BLE001 - any agent failure is contained
        results = [exc] * len(rows)
    if all(type(r) is np.ndarray and r.shape == (2,) and r.dtype == np.float64 for r in results):
        # the common case, checked at once
        accs = np.array(results)
        if np.all(np.isfinite(accs)):
            return accs, {}
    accs = np.zeros((len(rows), 2))
    faults: dict[int, AgentFault] = {}
    for i, (k, res) in enumerate(zip(rows, results, strict=True)):
        name = names[k]
        if isinstance(res, BaseException):
            faults[k] = AgentFault(batch.time, k, name, describe(res))
            continue
        try:
            acc = np.asarray(res, dtype=np.float64)
        except UNCONTAINED:
            raise
        except BaseException as exc:  # noqa: BLE001
            faults[k] = AgentFault(batch.time, k, name, describe(exc))
            continue
        if acc.shape != (2,):
            faults[k] = AgentFault(
                batch.time, k, name, f"expected an acceleration of shape (2,), got {acc.shape}"
            )
        elif not (math.isfinite(acc[0]) and math.isfinite(acc[1])):
            faults[k] = AgentFault(batch.time, k, name, f"non-finite acceleration {acc.tolist()}")
        else:
            accs[i] = acc
    return accs, faults
