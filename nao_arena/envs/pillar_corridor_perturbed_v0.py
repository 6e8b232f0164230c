"""pillar_corridor_perturbed_v0: pillar_corridor with seeded start noise
(perturb, default 0.1 m).

The shipped map ``pillar_corridor_perturbed`` (maps/pillar_corridor_perturbed.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "pillar_corridor_perturbed"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
