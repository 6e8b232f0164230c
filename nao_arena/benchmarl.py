"""BenchMARL tasks: every versioned env of :mod:`nao_arena.envs` as a BenchMARL task.

::

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig

    from nao_arena.benchmarl import NaoArenaTask

    task = NaoArenaTask.CROSSING_V0.get_task()          # or get_task(config={"n": 4})
    Experiment(
        task=task,
        algorithm_config=MappoConfig.get_from_yaml(),
        model_config=MlpConfig.get_from_yaml(),
        seed=0,
        config=ExperimentConfig.get_from_yaml(),
    ).run()

A task's config holds keywords of the env's ``parallel_env`` (map parameters such as
``n``, and :class:`~nao_arena.environment.EnvOptions` fields) on top of
:data:`DEFAULT_CONFIG`: ``agent_names="grouped"``, so that the robots of one group
(``east_0``, ``east_1``, ...) form one BenchMARL group and share a policy, and
``keep_finished=True``, so that every agent stays in the episode until it ends (a robot
at its goal is held there by its own agent, its reward 0), as BenchMARL's collectors
expect. The env reaches BenchMARL through TorchRL's ``PettingZooWrapper``; actions are
continuous (the acceleration as a fraction of a_max), the global state is
``state()``. ``max_steps`` is the episode's length in control steps (the map's time
limit over its dt).

This module needs BenchMARL (``pip install benchmarl``), which brings TorchRL;
``import nao_arena`` does not import it.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

from benchmarl.environments.common import Task, TaskClass
from torchrl.data import Composite
from torchrl.envs import EnvBase, PettingZooWrapper

from nao_arena.environment import NaoArenaParallelEnv
from nao_arena.envs import load

__all__ = ["DEFAULT_CONFIG", "NaoArenaTask", "NaoArenaTaskClass"]

DEFAULT_CONFIG: dict[str, Any] = {"agent_names": "grouped", "keep_finished": True}
"""What every task's config starts from (see the module docstring)."""


def _env_name(task_name: str) -> str:
    """The versioned env of a task: ``CROSSING_V0`` -> ``crossing_v0``."""
    return task_name.lower()


class NaoArenaTaskClass(TaskClass):
    """A nao_arena env as a BenchMARL task (see the module docstring)."""

    def _parallel_env(self) -> NaoArenaParallelEnv:
        config = {**DEFAULT_CONFIG, **copy.deepcopy(self.config)}
        env: NaoArenaParallelEnv = load(_env_name(self.name)).parallel_env(**config)
        return env

    def get_env_fun(
        self, num_envs: int, continuous_actions: bool, seed: int | None, device: Any
    ) -> Callable[[], EnvBase]:
        """A maker of the TorchRL env (one env; BenchMARL asks for ``num_envs`` of them
        through its own vectorisation). Actions are continuous only."""
        if not continuous_actions:
            raise ValueError(f"{self.name}: nao_arena's actions are continuous accelerations")
        return lambda: PettingZooWrapper(
            self._parallel_env(),
            return_state=True,
            use_mask=False,
            categorical_actions=False,
            seed=seed,
            device=device,
        )

    def supports_continuous_actions(self) -> bool:
        return True

    def supports_discrete_actions(self) -> bool:
        return False

    def has_state(self) -> bool:
        return True

    def has_render(self, env: EnvBase) -> bool:
        return True

    def max_steps(self, env: EnvBase) -> int:
        return self._parallel_env().max_steps

    def group_map(self, env: EnvBase) -> dict[str, list[str]]:
        return dict(env.group_map)

    def _group_keys(self, env: EnvBase, keep: str) -> Composite:
        spec = env.observation_spec.clone()
        for group in self.group_map(env):
            for key in list(spec[group].keys()):
                if key != keep:
                    del spec[group][key]
        if "state" in spec.keys():
            del spec["state"]
        return spec

    def observation_spec(self, env: EnvBase) -> Composite:
        return self._group_keys(env, "observation")

    def info_spec(self, env: EnvBase) -> Composite | None:
        return self._group_keys(env, "info")

    def state_spec(self, env: EnvBase) -> Composite | None:
        return Composite({"state": env.observation_spec["state"].clone()})

    def action_spec(self, env: EnvBase) -> Composite:
        return env.full_action_spec

    def action_mask_spec(self, env: EnvBase) -> Composite | None:
        return None

    @staticmethod
    def env_name() -> str:
        return "nao_arena"


class NaoArenaTask(Task):
    """One member per versioned env of :mod:`nao_arena.envs` (``tests`` check the list)."""

    CIRCLE_SWAP_PERTURBED_V0 = None
    CIRCLE_SWAP_V0 = None
    CORRIDOR_V0 = None
    CROSSING_STREAMS_PERTURBED_V1 = None
    CROSSING_STREAMS_V1 = None
    CROSSING_V0 = None
    CROWD_V0 = None
    CROWDNAV_CIRCLE_V0 = None
    CROWDNAV_SQUARE_V0 = None
    DENSE_SWAP_PERTURBED_V1 = None
    DENSE_SWAP_V1 = None
    DOORWAY_PERTURBED_V0 = None
    DOORWAY_V0 = None
    INTERSECTION_PERTURBED_V0 = None
    INTERSECTION_V0 = None
    PILLAR_CORRIDOR_PERTURBED_V0 = None
    PILLAR_CORRIDOR_V0 = None
    ROUNDABOUT_CROSSING_V0 = None
    ROUNDABOUT_V0 = None
    TWO_LANE_ROAD_V0 = None
    WAREHOUSE_AISLES_PERTURBED_V0 = None
    WAREHOUSE_AISLES_V0 = None

    @staticmethod
    def associated_class() -> type[NaoArenaTaskClass]:
        return NaoArenaTaskClass

    def get_task(self, config: dict[str, Any] | None = None) -> NaoArenaTaskClass:
        """The task with ``config`` (env keywords, on top of :data:`DEFAULT_CONFIG`); the
        config is never read from BenchMARL's YAML folder, which holds no nao_arena task."""
        return NaoArenaTaskClass(name=self.name, config=dict(config or {}))

    def get_from_yaml(self, path: str | None = None) -> NaoArenaTaskClass:
        """The task with the config of the YAML file ``path`` (None: the defaults)."""
        if path is None:
            return self.get_task()
        import yaml

        with open(path, encoding="utf-8") as f:
            return self.get_task(yaml.safe_load(f) or {})
