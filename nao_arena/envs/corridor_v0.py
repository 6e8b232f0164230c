"""corridor_v0: a walled hall split by a 1.6 m wide bottleneck; n robots (default 4) on each
side swap sides.

The shipped map ``corridor`` (maps/corridor.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "corridor"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
