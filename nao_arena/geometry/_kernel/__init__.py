"""The compiled geometry kernels (numba, ``cache=True``), one module per concept:

- :mod:`.quartic`: exact minimum distance on one piece of a piecewise-quadratic path;
- :mod:`.exact`: exact clearance, admissibility and first contact of
  constant-acceleration candidates (speed capped at v_max) against piecewise paths;
- :mod:`.sampled`: pieces of sampled obstacle paths, built inside the compiled loops;
- :mod:`.relevance`: relevance pruning (obstacles the robot could reach at all);
- :mod:`.disks`: the disk picture of the NAO union near a query point;
- :mod:`.outside`: nearest points outside a union of disks within the limit disc;
- :mod:`.batch`: batched admissibility, one acceleration per robot;
- :mod:`.boundary`: the admissibility test of one acceleration within the limit
  disc, bisection onto the NAO boundary, pushes out of slivers, sliding along it;
- :mod:`.candidates`: candidates tried nearest the desired acceleration first (the
  disk picture's, the ball search's, rings);
- :mod:`.search`: the disc search's entry points (selection, repair).

The public wrappers live in :mod:`nao_arena.geometry.clearance` and
:mod:`nao_arena.geometry.selection`. The loops that run per candidate borrow
their array arguments (:mod:`nao_arena.geometry.borrow`: no reference counting
per call) and get their scratch arrays from thin wrappers.

Compile time is part of the cost (the first run compiles what it calls), so:

- a compiled function calls another with a constant argument as ``np.int64(0)``
  or ``np.bool_(False)``, not ``0`` or ``False``: numba compiles a separate
  version of the callee for every literal value it is called with (a counter
  that starts at a literal is started the same way, since type inference first
  sees it as that literal). The exception is a literal meant to specialise a
  hot path: the candidate test scans with ``want_first=False``, so that its
  version of ``quartic.piece_minimum`` has no first-contact search;
- ``inline="always"`` is kept for small functions called per candidate, and an
  inlined function inlines no other large one: numba copies the callee's whole
  intermediate representation for every inlined call site, so nested inlining
  compiles in minutes (``outside._mark`` is a compiled call, not inlined, for
  that reason);
- small functions of scalars need no ``inline="always"``: LLVM inlines a compiled
  call of one (the motion rules of :mod:`nao_arena.motion`, called per candidate,
  are plain compiled functions, as fast as their former inlined copies).
"""
