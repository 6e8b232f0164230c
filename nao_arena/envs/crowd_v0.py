"""crowd_v0: n robots (default 20) with seeded random starts and goals in a walled square.

The shipped map ``crowd`` (maps/crowd.yaml); see :mod:`nao_arena.envs` for the keywords and
the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "crowd"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
