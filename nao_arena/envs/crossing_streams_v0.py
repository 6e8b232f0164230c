"""crossing_streams_v0: two perpendicular single-file streams of n robots each (default 20),
2 m apart, parking 45 m ahead; symmetric, no seed.

The shipped map ``crossing_streams`` (maps/crossing_streams.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "crossing_streams"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
