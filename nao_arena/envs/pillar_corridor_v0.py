"""pillar_corridor_v0: a walled 6 m corridor with six staggered octagonal pillars; n robots
(default 6) from each end (two-way flow); symmetric, no seed.

The shipped map ``pillar_corridor`` (maps/pillar_corridor.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "pillar_corridor"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
