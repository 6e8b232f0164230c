"""The imperfect world's sensing and actuation models, applied by :class:`~nao_arena.arena.Arena`.

Each is off at its neutral value (noise 0, dropout 0, field of view 2 pi, lag 0), and
then the arena does exactly what it does without it. Units: m, s, rad; vectors in the
world frame. Random draws come from generators the arena seeds from the episode's seed.

- Field of view (``sensing.field_of_view``, rad): a robot senses only the bodies whose
  centre lies within half the field of view of its heading: the direction of its velocity,
  or, standing still (speed below :data:`STILL_SPEED`), the direction to its goal; a robot
  standing still on its goal has no heading and senses all around. The nearest
  ``max_neighbours`` of the bodies in view are sensed (:func:`in_view`, :func:`subset`).
- Dropout (``sensing.dropout``, probability): each neighbour of each robot is missed in a
  step with that probability, independently (:func:`drop`).
- Noise (``sensing.noise``, m, m/s, m/s^2): Gaussian noise on what each robot senses of
  each neighbour's position, velocity and acceleration, drawn per observer, neighbour and
  step (:func:`with_neighbour_noise`). A robot's own state stays exact.
- Occlusion (``sensing.occlusion``): a robot senses only the bodies it can see past the
  bodies within its sensing range and the walls (:func:`nao_arena.occlusion.visible`),
  before the field of view and the ``max_neighbours`` cut.
- Lag (``actuation.lag``, s): a first-order response of the applied acceleration to the
  command (:func:`lag_factor`, :func:`lag_step`).
- Communication (``communication``: range m, latency s, loss): what cooperative robots
  share (:mod:`nao_arena.communication`); perfect by default.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from nao_arena.communication import Communication
from nao_arena.sensing import SensingBatch

if TYPE_CHECKING:
    from nao_arena.arena import ArenaOptions
    from nao_arena.maps import MapSpec

__all__ = [
    "NOISE_KEYS",
    "STILL_SPEED",
    "Imperfections",
    "drop",
    "headings",
    "imperfections",
    "in_view",
    "lag_factor",
    "lag_step",
    "subset",
    "with_neighbour_noise",
]

STILL_SPEED = 1e-6
"""Speed (m/s) below which a robot stands still: its heading is the direction to its goal."""

NOISE_KEYS = ("position", "velocity", "acceleration")
"""The keys of a sensing noise mapping: standard deviations in m, m/s and m/s^2."""


@dataclass(frozen=True)
class Imperfections:
    """The sensing and actuation models of an arena (the map's values, or the options').

    noise: standard deviations of the sensing noise on position (m), velocity (m/s) and
    acceleration (m/s^2); dropout: probability in [0, 1]; field_of_view: rad in
    (0, 2 pi]; occlusion: whether bodies and walls hide what is behind them; lag: time
    constant (s) of the actuation's response, >= 0; communication: the channel's
    range (m), latency (s) and loss.
    """

    noise: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dropout: float = 0.0
    field_of_view: float = math.tau
    occlusion: bool = False
    lag: float = 0.0
    communication: Communication = Communication()

    @property
    def noisy(self) -> bool:
        """Whether any of the sensing noise's standard deviations is > 0."""
        return any(sigma > 0.0 for sigma in self.noise)

    @property
    def all_around(self) -> bool:
        """Whether the field of view is the whole circle (no filtering)."""
        return self.field_of_view >= math.tau


def _number(name: str, value: object, low: float, high: float, low_open: bool = False) -> float:
    """``value`` as a float in [low, high] ((low, high] with low_open); ValueError naming
    ``name`` otherwise."""
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        x = float(value)  # type: ignore[arg-type]
        if (x > low if low_open else x >= low) and x <= high:
            return x
    span = f"{'(' if low_open else '['}{low:g}, {'2 pi' if high == math.tau else f'{high:g}'}]"
    raise ValueError(f"{name}: expected a finite number in {span}, got {value!r}")


def _flag(name: str, value: object) -> bool:
    """``value`` if it is a bool; ValueError naming ``name`` otherwise."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    raise ValueError(f"{name}: expected True or False, got {value!r}")


def _noise(value: Mapping[str, float]) -> tuple[float, float, float]:
    """A sensing noise mapping (keys of :data:`NOISE_KEYS`, missing ones 0) as a tuple;
    ValueError naming ``sensing_noise`` for another key or a value that is not >= 0."""
    if not isinstance(value, Mapping):
        raise ValueError(
            f"sensing_noise: expected a mapping with keys {', '.join(NOISE_KEYS)}, got {value!r}"
        )
    unknown = sorted(set(value) - set(NOISE_KEYS))
    if unknown:
        raise ValueError(
            f"sensing_noise: unknown key {unknown[0]!r}; expected one of: {', '.join(NOISE_KEYS)}"
        )
    p, v, a = (
        _number(f"sensing_noise.{key}", value.get(key, 0.0), 0.0, math.inf) for key in NOISE_KEYS
    )
    return (p, v, a)


def imperfections(spec: MapSpec, options: ArenaOptions) -> Imperfections:
    """The models of ``spec`` with the options that are set (not None) in their place;
    ValueError naming the option for an out-of-range value."""
    sensing, actuation = spec.sensing, spec.actuation
    noise = options.sensing_noise
    return Imperfections(
        noise=(
            (sensing.noise.position, sensing.noise.velocity, sensing.noise.acceleration)
            if noise is None
            else _noise(noise)
        ),
        dropout=_number(
            "sensing_dropout",
            sensing.dropout if options.sensing_dropout is None else options.sensing_dropout,
            0.0,
            1.0,
        ),
        field_of_view=_number(
            "sensing_field_of_view",
            sensing.field_of_view
            if options.sensing_field_of_view is None
            else options.sensing_field_of_view,
            0.0,
            math.tau,
            low_open=True,
        ),
        occlusion=_flag(
            "sensing_occlusion",
            sensing.occlusion if options.sensing_occlusion is None else options.sensing_occlusion,
        ),
        lag=_number(
            "actuation_lag",
            actuation.lag if options.actuation_lag is None else options.actuation_lag,
            0.0,
            math.inf,
        ),
        communication=_communication(spec, options),
    )


def _communication(spec: MapSpec, options: ArenaOptions) -> Communication:
    """The map's communication with the options that are set in their place; ValueError
    naming the option for an out-of-range value."""
    comm = spec.communication
    reach = comm.reach if options.communication_range is None else options.communication_range
    if not (isinstance(reach, int | float) and not isinstance(reach, bool) and float(reach) >= 0.0):
        raise ValueError(f"communication_range: expected a number >= 0 or inf, got {reach!r}")
    latency = (
        comm.latency if options.communication_latency is None else options.communication_latency
    )
    loss = comm.loss if options.communication_loss is None else options.communication_loss
    return Communication(
        range=float(reach),
        latency=_number("communication_latency", latency, 0.0, math.inf),
        loss=_number("communication_loss", loss, 0.0, 1.0),
    )


# ---------------------------------------------------------------------- field of view


def headings(
    positions: NDArray[np.float64], velocities: NDArray[np.float64], goals: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Unit headings (R, 2) of robots at ``positions`` (R, 2) m with ``velocities`` (R, 2)
    m/s and ``goals`` (R, 2) m: the direction of the velocity, or, below
    :data:`STILL_SPEED`, the direction to the goal; NaN where neither is defined (on the
    goal, or no finite goal)."""
    speed = np.hypot(velocities[:, 0], velocities[:, 1])
    to_goal = goals - positions
    distance = np.hypot(to_goal[:, 0], to_goal[:, 1])
    moving = speed >= STILL_SPEED
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(
            moving[:, None],
            velocities / speed[:, None],
            to_goal / distance[:, None],
        )
    out[~moving & ~(distance > 0.0)] = np.nan
    return out


def in_view(
    start: NDArray[np.int64],
    index: NDArray[np.int64],
    observers: NDArray[np.int64],
    positions: NDArray[np.float64],
    heading: NDArray[np.float64],
    field_of_view: float,
) -> NDArray[np.bool_]:
    """Which entries of the CSR neighbour lists (``start`` (R + 1,), ``index`` (E,): the
    bodies observer k = body ``observers[k]`` senses are index[start[k]:start[k + 1]])
    lie in view: the angle between the body's centre as seen from the observer's and the
    observer's ``heading`` (R, 2, unit; a NaN row sees all around) is at most half of
    ``field_of_view`` (rad). A body at the observer's very centre is in view."""
    counts = np.diff(start)
    rows = np.repeat(np.arange(len(counts)), counts)
    rel = positions[index] - positions[observers[rows]]
    h = heading[rows]
    distance = np.hypot(rel[:, 0], rel[:, 1])
    along = rel[:, 0] * h[:, 0] + rel[:, 1] * h[:, 1]
    inside: NDArray[np.bool_] = along >= distance * math.cos(0.5 * field_of_view)
    return inside | np.isnan(h[:, 0])


def subset(
    start: NDArray[np.int64],
    index: NDArray[np.int64],
    keep: NDArray[np.bool_],
    most: int | None = None,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The CSR lists (``start`` (R + 1,), ``index`` (E,)) with only the entries where
    ``keep`` (E,) holds, each list then cut to its first ``most`` (None: all), in order."""
    counts = np.diff(start)
    rows = np.repeat(np.arange(len(counts)), counts)[keep]
    kept = index[keep]
    tally = np.bincount(rows, minlength=len(counts))
    if most is not None:
        first = np.concatenate(([0], np.cumsum(tally)))
        rank = np.arange(len(rows)) - first[rows]
        kept = kept[rank < most]
        tally = np.minimum(tally, most)
    out_start = np.concatenate(([0], np.cumsum(tally))).astype(np.int64)
    return out_start, kept.astype(np.int64)


# ---------------------------------------------------------------------- dropout and noise


def drop(
    start: NDArray[np.int64],
    index: NDArray[np.int64],
    probability: float,
    rng: np.random.Generator,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The CSR lists less the entries missed: each independently with ``probability``
    (one uniform draw from ``rng`` per entry, in list order)."""
    keep = rng.random(len(index)) >= probability
    return subset(start, index, keep)


def with_neighbour_noise(
    batch: SensingBatch, sigmas: tuple[float, float, float], rng: np.random.Generator
) -> SensingBatch:
    """``batch`` with Gaussian noise of standard deviations ``sigmas`` (position m,
    velocity m/s, acceleration m/s^2; per component) on what each robot senses of each
    neighbour: every (robot, neighbour) pair of its lists gets a body row of its own,
    appended after the batch's rows, a copy of the neighbour's row with the noise added
    (drawn from ``rng``: positions, then velocities, then accelerations, (E, 2) each, in
    list order; none for a zero standard deviation); the lists point at those rows, in
    the same order (nearest first by the true distance), and ``row_bodies`` names the
    body of every row. The other rows, the robots' own states among them, are unchanged;
    radii, limits, kinds, shared plans and known paths are copied as they are."""
    n = len(batch.positions)
    idx = batch.nb_index

    def noisy(values: NDArray[np.float64], sigma: float) -> NDArray[np.float64]:
        rows = values[idx]
        if sigma > 0.0:
            rows = rows + rng.normal(0.0, sigma, rows.shape)
        return np.concatenate([values, rows])

    def copied(values: NDArray) -> NDArray:
        return np.concatenate([values, values[idx]])

    sp, sv, sa = sigmas
    positions = noisy(batch.positions, sp)
    velocities = noisy(batch.velocities, sv)
    accelerations = noisy(batch.accelerations, sa)
    return dataclasses.replace(
        batch,
        positions=positions,
        velocities=velocities,
        accelerations=accelerations,
        radii=copied(batch.radii),
        a_max=copied(batch.a_max),
        v_max=copied(batch.v_max),
        kinds=copied(batch.kinds),
        plans=None if batch.plans is None else copied(batch.plans),
        known_paths=None if batch.known_paths is None else copied(batch.known_paths),
        nb_index=np.arange(n, n + len(idx), dtype=np.int64),
        row_bodies=np.concatenate([batch.body_of(np.arange(n)), batch.body_of(idx)]),
        _everyone=None,
    )


# ---------------------------------------------------------------------- lag


def lag_factor(dt: float, lag: float) -> float:
    """1 - exp(-dt / lag): the fraction of the gap to a command held for dt (s) that a
    first-order response of time constant ``lag`` (s, > 0) closes."""
    return -math.expm1(-dt / lag)


def lag_step(
    applied: NDArray[np.float64], command: NDArray[np.float64], factor: float
) -> NDArray[np.float64]:
    """The applied accelerations (R, 2) m/s^2 after one control period of the
    first-order lag: applied + factor (command - applied) (:func:`lag_factor`), the exact
    response at the period's end to a command held over it (updates ``applied``)."""
    applied += factor * (command - applied)
    return applied
