"""roundabout_v0: two robots crossing 30 cars in three circular lanes (traffic scripted).

The shipped map ``roundabout`` (maps/roundabout.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "roundabout"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
