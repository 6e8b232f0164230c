"""crossing_v0: two perpendicular streams of n robots each (default 6), starts perturbed,
seeded.

The shipped map ``crossing`` (maps/crossing.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "crossing"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
