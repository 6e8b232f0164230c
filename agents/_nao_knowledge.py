"""What each ``nao`` robot knows of the others of its group under imperfect communication.

The stopping-plan rule (:mod:`nao_arena.stopping`) lets linked robots agree on their
plans; of a robot it is not linked with, a robot knows only the freshest of what it
sensed of it (with the sensing's age and noise) and the last message it heard from it
(exact, as old as it is). :func:`knowledge` gathers that into the rule's
:class:`~nao_arena.stopping.Knowledge`. Under perfect communication (``heard`` None)
every pair is linked.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from nao_arena.sensing import SensingBatch
from nao_arena.stopping import Knowledge, no_knowledge

__all__ = ["knowledge"]


def knowledge(sensed: SensingBatch, rows: NDArray[np.int64], sigmas: float) -> Knowledge:
    """What the group's robots ``rows`` (robot order) know of each other, from the batch
    as sensed (before any latency compensation): its neighbour lists and what the
    robots heard. Time is now (``sensed.time + sensed.age``). ``sigmas``: how many
    standard deviations of the sensing noise the tubes grow by."""
    heard = sensed.heard
    if heard is None:
        return no_knowledge()
    rows = np.asarray(rows, dtype=np.int64)
    n = len(rows)
    dt = float(sensed.dt)
    pair = np.ix_(rows, rows)
    linked = np.array(heard.linked[pair])
    when = np.array(heard.time[pair])
    position = np.array(heard.position[pair])
    velocity = np.array(heard.velocity[pair])
    spread = np.zeros((n, n, 2))
    # what each robot sensed of the group: used where it is fresher than the last message
    bodies = sensed.body_of(np.asarray(sensed.bodies, dtype=np.int64)[rows])
    member = np.full(int(bodies.max(initial=-1)) + 1, -1, dtype=np.int64)
    member[bodies] = np.arange(n)
    start = np.asarray(sensed.nb_start, dtype=np.int64)
    counts = start[rows + 1] - start[rows]
    observer = np.repeat(np.arange(n), counts)
    entries = np.concatenate(
        [np.arange(start[r], start[r + 1]) for r in rows.tolist()] or [np.zeros(0, np.int64)]
    ).astype(np.int64)
    seen_rows = np.asarray(sensed.nb_index, dtype=np.int64)[entries]
    seen_bodies = sensed.body_of(seen_rows)
    other = np.full(len(seen_rows), -1, dtype=np.int64)
    inside = seen_bodies < len(member)
    other[inside] = member[seen_bodies[inside]]
    t_sensed = float(sensed.time)
    use = (other >= 0) & (t_sensed > when[observer, np.maximum(other, 0)])
    i, j, r = observer[use], other[use], seen_rows[use]
    when[i, j] = t_sensed
    position[i, j] = sensed.positions[r]
    velocity[i, j] = sensed.velocities[r]
    sigma_p, sigma_v, _ = sensed.sensing_noise
    spread[i, j] = (sigma_p, sigma_v)
    now = t_sensed + float(sensed.age)
    free = np.zeros((n, n), dtype=np.int64)
    known = np.isfinite(when)
    free[known] = np.rint((now - when[known]) / dt).astype(np.int64) + 1
    np.fill_diagonal(free, 0)
    return Knowledge(linked, position, velocity, free, spread, float(sigmas))
