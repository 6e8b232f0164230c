"""The NAO safety shield: any policy's actions, made NAO-admissible.

:class:`NAOShield` wraps a nao_arena parallel env (``nao_shield_v0(env)`` is
the PettingZoo-style alias; it also takes the AEC env of ``nao_arena.env``
and returns the shielded AEC env). Each step it reads every acting
agent's action as the *desired* acceleration (what the env would apply:
clipped to [-1, 1], times a_max, scaled to |a| <= a_max, m/s^2) and
replaces it by the acceleration the ``nao`` agent would select for it:

- kept: the desired acceleration is admissible (outside every neighbour's
  NAO over the horizon, walls included): the action passes unchanged, the
  same object;
- repaired: it is not, and the robot holds an avoidance adjustment younger
  than ``reselect_after`` (s): the adjustment is repaired locally towards
  it (the ``nao`` agent's warm start);
- adjusted: the admissible acceleration nearest the desired one;
- infeasible: nothing admissible: the ``nao`` agent's fallback (braking
  towards standing still, or postponing contact when traffic is near; see
  its ``infeasible`` option).

The selection is the ``nao`` agent's own
(:meth:`nao_arena.agents.nao.NAOAgent.nearest_admissible_batch`): one agent
per controlled robot, made as the arena makes the robot's agent (the map's
predictor and agent options for the robot, then the shield's options), fed
the arena's sensing of the step (the neighbours, walls and limits the
robots' agents see). A shield with ``agent="ao"`` uses constant-acceleration
predictions. The replaced action is the selected acceleration / a_max; the
env scales it back (to rounding).

``infos[agent]["shield"]`` (after every reset and step) holds ``intervened``
(bool: the action was replaced), ``correction`` (|a_applied - a_desired|,
m/s^2), ``status`` (one of :data:`SHIELD_STATUSES`; "finished" for an agent
whose actions the env ignores with ``keep_finished``, "reset" after reset),
``desired`` and ``applied`` ((2,) m/s^2; None when finished or after reset).

Spaces, agents, seeding, rendering and ``state()`` are the env's; the
shield pickles and copies with it. Wrappers between the shield and the env
must pass actions through unchanged (wrap other wrappers around the shield).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec, parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import BaseParallelWrapper, OrderEnforcingWrapper

from nao_arena.agent import load_agent
from nao_arena.agents.nao import SHIELD_STATUSES as _SELECTION_STATUSES
from nao_arena.agents.nao import NAOAgent
from nao_arena.arena import make_agent
from nao_arena.environment import NaoArenaParallelEnv
from nao_arena.world import clip_accelerations

__all__ = ["SHIELD_STATUSES", "NAOShield", "nao_shield_v0"]

SHIELD_STATUSES: tuple[str, ...] = (*_SELECTION_STATUSES, "finished", "reset")
"""Values of ``infos[agent]["shield"]["status"]`` (see the module docstring)."""


def _idle(status: str) -> dict[str, Any]:
    """The shield's info of an agent whose action it did not look at."""
    return {
        "intervened": False,
        "correction": 0.0,
        "status": status,
        "desired": None,
        "applied": None,
    }


class NAOShield(BaseParallelWrapper):
    """A nao_arena parallel env whose actions pass through the NAO selection (module
    docstring). agent: "nao", "ao" or another :class:`NAOAgent` class or reference;
    agent_options: its constructor's options (horizon s, margin m, predictor,
    reselect_after s, infeasible ...), over the map's options for each robot."""

    def __init__(self, env: ParallelEnv, agent: str | type = "nao", **agent_options: Any) -> None:
        base = getattr(env, "unwrapped", None)
        if not isinstance(base, NaoArenaParallelEnv):
            raise TypeError(
                "env: expected a nao_arena parallel env (nao_arena.parallel_env"
                f"(...)), got {type(env).__name__}"
            )
        super().__init__(env)
        cls = load_agent(agent) if isinstance(agent, str) else agent
        if not (isinstance(cls, type) and issubclass(cls, NAOAgent)):
            raise ValueError(
                f"agent: expected 'nao', 'ao' or a subclass of NAOAgent, got {agent!r}"
            )
        if not agent_options.get("replan", True):
            raise ValueError("replan: the shield selects at every step; expected True")
        self.agent_class: type[NAOAgent] = cls
        self.agent_options: dict[str, Any] = dict(agent_options)
        self.base: NaoArenaParallelEnv = base
        self.shield_agents: list[NAOAgent] = self._make_agents(None)
        self.statuses: Counter[str] = Counter()
        """How many agent-steps of the episode ended in each status."""

    def _make_agents(self, seed: int | None) -> list[NAOAgent]:
        """One fresh agent per controlled robot (``possible_agents`` order), reset with
        generators spawned from ``seed``."""
        base = self.base
        robots = [base.spec.robots[k] for k in base.controlled_robots]
        seeds = np.random.SeedSequence(seed).spawn(len(robots))
        agents = []
        for robot, ss in zip(robots, seeds, strict=True):
            ag = make_agent(self.agent_class, robot, self.agent_options)
            ag.reset(robot, np.random.default_rng(ss))
            agents.append(ag)
        return agents

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float32]], dict[str, dict[str, Any]]]:
        """The env's reset; fresh shield agents (the map may change with the seed)."""
        obs, infos = self.env.reset(seed=seed, options=options)
        self.shield_agents = self._make_agents(seed)
        self.statuses = Counter()
        for info in infos.values():
            info["shield"] = _idle("reset")
        return obs, infos

    def shield(
        self, actions: Mapping[str, Any]
    ) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        """The actions the env gets (the admissible ones unchanged, the others replaced)
        and each live agent's shield info; checks the actions as the env does (ValueError)."""
        base = self.base
        if base.arena.stats is None:
            raise RuntimeError("call reset() before step()")
        live = list(base.agents)
        if not live:
            return dict(actions), {}
        clipped = base._actions_array(actions, live)
        finished = set(base.finished_agents)
        infos = {a: _idle("finished") for a in finished}
        acting = [i for i, a in enumerate(live) if a not in finished]
        if not acting:
            return dict(actions), infos
        names = [live[i] for i in acting]
        index = {a: i for i, a in enumerate(base.possible_agents)}
        rows = [base.controlled_robots[index[a]] for a in names]
        a_max = base.arena.world.a_max[base.arena.robot_ids[rows]]
        # what the env and the world would make of the actions (m/s^2)
        desired = clip_accelerations(clipped[acting] * a_max[:, None], a_max)
        agents = [self.shield_agents[index[a]] for a in names]
        applied, status = self.agent_class.nearest_admissible_batch(
            agents, base.arena.sensed(), rows, desired
        )
        out = dict(actions)
        diff = applied - desired
        changed = np.any(applied != desired, axis=1).tolist()
        correction = np.hypot(diff[:, 0], diff[:, 1]).tolist()
        for i, a in enumerate(names):
            if changed[i]:
                out[a] = applied[i] / a_max[i]
            # rows of this step's fresh arrays
            infos[a] = {
                "intervened": changed[i],
                "correction": correction[i],
                "status": status[i],
                "desired": desired[i],
                "applied": applied[i],
            }
        self.statuses.update(status)
        return out, infos

    def step(
        self, actions: Mapping[str, Any]
    ) -> tuple[
        dict[str, NDArray[np.float32]],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        """:meth:`shield` the actions, then the env's step; infos get ``"shield"``."""
        shielded, shield_infos = self.shield(actions)
        obs, rewards, terminated, truncated, infos = self.env.step(shielded)
        for a, info in infos.items():
            info["shield"] = shield_infos.get(a, _idle("finished"))
        return obs, rewards, terminated, truncated, infos

    def __str__(self) -> str:
        return f"NAOShield<{self.env}>"


def nao_shield_v0(
    env: ParallelEnv | AECEnv, agent: str | type = "nao", **agent_options: Any
) -> NAOShield | AECEnv:
    """:class:`NAOShield` of a nao_arena parallel env; of the AEC env ``nao_arena.env(...)``
    (PettingZoo's ``parallel_to_aec`` of a parallel env), the AEC form of the shielded
    parallel env."""
    if isinstance(env, AECEnv):
        inner: Any = env.env if type(env) is OrderEnforcingWrapper else env
        if not isinstance(inner, parallel_to_aec_wrapper):
            raise TypeError(
                "env: expected a nao_arena parallel env or nao_arena.env(...) "
                f"(an AEC env converted from one), got {type(env).__name__}"
            )
        return parallel_to_aec(NAOShield(inner.env, agent, **agent_options))
    return NAOShield(env, agent, **agent_options)
