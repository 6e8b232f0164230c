"""One controlled robot among the map's other agents, as a Gymnasium env.

The common research setup: a learning robot among a crowd that runs its own avoidance
(NAO by default; ``agent="orca"`` for an ORCA crowd, any agent the map's ``agent``
parameter takes), traffic and walls. Every versioned env of :mod:`nao_arena.envs` is
registered with Gymnasium as ``nao_arena/<map>-v<N>`` (``crossing_v0`` ->
``nao_arena/crossing-v0``)::

    import gymnasium
    env = gymnasium.make("nao_arena.envs:nao_arena/crossing-v0", agent="orca")
    env = nao_arena.envs.SingleRobotEnv("crossing", robot="east0")   # the class itself

(the ``nao_arena.envs:`` prefix makes Gymnasium import the module that registers them;
after ``import nao_arena.envs`` the id alone works). Keywords: ``robot`` (the
controlled robot's name or index; default the map's first robot), ``render_mode``, and
those of the versioned env (:class:`~nao_arena.environment.EnvOptions` fields and map
parameters). The observation, action, reward, termination, truncation and infos are
those of that robot in :class:`~nao_arena.environment.NaoArenaParallelEnv` (one agent
controlled, the others driven by their agents inside the step); see
:mod:`nao_arena.environment`. An episode ends when the robot terminates (at its goal;
after a collision with ``terminate_on_collision``) or is truncated (time limit).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, SupportsFloat

import gymnasium
from numpy.typing import NDArray

if TYPE_CHECKING:
    from nao_arena.environment import NaoArenaParallelEnv

__all__ = ["SingleRobotEnv", "gymnasium_id", "register_all"]


class SingleRobotEnv(gymnasium.Env[NDArray[Any], NDArray[Any]]):
    """One robot of a map controlled, the others driven by their agents (see the module)."""

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    def __init__(
        self,
        map: str = "crossing",  # noqa: A002 - the parallel env's keyword
        robot: str | int | None = None,
        render_mode: str | None = None,
        **kwargs: Any,
    ) -> None:
        if "controlled" in kwargs:
            raise TypeError("SingleRobotEnv controls one robot: give robot=NAME, not controlled")
        from nao_arena.environment import NaoArenaParallelEnv

        chosen: str | int = 0 if robot is None else robot
        self.par: NaoArenaParallelEnv = NaoArenaParallelEnv(
            map, render_mode=render_mode, controlled=[chosen], **kwargs
        )
        (self.agent,) = self.par.possible_agents
        self.render_mode = render_mode
        self.observation_space = self.par.observation_space(self.agent)
        self.action_space = self.par.action_space(self.agent)
        self.metadata = {**self.metadata, "render_fps": self.par.metadata["render_fps"]}

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[NDArray[Any], dict[str, Any]]:
        """A new episode (``seed``: the map's and the agents' seed, as the parallel env's)."""
        super().reset(seed=seed)
        obs, infos = self.par.reset(seed=seed, options=options)
        return obs[self.agent], infos[self.agent]

    def step(
        self, action: NDArray[Any]
    ) -> tuple[NDArray[Any], SupportsFloat, bool, bool, dict[str, Any]]:
        """One control step with the robot's normalized action (2,) in [-1, 1]."""
        if self.agent not in self.par.agents:
            raise RuntimeError("the episode has ended: call reset()")
        obs, rewards, terms, truncs, infos = self.par.step({self.agent: action})
        a = self.agent
        return obs[a], float(rewards[a]), bool(terms[a]), bool(truncs[a]), infos[a]

    def render(self) -> Any:
        return self.par.render()

    def close(self) -> None:
        self.par.close()


def gymnasium_id(versioned: str) -> str:
    """``"crossing_v0"`` -> ``"nao_arena/crossing-v0"``."""
    base, version = versioned.rsplit("_v", 1)
    return f"nao_arena/{base}-v{version}"


def register_all(names: list[str]) -> None:
    """Register ``nao_arena/<map>-v<N>`` with Gymnasium for each versioned env name
    ``<map>_v<N>`` (on the shipped map ``<map>``), unless already registered."""
    for name in names:
        env_id = gymnasium_id(name)
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point="nao_arena.envs:SingleRobotEnv",
            kwargs={"map": name.rsplit("_v", 1)[0]},
        )
