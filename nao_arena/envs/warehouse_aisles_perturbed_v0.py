"""warehouse_aisles_perturbed_v0: warehouse_aisles with seeded start noise
(perturb, default 0.1 m).

The shipped map ``warehouse_aisles_perturbed`` (maps/warehouse_aisles_perturbed.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "warehouse_aisles_perturbed"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
