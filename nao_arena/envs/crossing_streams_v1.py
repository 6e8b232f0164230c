"""crossing_streams_v1: two perpendicular single-file streams of n robots each (default 20),
2 m apart, parking 45 m ahead; symmetric, no seed.

The shipped map ``crossing_streams`` (maps/crossing_streams.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule. v1 (from v0): every robot senses the 10 nearest bodies
within 15 m (v0: every body within 30 m), and nao robots look 1.5 s ahead (v0: 3 s).
"""

from nao_arena.envs._make import constructors

MAP = "crossing_streams"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
