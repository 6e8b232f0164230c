"""Versioned PettingZoo environments: one module per shipped map, named ``<map>_v<N>``.

As in PettingZoo's own environments (``from pettingzoo.butterfly import
pistonball_v6``)::

    from nao_arena.envs import crossing_v0

    par = crossing_v0.parallel_env(keep_finished=True)  # a pettingzoo.ParallelEnv
    aec = crossing_v0.env()                              # its AEC form
    par.metadata["name"]                                 # "crossing_v0"

Each module has ``env(render_mode=None, **kwargs)``, ``parallel_env(render_mode=None,
**kwargs)`` and ``MAP`` (the shipped map's name). The keywords are those of
:func:`nao_arena.environment.parallel_env` except ``map``, which the module fixes:
:class:`~nao_arena.environment.EnvOptions` fields and map parameters (``n=4``,
``seed=3``). The parallel env is the native form, so there is no ``raw_env``.
:func:`available` lists the names. With PettingZoo >= 1.27 importing this package
also registers every env in PettingZoo's registry as ``nao_arena/<name>``:
``pettingzoo.make("parallel", "nao_arena/crossing_v0")``.

Versions
--------
The suffix ``_vN`` changes whenever behaviour that affects learning changes: the
observation layout or bounds, the action meaning, rewards, terminations and
truncations, the dynamics (physics, limits, the built-in agents of uncontrolled
robots, traffic) or the map (its robots, goals, walls, parameter defaults, time
limit). Results on the same ``_vN`` are comparable; changes that do not touch
learning (speed, rendering, messages, new opt-in options) keep the version. A change
renames the module (``crossing_v0`` -> ``crossing_v1``), so that code written for the old
version fails at its import instead of learning on something else.
``tests/test_envs_registry.py`` fingerprints what hashes alike on every platform (the map
file, the default options, the agents, the spaces) and fails when that changes within a
version; changes of the dynamics are on the reviewer.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from nao_arena.envs._single import SingleRobotEnv

__all__ = ["SingleRobotEnv", "available", "load"]

_NAMES: tuple[str, ...] = (
    "circle_swap_perturbed_v0",
    "circle_swap_v0",
    "corridor_v0",
    "crossing_streams_perturbed_v1",
    "crossing_streams_v1",
    "crossing_v0",
    "crowd_v0",
    "crowdnav_circle_v0",
    "crowdnav_square_v0",
    "dense_swap_perturbed_v1",
    "dense_swap_v1",
    "doorway_perturbed_v0",
    "doorway_v0",
    "intersection_perturbed_v0",
    "intersection_v0",
    "pillar_corridor_perturbed_v0",
    "pillar_corridor_v0",
    "roundabout_crossing_v0",
    "roundabout_v0",
    "two_lane_road_v0",
    "warehouse_aisles_perturbed_v0",
    "warehouse_aisles_v0",
)


def available() -> list[str]:
    """Names of the versioned envs (module names in this package), sorted."""
    return sorted(_NAMES)


def load(name: str) -> ModuleType:
    """The module of the versioned env ``name`` (e.g. ``"crossing_v0"``)."""
    if name not in _NAMES:
        raise ValueError(f"unknown env {name!r}: expected one of {', '.join(available())}")
    return importlib.import_module(f"{__name__}.{name}")


def __getattr__(name: str) -> ModuleType:
    """``nao_arena.envs.crossing_v0`` without importing it first: a versioned env's module
    on first use."""
    if name in _NAMES:
        return load(name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _register() -> None:
    """Every env in PettingZoo's registry as ``nao_arena/<name>`` (PettingZoo >= 1.27), and
    its single-robot form in Gymnasium's as ``nao_arena/<map>-v<N>``
    (:class:`SingleRobotEnv`)."""
    import pettingzoo

    from nao_arena.envs._single import register_all

    register_all(list(_NAMES))

    register = getattr(pettingzoo, "register", None)
    if register is None:
        return
    for name in _NAMES:
        register("aec", f"nao_arena/{name}", entry_point=f"{__name__}.{name}:env")
        register("parallel", f"nao_arena/{name}", entry_point=f"{__name__}.{name}:parallel_env")


_register()
