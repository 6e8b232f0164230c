"""``social_force``: a person walking by the social force model (Helbing and Molnár 1995).

The model in its circular form, with the anisotropy factor of the later papers, every
quantity per unit mass (an acceleration, m/s^2; world frame; m, s, m/s). A person i at
p_i with velocity v_i, radius r_i and desired speed v0 accelerates by

    a_i = (v0 e_goal - v_i) / tau                                    (driving term)
        + sum_j A exp((r_ij - d_ij) / B) n_ij w(phi_ij)              (other bodies)
        + sum_W A_w exp((r_i - d_iW) / B_w) n_iW                     (walls)

- driving term: e_goal is the unit vector from p_i to the goal; v0 = min(v_pref, v_max,
  d_goal / (2 tau)) at distance d_goal (m) from the goal, and 0 within ``goal_radius`` of
  it (there the person brakes to a standstill, v_i relaxing to zero in tau). The cap
  d_goal / (2 tau) makes the arrival a damped approach (damping ratio 1/sqrt(2) while
  the acceleration stays within a_max) that ends within the goal radius instead of
  overshooting it; it only acts within 2 tau v0 of the goal (1.34 m at 1.34 m/s). A
  person with neither goal nor route stands still (v0 = 0).
- other bodies j (every neighbour the person senses, robots, people and traffic alike;
  with ``sees_robots=False`` none of kind ``"robot"``): r_ij = r_i + r_j (m), d_ij =
  |p_i - p_j| (m), n_ij = (p_i - p_j) / d_ij, the unit vector from j to i. The anisotropy
  w(phi) = lambda + (1 - lambda) (1 + cos phi) / 2 weighs a body ahead (phi = 0) by 1 and
  one right behind (phi = pi) by lambda, phi being the angle between the person's
  direction of motion e_i and the direction -n_ij in which j lies: cos phi = -n_ij . e_i.
  e_i = v_i / |v_i|; at rest (|v_i| <= 1e-6 m/s) the direction of the desired velocity;
  with neither (at rest at the goal) every direction weighs 1. Bodies at the person's own
  centre (d_ij = 0: no direction) push nothing.
- walls W (segments with half-thickness ``wall_radius``, m; 0 for polygon edges): d_iW =
  |p_i - q| - wall_radius, q the point of the segment nearest p_i, and n_iW = (p_i - q) /
  |p_i - q| (with p_i on the segment itself, its left-hand normal). Each segment repels
  on its own (at a polygon's corner both edges push).

Every exponent (r - d) / B is capped at :data:`EXPONENT_CAP` (bodies overlapping by more
than 50 B), so the acceleration stays finite however deep an overlap; the world scales a
longer acceleration to the person's a_max and keeps the speed within v_max.

Parameters (defaults: :class:`SocialForceParams`)
-------------------------------------------------
The defaults are the values of D. Helbing and P. Molnár, "Social force model for
pedestrian dynamics", Phys. Rev. E 51:4282-4286 (1995), also the defaults of
PySocialForce and of CrowdNav's socialforce: relaxation time tau = 0.5 s; the repulsive
potential of another person V(b) = V0 exp(-b / sigma), V0 = 2.1 m^2/s^2, sigma = 0.3 m;
that of a wall U(b) = U0 exp(-b / R), U0 = 10 m^2/s^2, R = 0.2 m. Their forces -V'(b) =
(V0 / sigma) exp(-b / sigma) are taken here in the circular form of D. Helbing, I.
Farkas and T. Vicsek, "Simulating dynamical features of escape panic", Nature
407:487-490 (2000), with b the gap between the bodies (d_ij - r_ij, d_iW - r_i; the 1995
paper's b is the semi-minor axis of an ellipse about the other person's centre that
stretches along its next step, and the distance from the centre to a wall): so
``strength`` A = V0 / sigma = 7 m/s^2, ``range`` B = sigma = 0.3 m, ``wall_strength``
A_w = U0 / R = 50 m/s^2, ``wall_range`` B_w = R = 0.2 m.

Helbing, Farkas and Vicsek's own parameters for this form (A_i = 2000 N, B_i = 0.08 m
for people and walls alike, mass 80 kg, tau = 0.5 s: per unit mass ``strength=25``,
``range=0.08``, ``wall_strength=25``, ``wall_range=0.08``) model escape panic, where
bodies touch: their body force and sliding friction (k = 1.2e5 kg/s^2, kappa = 2.4e5
kg/(m s)), like any contact, are the physics engine's here. Either way the circular form
does not anticipate: a person reacts to where others are, not to where they are going.
Two people meeting head-on in a corridor at 1 m/s pass with a gap at the defaults; at
1.1 m/s and faster they brush as they pass (overlaps of up to a few centimetres).

``anisotropy`` lambda = 0.5 (0 <= lambda <= 1; 1: isotropic, the 2000 paper's form):
the form w(phi) is that of D. Helbing, I. J. Farkas, P. Molnár and T. Vicsek,
"Simulation of pedestrian crowds in normal and evacuation situations", in Pedestrian
and Evacuation Dynamics, Springer (2002), pp. 21-58; the value gives a person right
behind the weight c = 0.5 that Helbing and Molnár (1995) give to what lies outside the
field of view.

``v_pref`` (m/s): the desired speed. None (the default) draws it once per episode, in
:meth:`SocialForceAgent.reset`, from the generator the arena hands the person (the same
seed gives the same person), from the normal distribution of mean 1.34 m/s and
standard deviation 0.26 m/s that Helbing and Molnár (1995) take for the desired speeds
of pedestrians (after Henderson 1971; 1.34 m/s is also U. Weidmann's free walking speed,
"Transporttechnik der Fussgänger", ETH Zürich, IVT Schriftenreihe 90, 1993), clipped to
[0.5, 2.0] m/s. Before any reset an undrawn v_pref is the mean, 1.34 m/s. The person
walks at most at its body's v_max.

``sees_robots`` (default True): False leaves out every neighbour of kind ``"robot"`` (the
"invisible robot" setup of CrowdNav, in which the people do not react to the robot).
Every other kind (``"traffic"``, and ``"person"`` for the bodies a map places as people)
is seen; people placed as robots (bodies of kind ``"robot"`` that this agent drives) are
left out like any robot. ``goal_radius`` (m, default 0.2): within it the person stands
still.

Batched
-------
All people of the class act together (:meth:`SocialForceAgent.act_batch`: one pass of
numpy operations over the step's bulk arrays, one row per person, one per (person,
neighbour) pair, one per (person, wall) pair); :meth:`SocialForceAgent.act` is the same
computation on the one-robot batch of its observation, so both give the same bits. The
sums over neighbours and walls are taken in the sensing order (neighbours nearest first,
walls as listed), one term after the other.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from nao_arena.agent import PanelAgent
from nao_arena.sensing import Observation, SensingBatch

__all__ = [
    "EXPONENT_CAP",
    "ROBOT_KIND",
    "V_PREF_MAX",
    "V_PREF_MEAN",
    "V_PREF_MIN",
    "V_PREF_SD",
    "SocialForceAgent",
    "SocialForceParams",
    "anisotropy_weight",
    "desired_velocities",
    "draw_v_pref",
    "headings",
    "neighbour_accelerations",
    "social_force_accelerations",
    "wall_accelerations",
]

V_PREF_MEAN = 1.34
"""Mean desired walking speed (m/s), Helbing and Molnár (1995); Weidmann (1993)."""
V_PREF_SD = 0.26
"""Standard deviation of the desired walking speed (m/s), Helbing and Molnár (1995)."""
V_PREF_MIN = 0.5
"""Smallest desired speed drawn (m/s): slower draws are raised to it."""
V_PREF_MAX = 2.0
"""Largest desired speed drawn (m/s): faster draws are lowered to it."""

EXPONENT_CAP = 50.0
"""Largest exponent (r - d) / B taken (exp(50) ~ 5e21): deep overlaps stay finite."""
ROBOT_KIND = "robot"
"""The kind of the bodies that ``sees_robots=False`` leaves out."""
_AT_REST = 1e-6
"""Speed (m/s) up to which a person has no direction of motion."""


@dataclass(frozen=True)
class SocialForceParams:
    """The social force model's parameters, per unit mass (see the module docstring for
    their sources): tau (s, > 0): relaxation time; strength (m/s^2, >= 0) and range (m,
    > 0): A and B of the repulsion between bodies; anisotropy (lambda, in [0, 1]): the
    weight of a body right behind; wall_strength (m/s^2, >= 0) and wall_range (m, > 0):
    the walls' A_w and B_w; goal_radius (m, >= 0): the person stands still within it;
    sees_robots: False leaves out neighbours of kind ``"robot"``. A bad value raises
    ValueError in one line naming the option."""

    tau: float = 0.5
    strength: float = 7.0  # V0 / sigma = 2.1 m^2/s^2 / 0.3 m
    range: float = 0.3
    anisotropy: float = 0.5
    wall_strength: float = 50.0  # U0 / R = 10 m^2/s^2 / 0.2 m
    wall_range: float = 0.2
    goal_radius: float = 0.2
    sees_robots: bool = True

    def __post_init__(self) -> None:
        fields = self.__dict__
        for name, low, strict, unit in (
            ("tau", 0.0, True, "s"),
            ("strength", 0.0, False, "m/s^2"),
            ("range", 0.0, True, "m"),
            ("anisotropy", 0.0, False, "lambda"),
            ("wall_strength", 0.0, False, "m/s^2"),
            ("wall_range", 0.0, True, "m"),
            ("goal_radius", 0.0, False, "m"),
        ):
            fields[name] = _number(name, fields[name], low, strict, unit)
        if self.anisotropy > 1.0:
            raise ValueError(
                f"social_force option anisotropy: expected a number in [0, 1] (lambda), "
                f"got {self.anisotropy!r}"
            )
        if not isinstance(self.sees_robots, (bool, np.bool_)):
            raise ValueError(
                f"social_force option sees_robots: expected True or False, got {self.sees_robots!r}"
            )
        fields["sees_robots"] = bool(self.sees_robots)


def _number(name: str, value: Any, low: float, strict: bool, unit: str) -> float:
    """``value`` as a finite float > low (strict) or >= low; else ValueError naming the
    option."""
    bad = isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating))
    x = math.nan
    if not bad:
        x = float(value)
        bad = not math.isfinite(x) or (x <= low if strict else x < low)
    if bad:
        rel = ">" if strict else ">="
        raise ValueError(
            f"social_force option {name}: expected a finite number {rel} {low:g} ({unit}), "
            f"got {value!r}"
        )
    return x


def draw_v_pref(rng: np.random.Generator) -> float:
    """One person's desired speed (m/s): one normal draw (mean :data:`V_PREF_MEAN`,
    standard deviation :data:`V_PREF_SD`) from ``rng``, clipped to [:data:`V_PREF_MIN`,
    :data:`V_PREF_MAX`]."""
    return float(np.clip(rng.normal(V_PREF_MEAN, V_PREF_SD), V_PREF_MIN, V_PREF_MAX))


def anisotropy_weight(cos_phi: NDArray[np.float64], anisotropy: Any) -> NDArray[np.float64]:
    """w(phi) = lambda + (1 - lambda) (1 + cos phi) / 2 (dimensionless): 1 ahead (cos phi
    = 1), lambda right behind (cos phi = -1); lambda one value or one per element."""
    return anisotropy + (1.0 - anisotropy) * (1.0 + cos_phi) / 2.0


def _norms(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """|v| (m or m/s) of each row of ``v`` (n, 2), as sqrt(x^2 + y^2)."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1])


def _unit_rows(v: NDArray[np.float64], norm: NDArray[np.float64], where: Any) -> Any:
    """v / |v| (n, 2) where ``where`` holds, else 0."""
    out = np.zeros_like(v)
    np.divide(v, norm[:, None], out=out, where=np.asarray(where)[:, None])
    return out


def desired_velocities(
    targets: NDArray[np.float64],
    positions: NDArray[np.float64],
    speeds: NDArray[np.float64],
    tau: NDArray[np.float64],
    goal_radius: NDArray[np.float64],
) -> NDArray[np.float64]:
    """v0 e_goal (n, 2) m/s per person: toward its target (m; a non-finite row: none) at
    v0 = min(speed, d / (2 tau)) from distance d (m), zero within ``goal_radius`` (m) of
    it or without a target; speeds (m/s) = min(v_pref, v_max), tau (s), per row."""
    rel = targets - positions
    dist = _norms(rel)
    walking = np.isfinite(dist) & (dist > goal_radius)
    speed = np.minimum(speeds, dist / (2.0 * tau))
    return _unit_rows(rel, dist, walking) * np.where(walking, speed, 0.0)[:, None]


def headings(
    velocities: NDArray[np.float64], desired: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Each person's direction of motion e_i (n, 2) and whether it has one: v / |v|;
    at rest (|v| <= 1e-6 m/s) the direction of the desired velocity ``desired`` (m/s);
    neither: none (every direction then weighs 1)."""
    speed = _norms(velocities)
    moving = speed > _AT_REST
    want = _norms(desired)
    wanting = want > 0.0
    e = np.where(
        moving[:, None],
        _unit_rows(velocities, speed, moving),
        _unit_rows(desired, want, wanting & ~moving),
    )
    return e, moving | wanting


def neighbour_accelerations(
    rel: NDArray[np.float64],
    reach: NDArray[np.float64],
    heading: NDArray[np.float64],
    has_heading: NDArray[np.bool_],
    strength: NDArray[np.float64],
    range_: NDArray[np.float64],
    anisotropy: NDArray[np.float64],
) -> NDArray[np.float64]:
    """A exp((r_ij - d_ij) / B) n_ij w(phi_ij) (E, 2) m/s^2, one row per (person,
    body) pair: rel = p_i - p_j (m), reach = r_ij = r_i + r_j (m), the person's heading
    e_i (unit; ``has_heading`` False: w = 1), A (m/s^2), B (m), lambda per pair. A pair at
    one centre (d_ij = 0) gives 0; the exponent is capped at :data:`EXPONENT_CAP`."""
    d = _norms(rel)
    apart = d > 0.0
    n = _unit_rows(rel, d, apart)
    cos_phi = -(n[:, 0] * heading[:, 0] + n[:, 1] * heading[:, 1])
    w = np.where(has_heading, anisotropy_weight(cos_phi, anisotropy), 1.0)
    magnitude = strength * np.exp(np.minimum((reach - d) / range_, EXPONENT_CAP))
    return n * (magnitude * w)[:, None]


def wall_accelerations(
    positions: NDArray[np.float64],
    radii: NDArray[np.float64],
    a: NDArray[np.float64],
    b: NDArray[np.float64],
    wall_radius: NDArray[np.float64],
    strength: NDArray[np.float64],
    range_: NDArray[np.float64],
) -> NDArray[np.float64]:
    """A_w exp((r_i - d_iW) / B_w) n_iW (P, 2) m/s^2, one row per (person, wall) pair:
    the person's centre (m) and radius (m), the wall's end points a, b (m) and
    half-thickness (m), A_w (m/s^2) and B_w (m) per pair. d_iW = |p_i - q| - wall_radius
    with q the point of segment ab nearest p_i; n_iW = (p_i - q) / |p_i - q|, or the
    left-hand normal of ab where p_i is on it (0 for a segment of no length)."""
    ab = b - a
    length2 = ab[:, 0] * ab[:, 0] + ab[:, 1] * ab[:, 1]
    ap = positions - a
    proper = length2 > 0.0
    t = np.zeros_like(length2)
    np.divide(ap[:, 0] * ab[:, 0] + ap[:, 1] * ab[:, 1], length2, out=t, where=proper)
    t = np.clip(t, 0.0, 1.0)
    rel = positions - (a + ab * t[:, None])
    d = _norms(rel)
    off = d > 0.0
    left = np.stack([-ab[:, 1], ab[:, 0]], axis=1)
    n = np.where(
        off[:, None],
        _unit_rows(rel, d, off),
        _unit_rows(left, np.sqrt(length2), proper & ~off),
    )
    gap = d - wall_radius
    magnitude = strength * np.exp(np.minimum((radii - gap) / range_, EXPONENT_CAP))
    return n * magnitude[:, None]


def _sum_by_row(
    row: NDArray[np.int64], terms: NDArray[np.float64], rows: int
) -> NDArray[np.float64]:
    """Sum (rows, 2) of the terms (P, 2) by their row, each row's terms added one after
    the other in their order (the same bits whichever other rows there are)."""
    return np.stack(
        [
            np.bincount(row, weights=terms[:, 0], minlength=rows),
            np.bincount(row, weights=terms[:, 1], minlength=rows),
        ],
        axis=1,
    )


@dataclass(frozen=True)
class _Table:
    """Per person (one row each): desired speed cap (m/s) and the parameters."""

    v_pref: NDArray[np.float64]
    tau: NDArray[np.float64]
    strength: NDArray[np.float64]
    range: NDArray[np.float64]
    anisotropy: NDArray[np.float64]
    wall_strength: NDArray[np.float64]
    wall_range: NDArray[np.float64]
    goal_radius: NDArray[np.float64]
    sees_robots: NDArray[np.bool_]


def _table(agents: Sequence[SocialForceAgent]) -> _Table:
    """The parameters of ``agents``, one row each."""
    rows = [
        (
            ag.v_pref,
            ag.params.tau,
            ag.params.strength,
            ag.params.range,
            ag.params.anisotropy,
            ag.params.wall_strength,
            ag.params.wall_range,
            ag.params.goal_radius,
        )
        for ag in agents
    ]
    table = np.array(rows, dtype=np.float64).reshape(len(agents), 8)
    c = [np.ascontiguousarray(table[:, i]) for i in range(8)]
    return _Table(
        v_pref=c[0],
        tau=c[1],
        strength=c[2],
        range=c[3],
        anisotropy=c[4],
        wall_strength=c[5],
        wall_range=c[6],
        goal_radius=c[7],
        sees_robots=np.array([ag.params.sees_robots for ag in agents], dtype=np.bool_),
    )


def _targets(batch: SensingBatch, rows: NDArray[np.int64]) -> NDArray[np.float64]:
    """Each robot's goal (m); a robot without one heads for its route's end; neither:
    NaN (it stands still)."""
    targets = np.array(batch.goals[rows], dtype=np.float64).reshape(len(rows), 2)
    for i, k in enumerate(rows.tolist()):
        if not np.all(np.isfinite(targets[i])):
            route = batch.routes[k]
            if route is not None and len(route):
                targets[i] = route[-1]
    return targets


def social_force_accelerations(
    batch: SensingBatch, rows: NDArray[np.int64], table: _Table
) -> NDArray[np.float64]:
    """The social force acceleration (len(rows), 2) m/s^2 of robots ``rows`` of ``batch``
    (robot order), their parameters one row each in ``table`` (see the module docstring)."""
    m = len(rows)
    bodies = batch.bodies[rows]
    p = np.asarray(batch.positions[bodies], dtype=np.float64).reshape(m, 2)
    v = np.asarray(batch.velocities[bodies], dtype=np.float64).reshape(m, 2)
    r = np.asarray(batch.radii[bodies], dtype=np.float64)
    speeds = np.minimum(table.v_pref, batch.v_max[bodies])
    desired = desired_velocities(_targets(batch, rows), p, speeds, table.tau, table.goal_radius)
    heading, has_heading = headings(v, desired)
    drive = (desired - v) / table.tau[:, None]

    # (person, neighbour) pairs in sensing order, people in row order
    start = batch.nb_start[rows]
    count = batch.nb_start[rows + 1] - start
    row = np.repeat(np.arange(m, dtype=np.int64), count)
    first = np.repeat(np.cumsum(count) - count, count)
    nb = batch.nb_index[np.repeat(start, count) + np.arange(len(row)) - first]
    if not table.sees_robots.all():
        seen = table.sees_robots[row] | (batch.kinds[nb] != ROBOT_KIND)
        row, nb = row[seen], nb[seen]
    pairs = neighbour_accelerations(
        p[row] - batch.positions[nb],
        r[row] + batch.radii[nb],
        heading[row],
        has_heading[row],
        table.strength[row],
        table.range[row],
        table.anisotropy[row],
    )
    bodies_push = _sum_by_row(row, pairs, m)

    # (person, wall) pairs, walls in their order
    walls = np.asarray(batch.walls, dtype=np.float64).reshape(-1, 2, 2)
    w = len(walls)
    wrow = np.repeat(np.arange(m, dtype=np.int64), w)
    wall = np.tile(np.arange(w, dtype=np.int64), m)
    wall_terms = wall_accelerations(
        p[wrow],
        r[wrow],
        walls[wall, 0],
        walls[wall, 1],
        np.asarray(batch.wall_radius, dtype=np.float64)[wall],
        table.wall_strength[wrow],
        table.wall_range[wrow],
    )
    walls_push = _sum_by_row(wrow, wall_terms, m)
    return drive + bodies_push + walls_push


class SocialForceAgent:
    """A person walking by the social force model (see the module docstring).

    Options (keyword, defaults from Helbing and Molnár 1995, per unit mass): tau
    (s), strength (m/s^2), range (m), anisotropy (lambda in [0, 1]), wall_strength
    (m/s^2), wall_range (m), goal_radius (m), sees_robots (False: neighbours of kind
    "robot" are left out) and v_pref (m/s; None: drawn per person at each reset).
    ``params`` holds the first eight (:class:`SocialForceParams`); ``v_pref`` is the
    person's desired speed (m/s) for the episode."""

    def __init__(
        self,
        tau: float = SocialForceParams.tau,
        strength: float = SocialForceParams.strength,
        range: float = SocialForceParams.range,
        anisotropy: float = SocialForceParams.anisotropy,
        wall_strength: float = SocialForceParams.wall_strength,
        wall_range: float = SocialForceParams.wall_range,
        goal_radius: float = SocialForceParams.goal_radius,
        sees_robots: bool = True,
        v_pref: float | None = None,
    ) -> None:
        self.params = SocialForceParams(
            tau=tau,
            strength=strength,
            range=range,
            anisotropy=anisotropy,
            wall_strength=wall_strength,
            wall_range=wall_range,
            goal_radius=goal_radius,
            sees_robots=sees_robots,
        )
        self.v_pref_option = (
            None if v_pref is None else _number("v_pref", v_pref, 0.0, False, "m/s")
        )
        self.v_pref = V_PREF_MEAN if self.v_pref_option is None else self.v_pref_option

    def reset(self, spec: Any, rng: np.random.Generator) -> None:
        """A new episode: the desired speed is the option's, or one draw from ``rng``
        (:func:`draw_v_pref`) when the option is None."""
        self.v_pref = self.v_pref_option if self.v_pref_option is not None else draw_v_pref(rng)

    def panel(self) -> PanelAgent:
        """What the viewer's acceleration panel shows of this person: its desired speed."""
        return PanelAgent(v_pref=self.v_pref)

    def act(self, obs: Observation) -> NDArray[np.float64]:
        """The social force acceleration (2,) m/s^2 (world frame) of the person ``obs``
        describes: :meth:`act_batch`'s computation on the one-robot batch of ``obs``."""
        batch = SensingBatch.of_observation(obs)
        return social_force_accelerations(batch, _ROW0, _table([self]))[0]

    @classmethod
    def act_batch(
        cls, agents: Sequence[SocialForceAgent], batch: SensingBatch, rows: Sequence[int]
    ) -> NDArray[np.float64] | list[NDArray[np.float64] | Exception]:
        """:meth:`act` of every robot ``rows`` of ``batch`` at once (agent i drives robot
        rows[i]): an array (len(rows), 2) m/s^2. If a subclass overrides ``act``, every
        agent acts robot by robot: one acceleration or exception per row (a list)."""
        rows_a = np.asarray(rows, dtype=np.int64).reshape(-1)
        if all(type(ag).act is _ACT for ag in agents):
            return social_force_accelerations(batch, rows_a, _table(agents))
        out: list[NDArray[np.float64] | Exception] = []
        for ag, k in zip(agents, rows_a.tolist(), strict=True):
            try:
                out.append(ag.act(batch.observation(k)))
            except Exception as exc:  # noqa: BLE001 - the agent's failure
                out.append(exc)
        return out


_ACT = SocialForceAgent.act
_ROW0 = np.zeros(1, dtype=np.int64)
