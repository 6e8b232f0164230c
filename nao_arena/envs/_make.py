"""The two constructors of a versioned env module (see :mod:`nao_arena.envs`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pettingzoo import AECEnv
from pettingzoo.utils.conversions import parallel_to_aec

from nao_arena.environment import NaoArenaParallelEnv


def constructors(
    module: str, map_name: str
) -> tuple[Callable[..., AECEnv], Callable[..., NaoArenaParallelEnv]]:
    """``env`` and ``parallel_env`` of the module ``module`` (``nao_arena.envs.<name>``)
    on the shipped map ``map_name``; its envs' ``metadata["name"]`` is ``<name>``."""
    name = module.rsplit(".", 1)[-1]

    def parallel_env(render_mode: str | None = None, **kwargs: Any) -> NaoArenaParallelEnv:
        if "map" in kwargs:
            raise TypeError(
                f"{name}.parallel_env: the map is fixed ({map_name!r}), got "
                f"map={kwargs['map']!r}; use nao_arena.parallel_env(map, ...) "
                f"for another map"
            )
        par = NaoArenaParallelEnv(map_name, render_mode=render_mode, **kwargs)
        par.metadata = {**par.metadata, "name": name}
        return par

    def env(render_mode: str | None = None, **kwargs: Any) -> AECEnv:
        return parallel_to_aec(parallel_env(render_mode=render_mode, **kwargs))

    parallel_env.__doc__ = (
        f"{name}: the PettingZoo ParallelEnv on the map {map_name!r}; keywords: EnvOptions "
        f"fields and map parameters (see nao_arena.environment)."
    )
    env.__doc__ = f"{name}: the AEC form of :func:`parallel_env`."
    for f in (parallel_env, env):
        f.__module__ = module  # pickled by reference to the module's attribute
        f.__qualname__ = f.__name__
    return env, parallel_env
