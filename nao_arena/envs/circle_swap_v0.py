"""circle_swap_v0: n robots (default 10) evenly on a circle, each driving to the antipodal
point; no randomness in the scene.

The shipped map ``circle_swap`` (maps/circle_swap.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "circle_swap"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
