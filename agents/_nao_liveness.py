"""The ``nao`` agent's liveness test on a whole batch, in one compiled call.

:func:`held_by_standing_kernel` is :func:`nao_arena.agents.nao._held_by_standing`'s
work: per robot, whether parked robots hold it while it has room behind it (the
time that counts toward switching the side of its detours).
"""

from __future__ import annotations

import math

from nao_arena.jit import inner_kernel

#: m/s below which the nearest neighbour counts as standing still
STILL_SPEED = 0.1
#: m from the robot's surface within which a neighbour holds it, or boxes it in
HOLD_GAP = 1.0


@inner_kernel
def held_by_standing_kernel(
    nb_start, nb_index, rows, bodies, positions, velocities, radii, rad, goals, out
):
    """Per robot i (batch row rows[i], body bodies[rows[i]], radius rad[i] m, goal
    goals[i] m): out[i] = its nearest sensed neighbour (the first of its list
    nb_index[nb_start[row]:nb_start[row + 1]]) stands still (below STILL_SPEED m/s)
    within HOLD_GAP m of its surface, and no sensed neighbour is within HOLD_GAP m
    of its surface on the side away from its goal (relative position . (goal -
    position) < 0). positions (m), velocities (m/s), radii (m) are per body."""
    for i in range(rows.shape[0]):
        row = rows[i]
        start = nb_start[row]
        stop = nb_start[row + 1]
        out[i] = False
        if stop <= start:
            continue
        own = bodies[row]
        px = positions[own, 0]
        py = positions[own, 1]
        near = nb_index[start]
        gap = math.hypot(positions[near, 0] - px, positions[near, 1] - py) - radii[near] - rad[i]
        if not (
            math.hypot(velocities[near, 0], velocities[near, 1]) < STILL_SPEED and gap < HOLD_GAP
        ):
            continue
        ax = goals[i, 0] - px
        ay = goals[i, 1] - py
        boxed = False
        for e in range(start, stop):
            other = nb_index[e]
            rx = positions[other, 0] - px
            ry = positions[other, 1] - py
            if math.hypot(rx, ry) - radii[other] - rad[i] < HOLD_GAP and rx * ax + ry * ay < 0.0:
                boxed = True
                break
        out[i] = not boxed
