"""doorway_v0: a walled hall split by a wall with one 1.8 m gap; n robots (default 10) on
each side cross through it; symmetric, no seed.

The shipped map ``doorway`` (maps/doorway.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "doorway"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
