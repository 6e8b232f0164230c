"""The compiled geometry kernels (numba, ``cache=True``), one module per concept:

- :mod:`.quartic`: exact minimum distance on one piece of a piecewise-quadratic path;
- :mod:`.exact`: exact clearance, admissibility and first contact of
  constant-acceleration candidates (speed capped at v_max) against piecewise paths;
- :mod:`.sampled`: pieces of sampled obstacle paths, built inside the compiled loops;
- :mod:`.relevance`: relevance pruning (obstacles the robot could reach at all);
- :mod:`.disks`: the disk picture of the NAO union near a query point;
- :mod:`.outside`: nearest points outside a union of disks within the limit disc;
- :mod:`.batch`: batched admissibility, one acceleration per robot;
- :mod:`.search`: the disc search (bisection, candidates, rings, sliding, repair,
  selection).

The public wrappers live in :mod:`nao_arena.geometry.clearance` and
:mod:`nao_arena.geometry.selection`. The loops that run per candidate borrow
their array arguments (:mod:`nao_arena.geometry.borrow`: no reference counting
per call) and get their scratch arrays from thin wrappers.
"""
