"""dense_swap_v0: the RVO2 / AVO2 circle swap: n robots (default 100) of radius 0.5 m to the
antipodes of a circle of radius max(10, 1.1 n / pi) m; symmetric, no seed.

The shipped map ``dense_swap`` (maps/dense_swap.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "dense_swap"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
