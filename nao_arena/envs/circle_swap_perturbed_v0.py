"""circle_swap_perturbed_v0: circle_swap with seeded perturbed starts (parameter perturb, m).

The shipped map ``circle_swap_perturbed`` (maps/circle_swap_perturbed.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "circle_swap_perturbed"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
