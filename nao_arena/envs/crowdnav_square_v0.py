"""crowdnav_square_v0: CrowdNav's square crossing, one robot among n social-force people
(default 5) who cross a 10 m square from side to side, seeded.

The shipped map ``crowdnav_square`` (maps/crowdnav_square.yaml); see :mod:`nao_arena.envs`
for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "crowdnav_square"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
