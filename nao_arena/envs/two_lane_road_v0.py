"""two_lane_road_v0: overtaking a slow car on a two-lane road with oncoming cars; two robots.

The shipped map ``two_lane_road`` (maps/two_lane_road.yaml); see :mod:`nao_arena.envs` for
the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "two_lane_road"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
