"""The compiled geometry kernels (numba, ``cache=True``), one module per concept:

- :mod:`.bundles`: the named bundles (NamedTuples) the kernels take their arguments in;
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
- no function is inlined by numba (``inline="always"``): numba deep-copies the
  callee's whole intermediate representation for every inlined call site (7.5 of
  the 11 s that ``segment.wall_scan`` took to compile). LLVM inlines compiled
  calls anyway, once the callees' code is linked into the caller's module:
  without numba's inlining the decisions of ``benchmarks/bench_decisions.py``
  run as fast and the kernels of a NAO run compile in 65 s of CPU instead of 89;
- an array is filled by element loops, not by slice or broadcast assignment
  (``a[:, 2] = x``, ``a[k] = b[i]``): numba compiles a shape-mismatch error
  message, with its string formatting, for each such assignment.
"""
