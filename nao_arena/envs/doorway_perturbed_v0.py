"""doorway_perturbed_v0: doorway with seeded start noise
(perturb, default 0.1 m).

The shipped map ``doorway_perturbed`` (maps/doorway_perturbed.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "doorway_perturbed"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
