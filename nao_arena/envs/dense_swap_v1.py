"""dense_swap_v1: the RVO2 / AVO2 circle swap: n robots (default 100) of radius 0.5 m to the
antipodes of a circle of radius max(10, 1.1 n / pi) m; symmetric, no seed.

The shipped map ``dense_swap`` (maps/dense_swap.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule. v1 (from v0): every robot senses the 10 nearest bodies
within 15 m (v0: every body within 30 m), and nao robots look 1.5 s ahead (v0: 3 s).
"""

from nao_arena.envs._make import constructors

MAP = "dense_swap"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
