"""crowdnav_circle_v0: CrowdNav's circle crossing, one robot through n social-force people
(default 5) who start on a circle of radius 4 m and cross it, seeded.

The shipped map ``crowdnav_circle`` (maps/crowdnav_circle.yaml); see :mod:`nao_arena.envs`
for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "crowdnav_circle"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
