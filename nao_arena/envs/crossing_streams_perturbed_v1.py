"""crossing_streams_perturbed_v1: crossing_streams with seeded start noise
(perturb, default 0.01 m).

The shipped map ``crossing_streams_perturbed`` (maps/crossing_streams_perturbed.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule. v1 (from v0): every robot
senses the 10 nearest bodies within 15 m (v0: every body within 30 m), and nao robots look
1.5 s ahead (v0: 3 s).
"""

from nao_arena.envs._make import constructors

MAP = "crossing_streams_perturbed"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
