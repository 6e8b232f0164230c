"""dense_swap_perturbed_v0: dense_swap with seeded start noise
(perturb, default 0.01 m).

The shipped map ``dense_swap_perturbed`` (maps/dense_swap_perturbed.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "dense_swap_perturbed"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
