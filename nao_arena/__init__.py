"""nao_arena: a physics-simulated multi-robot testbed built around the
Nonlinear Acceleration Obstacle (NAO).

Units everywhere: metres, seconds, m/s, m/s^2; angles in radians.

``nao_arena.parallel_env(map="roundabout", ...)`` is the PettingZoo parallel
env and ``nao_arena.env(...)`` its AEC version (see
:mod:`nao_arena.environment`); both are imported on first use, so that
``import nao_arena`` stays light. The package exports only the names in
``__all__``.
"""

from typing import Any as _Any

__version__ = "0.1.0"

__all__ = ["__version__", "env", "parallel_env"]


def parallel_env(map: str = "roundabout", render_mode: str | None = None,  # noqa: A002
                 **kwargs: _Any) -> _Any:
    """The map's PettingZoo ParallelEnv (see :func:`nao_arena.environment.parallel_env`)."""
    from nao_arena.environment import parallel_env as make

    return make(map, render_mode=render_mode, **kwargs)


def env(map: str = "roundabout", render_mode: str | None = None,  # noqa: A002
        **kwargs: _Any) -> _Any:
    """The map's PettingZoo AECEnv (see :func:`nao_arena.environment.env`)."""
    from nao_arena.environment import env as make

    return make(map, render_mode=render_mode, **kwargs)
