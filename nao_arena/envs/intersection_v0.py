"""intersection_v0: a four-way intersection of 4.5 m streets between four buildings; n robots
(default 4) per arm cross to the opposite arm; symmetric, no seed.

The shipped map ``intersection`` (maps/intersection.yaml); see :mod:`nao_arena.envs` for the
keywords and the versioning rule.
"""

from nao_arena.envs._make import constructors

MAP = "intersection"
env, parallel_env = constructors(__name__, MAP)

__all__ = ["MAP", "env", "parallel_env"]
