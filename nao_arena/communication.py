"""Communication between robots: what cooperative agents share, and when it arrives.

A map's ``communication`` section (or :class:`~nao_arena.arena.ArenaOptions`'
``communication_*`` fields) sets a channel with a ``range`` (m), a ``latency`` (s) and a
``loss`` (probability); ``communication: off`` is range 0: nothing is shared. The
default is perfect (infinite range, no latency, no loss), and then the arena does
exactly what it did before the channel existed.

Every control period each robot broadcasts a message: its exact state (position m,
velocity m/s, world frame) and, over the same exchange, its plan for the period. A
message from robot j reaches robot i when the two are within ``range`` of each other
when it is sent, unless the exchange is lost: each unordered pair loses its exchange of
a period with probability ``loss``, both directions together (:func:`lost`, a
deterministic draw keyed by the episode's seed, the pair and the period, so the same
seed loses the same messages). It arrives ``latency`` s later, in whole control periods
(``round(latency / dt)``).

Two robots are *linked* in a period when their exchange of that period arrives in that
period: within range, not lost, and no latency. Linked robots can agree on their plans
within the period (the stopping-plan rule of :mod:`nao_arena.stopping` runs on linked
pairs) and see each other's committed accelerations (the ``plans`` of sensing, which
are NaN for every pair that is not linked). Robots that are not linked know of each
other only what they sense and the last message heard (:class:`Heard`).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["OFF", "Channel", "Communication", "Heard", "exchanges", "lost"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Communication:
    """A channel's settings: ``range`` (m, >= 0; inf: everywhere, 0: off), ``latency``
    (s, >= 0), ``loss`` (probability in [0, 1] that a pair's exchange of a period is
    lost)."""

    range: float = math.inf
    latency: float = 0.0
    loss: float = 0.0

    @property
    def perfect(self) -> bool:
        """Whether every message arrives at once, everywhere: the default."""
        return self.range == math.inf and self.latency == 0.0 and self.loss == 0.0

    @property
    def off(self) -> bool:
        """Whether nothing is ever shared (range 0 or every exchange lost)."""
        return self.range == 0.0 or self.loss >= 1.0


OFF = Communication(range=0.0)
"""No communication: robots know of each other only what they sense."""


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def _mix(x: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """The splitmix64 finaliser of x (uint64, wrapping)."""
    x = x ^ (x >> np.uint64(30))
    x = x * np.uint64(0xBF58476D1CE4E5B9)
    x = x ^ (x >> np.uint64(27))
    x = x * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def lost(
    key: int, first: NDArray[np.int64], second: NDArray[np.int64], period: int, loss: float
) -> NDArray[np.bool_]:
    """Whether the exchange of the unordered robot pairs (first[e], second[e]) (robot
    indices) in control period ``period`` is lost, with probability ``loss``: a uniform
    draw in [0, 1) from a hash of (key, pair, period), the same for (i, j) and (j, i)."""
    lo = np.minimum(first, second).astype(np.uint64)
    hi = np.maximum(first, second).astype(np.uint64)
    with np.errstate(over="ignore"):
        x = _mix(np.uint64(key) + _GOLDEN * (np.uint64(period) + np.uint64(1)))
        x = _mix(x ^ (lo * np.uint64(0xD6E8FEB86659FD93)))
        x = _mix(x ^ (hi * np.uint64(0xA0761D6478BD642F)))
    uniform = (x >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)
    return np.asarray(uniform < loss, dtype=np.bool_)


def exchanges(
    positions: FloatArray, comm: Communication, key: int, period: int
) -> NDArray[np.bool_]:
    """(R, R): whether the exchange of robots i and j (robot order; centres ``positions``
    (R, 2) m when it is sent) in control period ``period`` arrives: within ``comm.range``
    of each other and not lost (:func:`lost`). Symmetric; the diagonal is False."""
    n = len(positions)
    out = np.zeros((n, n), dtype=np.bool_)
    if n < 2 or comm.off:
        return out
    i, j = np.triu_indices(n, 1)
    d = positions[i] - positions[j]
    ok = np.hypot(d[:, 0], d[:, 1]) <= comm.range
    if comm.loss > 0.0:
        ok &= ~lost(key, i, j, period, comm.loss)
    out[i[ok], j[ok]] = True
    out[j[ok], i[ok]] = True
    return out


@dataclass(frozen=True)
class Heard:
    """What the robots know of each other through the channel at one control period
    (robot order; read-only arrays).

    linked (R, R): the pairs linked this period (see the module). time (R, R) s: when
    the last message robot i heard from robot j was sent (-inf: none yet); position
    (R, R, 2) m and velocity (R, R, 2) m/s: the state it carried (j's exact state then,
    world frame)."""

    linked: NDArray[np.bool_]
    time: FloatArray
    position: FloatArray
    velocity: FloatArray


def _frozen(a: NDArray) -> NDArray:
    a.setflags(write=False)
    return a


class Channel:
    """The messages of one episode: sends each period's broadcast and delivers what
    arrives (:meth:`exchange`)."""

    def __init__(self, comm: Communication, n_robots: int, dt: float, key: int) -> None:
        self.comm = comm
        self.dt = float(dt)
        self.key = int(key)
        self.delay = int(round(comm.latency / self.dt))
        n = int(n_robots)
        self._time = np.full((n, n), -math.inf)
        self._position = np.zeros((n, n, 2))
        self._velocity = np.zeros((n, n, 2))
        # messages on their way: (send time, delivered (R, R), positions, velocities)
        self._on_the_way: deque[tuple[float, NDArray[np.bool_], FloatArray, FloatArray]] = deque()

    def exchange(self, time: float, positions: FloatArray, velocities: FloatArray) -> Heard:
        """Every robot broadcasts its state (positions (R, 2) m, velocities (R, 2) m/s, at
        ``time`` s); the messages due by now arrive; returns what is known now."""
        period = int(round(time / self.dt))
        delivered = exchanges(positions, self.comm, self.key, period)
        self._on_the_way.append(
            (float(time), delivered, np.array(positions, float), np.array(velocities, float))
        )
        while self._on_the_way and self._on_the_way[0][0] + self.delay * self.dt <= time + 1e-9:
            sent, ok, p, v = self._on_the_way.popleft()
            receiver, sender = np.nonzero(ok)
            self._time[receiver, sender] = sent
            self._position[receiver, sender] = p[sender]
            self._velocity[receiver, sender] = v[sender]
        linked = delivered if self.delay == 0 else np.zeros_like(delivered)
        return Heard(
            linked=_frozen(linked.copy()),
            time=_frozen(self._time.copy()),
            position=_frozen(self._position.copy()),
            velocity=_frozen(self._velocity.copy()),
        )
