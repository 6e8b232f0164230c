"""roundabout_crossing_v0: one robot crossing 30 cars in three circular lanes (a single agent).

The shipped map ``roundabout_crossing`` (maps/roundabout_crossing.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "roundabout_crossing"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
