"""warehouse_aisles_v0: five shelf rows forming four 1.8 m aisles; n robots (default 2)
enter every aisle from each end (two-way traffic); symmetric, no seed.

The shipped map ``warehouse_aisles`` (maps/warehouse_aisles.yaml); see
:mod:`nao_arena.envs` for the keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "warehouse_aisles"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
