"""The map file's schema: the pydantic models of its sections (unknown keys are errors,
models are frozen), the size limits, and :class:`MapSpec`, a loaded map. The fields are
described in :mod:`nao_arena.maps`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, Literal, cast

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticKnownError

from nao_arena.traffic import CircleLane, FollowerParams, PolylineLane

__all__ = [
    "MAX_BODIES",
    "MAX_ITERATIONS",
    "MAX_DT",
    "MAX_LATENCY",
    "MAX_MAGNITUDE",
    "MAX_STEPS",
    "MAX_SUBSTEPS",
    "MAX_TIME_LIMIT",
    "MIN_DT",
    "MAX_TRIES",
    "Actuation",
    "BodyCount",
    "BodySpec",
    "Bounds",
    "CircleLaneSpec",
    "Episode",
    "LayoutSpec",
    "MapFile",
    "MapSpec",
    "NonNeg",
    "Num",
    "Physics",
    "PolygonWall",
    "PolylineLaneSpec",
    "Pos",
    "PosInt",
    "RobotSpec",
    "RobotTemplate",
    "Scalar",
    "SegmentWall",
    "CommunicationSpec",
    "Sensing",
    "SensingNoise",
    "StrictModel",
    "TrafficGroup",
    "Vec2",
]


MAX_BODIES = 10_000
"""Most bodies (robots and traffic vehicles) in one map, and in one layout or lane."""
MAX_SUBSTEPS = 1000
"""Most physics substeps per control period (``physics.substeps``)."""
MAX_ITERATIONS = 1000
"""Most solver iterations per physics step (``physics.iterations``)."""
MAX_TRIES = 1_000_000
"""Most random draws of the ``crowd`` builder (``max_tries``)."""
MAX_MAGNITUDE = 1e6
"""Largest magnitude of any number in a map (coordinates in m, speeds in m/s, ...)."""
MIN_DT = 1e-3
"""Shortest control period ``physics.dt`` (s)."""
MAX_DT = 1.0
"""Longest control period ``physics.dt`` (s)."""
MAX_TIME_LIMIT = 1e5
"""Longest episode ``episode.time_limit`` (s, about 28 h)."""
MAX_LATENCY = 10.0
"""Longest sensing latency ``sensing.latency`` (s)."""
MAX_STEPS = 1_000_000
"""Most control periods in an episode (``episode.time_limit / physics.dt``)."""


def _no_bool_number(value: Any) -> Any:
    """A YAML ``true`` is not the number 1."""
    if isinstance(value, bool):
        raise PydanticKnownError("float_type")
    return value


def _no_bool_integer(value: Any) -> Any:
    if isinstance(value, bool):
        raise PydanticKnownError("int_type")
    return value


def _within_magnitude(value: float) -> float:
    """At most :data:`MAX_MAGNITUDE` either way (checked after finiteness)."""
    if value > MAX_MAGNITUDE:
        raise PydanticKnownError("less_than_equal", {"le": MAX_MAGNITUDE})
    if value < -MAX_MAGNITUDE:
        raise PydanticKnownError("greater_than_equal", {"ge": -MAX_MAGNITUDE})
    return value


Num = Annotated[
    float,
    BeforeValidator(_no_bool_number),
    Field(allow_inf_nan=False),
    AfterValidator(_within_magnitude),
]
Pos = Annotated[Num, Field(gt=0)]
NonNeg = Annotated[Num, Field(ge=0)]
Vec2 = tuple[Num, Num]
PosInt = Annotated[int, BeforeValidator(_no_bool_integer), Field(gt=0)]
BodyCount = Annotated[PosInt, Field(le=MAX_BODIES)]
Scalar = bool | int | float | str


class StrictModel(BaseModel):
    """A section of a map file: unknown keys are errors; instances are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class Bounds(StrictModel):
    """The arena's extent (m); ``walls`` closes it with segments of ``wall_thickness`` m."""

    min: Vec2
    max: Vec2
    walls: bool = False
    wall_thickness: Pos = 0.2

    @model_validator(mode="after")
    def _ordered(self) -> Bounds:
        if not (self.max[0] > self.min[0] and self.max[1] > self.min[1]):
            raise ValueError(f"expected max > min in x and y, got min {self.min} max {self.max}")
        return self

    def contains(self, points: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether points (n, 2) m lie inside the bounds (edges included)."""
        p = np.asarray(points, float).reshape(-1, 2)
        lo, hi = np.array(self.min), np.array(self.max)
        return np.all((p >= lo) & (p <= hi), axis=1)


class SegmentWall(StrictModel):
    """A straight wall from a to b (m) of ``thickness`` m (a capsule of radius thickness/2)."""

    type: Literal["segment"]
    a: Vec2
    b: Vec2
    thickness: Pos = 0.2


class PolygonWall(StrictModel):
    """A convex polygonal obstacle with vertices ``points`` (m), either orientation."""

    type: Literal["polygon"]
    points: list[Vec2] = Field(min_length=3)

    @field_validator("points")
    @classmethod
    def _convex(cls, pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
        p = np.asarray(pts, float)
        e = np.roll(p, -1, axis=0) - p
        cross = e[:, 0] * np.roll(e, -1, axis=0)[:, 1] - e[:, 1] * np.roll(e, -1, axis=0)[:, 0]
        if not (np.all(cross > 0) or np.all(cross < 0)):
            raise ValueError("expected a convex polygon (no repeated or collinear vertices)")
        return pts


Wall = Annotated[SegmentWall | PolygonWall, Field(discriminator="type")]


class RobotTemplate(StrictModel):
    """Settings shared by the robots of a layout (units as in :class:`RobotSpec`)."""

    radius: Pos = 0.3
    mass: Pos = 1.0
    a_max: Pos = 2.0
    v_max: Pos = 1.5
    agent: str = "nao"
    predictor: str = "turn_rate"
    agent_options: dict[str, Scalar] = Field(default_factory=dict)
    agent_options_for: str | None = None
    """The agent the ``agent_options`` are meant for (None: any agent that takes them):
    when the robot runs another agent (``--agent``), that agent gets none of them."""
    kind: Literal["robot", "person"] = "robot"
    """``"robot"``: a robot under test (its statistics are reported, ``--agent`` replaces
    its agent, the env may control it); ``"person"``: a simulated pedestrian driven by its
    own agent (e.g. ``social_force``, ``orca``), reported apart, whose agent ``--agent``
    and the env leave alone, and which the robots' agents count as a body that does not
    cooperate (as traffic). People come after the robots in body order."""


class RobotSpec(RobotTemplate):
    """One robot: start, goal/route and velocity in m and m/s; limits in m/s^2 and m/s."""

    name: str | None = None
    start: Vec2
    goal: Vec2 | None = None
    route: list[Vec2] | None = Field(default=None, min_length=1)
    velocity: Vec2 = (0.0, 0.0)

    @model_validator(mode="before")
    @classmethod
    def _goal_from_route(cls, data: Any) -> Any:
        if isinstance(data, dict) and data.get("goal") is None and data.get("route"):
            route = data["route"]
            if isinstance(route, list) and route:
                data = {**data, "goal": route[-1]}
        return data

    @field_validator("velocity")
    @classmethod
    def _slow_enough(cls, v: tuple[float, float], info: ValidationInfo) -> tuple[float, float]:
        v_max = info.data.get("v_max")
        speed = math.hypot(*v)
        if v_max is not None and speed > v_max * (1 + 1e-9):
            raise ValueError(f"expected |velocity| <= v_max ({v_max:g}), got {speed:g}")
        return v

    @model_validator(mode="after")
    def _has_goal(self) -> RobotSpec:
        if self.goal is None:
            raise ValueError("expected a goal or a route")
        return self


class CircleLaneSpec(StrictModel):
    """A circular lane: centre (m), radius (m), driving direction, angle of s = 0 (rad)."""

    type: Literal["circle"]
    center: Vec2 = (0.0, 0.0)
    radius: Pos
    direction: Literal["ccw", "cw"] = "ccw"
    start_angle: Num = 0.0

    def geometry(self) -> CircleLane:
        """The lane as a :class:`nao_arena.traffic.CircleLane`."""
        return CircleLane(self.center, self.radius, self.direction, self.start_angle)


class PolylineLaneSpec(StrictModel):
    """A polyline lane through ``points`` (m), driven from the first point; open or closed."""

    type: Literal["polyline"]
    points: list[Vec2] = Field(min_length=2)
    closed: bool = False

    @field_validator("points")
    @classmethod
    def _distinct(cls, pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
        p = np.asarray(pts, float)
        if np.any(np.all(np.diff(p, axis=0) == 0.0, axis=1)):
            raise ValueError("expected no repeated consecutive points")
        return pts

    def geometry(self) -> PolylineLane:
        """The lane as a :class:`nao_arena.traffic.PolylineLane`."""
        return PolylineLane(np.asarray(self.points, float), self.closed)


LaneSpec = Annotated[CircleLaneSpec | PolylineLaneSpec, Field(discriminator="type")]


class TrafficGroup(StrictModel):
    """Scripted vehicles on one lane (fields: see :mod:`nao_arena.maps`)."""

    name: str | None = None
    lane: LaneSpec
    speed: Pos
    count: BodyCount = 1
    spacing: Pos | None = Field(default=None, validate_default=True)
    offset: Num = 0.0
    phase_jitter: NonNeg = 0.0
    radius: Pos = 1.0
    mass: Pos = 1000.0
    a_max: Pos = 3.0
    v_max: Pos | None = Field(default=None, validate_default=True)
    time_headway: Pos = 1.0
    min_gap: NonNeg = 2.0

    @field_validator("spacing")
    @classmethod
    def _default_spacing(cls, spacing: float | None, info: ValidationInfo) -> float | None:
        lane, count = info.data.get("lane"), info.data.get("count")
        if spacing is not None or lane is None or count is None:
            return spacing
        if lane.geometry().closed:
            return lane.geometry().length / count
        if count > 1:
            raise ValueError("expected a positive number on an open lane with count > 1")
        return 1.0

    @field_validator("v_max")
    @classmethod
    def _above_speed(cls, v_max: float | None, info: ValidationInfo) -> float | None:
        speed = info.data.get("speed")
        if speed is None:
            return v_max
        if v_max is None:
            return 1.5 * speed
        if v_max <= speed:
            raise ValueError(f"expected a number greater than speed ({speed:g}), got {v_max:g}")
        return v_max

    def lane_geometry(self) -> CircleLane | PolylineLane:
        """The lane centreline (see :mod:`nao_arena.traffic`)."""
        return self.lane.geometry()

    def arc_positions(self) -> NDArray[np.float64]:
        """Arc lengths (count,) m of the vehicles: offset + k spacing."""
        assert self.spacing is not None
        # float64 at run time (numpy's stubs say floating[Any])
        return cast("NDArray[np.float64]", self.offset + self.spacing * np.arange(self.count))

    def follower_params(self) -> FollowerParams:
        """The lane followers' settings."""
        return FollowerParams(
            speed=self.speed,
            a_max=self.a_max,
            time_headway=self.time_headway,
            min_gap=self.min_gap,
        )


MAX_START_CLEARANCE_FOR = 60.0
"""Longest ``start_clearance_for`` (s): each draw of a start time checks every control
step of it."""


class RecordedPeople(StrictModel):
    """People replayed from a recording (``traffic[]`` with ``type: recorded``; see
    :mod:`nao_arena.pedestrians`): ``file`` (relative to the map file), its ``format``,
    the ``fps`` of its frame numbers, ``time_offset`` (s, the recording's time at which
    the episode starts), ``time_jitter`` (s: the offset is moved by a uniform draw in
    [0, time_jitter) from the map's seeded generator), the people's ``radius`` (m),
    ``name`` (prefix of their names). With a time_jitter, the draw is made again while
    one of the people in the scene at the episode's start is within ``start_clearance``
    (m, surface to surface; 0: overlapping) of a robot's start: no robot starts on, or
    that close to, a recorded person; with ``start_clearance_for`` (s, default 0: the
    start only), nor has one come that close to a robot standing at its start within
    that time (someone about to walk into a robot that has had no time to react)."""

    type: Literal["recorded"]
    file: str
    format: Literal["obsmat", "xy"] = "obsmat"
    fps: Pos = 15.0
    time_offset: NonNeg = 0.0
    time_jitter: NonNeg = 0.0
    start_clearance: NonNeg = 0.0
    start_clearance_for: Annotated[NonNeg, Field(le=MAX_START_CLEARANCE_FOR)] = 0.0
    radius: Pos = 0.3
    name: str | None = None


class ReplayedPeople(RecordedPeople):
    """A :class:`RecordedPeople` entry as loaded: ``file`` resolved (an absolute path),
    ``people`` the recording's indices of the people replayed (those present for at least
    one control period of the episode), ``entry`` the entry's index in ``traffic``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    people: list[int] = Field(default_factory=list)
    entry: int = 0

    def recording(self) -> Any:
        """The recording (:class:`nao_arena.pedestrians.Recording`, read once per process
        and file version)."""
        from nao_arena.pedestrians import cached_recording

        return cached_recording(self.file, self.format, self.fps, self.time_offset)


def _traffic_kind(value: Any) -> str:
    """Which model a ``traffic`` entry is: ``recorded`` people, or a lane group."""
    kind = value.get("type") if isinstance(value, dict) else getattr(value, "type", None)
    return "recorded" if kind == "recorded" else "lane_group"


TrafficEntry = Annotated[
    Annotated[TrafficGroup, Tag("lane_group")] | Annotated[RecordedPeople, Tag("recorded")],
    Discriminator(_traffic_kind),
]


class Physics(StrictModel):
    """Control period dt (s), physics substeps per period, contact material, solver."""

    dt: Annotated[Num, Field(ge=MIN_DT, le=MAX_DT)] = 0.1
    substeps: Annotated[PosInt, Field(le=MAX_SUBSTEPS)] = 10
    elasticity: Annotated[Num, Field(ge=0, le=1)] = 0.2
    friction: NonNeg = 0.0
    collision_slop: NonNeg = 0.005
    iterations: Annotated[PosInt, Field(le=MAX_ITERATIONS)] = 10


class Episode(StrictModel):
    """Time limit (s) and goal tolerance (m)."""

    time_limit: Annotated[Pos, Field(le=MAX_TIME_LIMIT)] = 60.0
    goal_tolerance: Pos = 0.3


class SensingNoise(StrictModel):
    """Standard deviations of the Gaussian noise on what a robot senses of each neighbour
    (world frame, per component): ``position`` (m), ``velocity`` (m/s), ``acceleration``
    (m/s^2). 0: none."""

    position: NonNeg = 0.0
    velocity: NonNeg = 0.0
    acceleration: NonNeg = 0.0


class Sensing(StrictModel):
    """What robots sense: neighbours within ``range`` (m), at most ``max_neighbours``;
    ``latency`` (s): how old what the robots' agents sense is (their own state, their
    neighbours', plans and paths: the sensing of that many seconds ago, in whole control
    periods, ``round(latency / physics.dt)``; at the start of an episode, the first
    state); ``noise`` (:class:`SensingNoise`): Gaussian noise on each neighbour's sensed
    position, velocity and acceleration, drawn per observer, neighbour and step (a
    robot's own state stays exact); ``dropout`` (probability in [0, 1]): each neighbour
    of each robot is missed in a step with that probability, independently;
    ``field_of_view`` (rad, in (0, 2 pi]; 2 pi: all around): a robot senses only the
    bodies whose centre lies within half that angle of its heading (the direction of
    its velocity; standing still, the direction to its goal); ``occlusion`` (true: a robot
    senses only the bodies it can see past the bodies and walls in front of them, see
    :mod:`nao_arena.occlusion`). The statistics keep using the truth. 0 (2 pi for the
    field of view, false for occlusion): none."""

    range: Pos = 30.0
    max_neighbours: BodyCount | None = None
    latency: Annotated[NonNeg, Field(le=MAX_LATENCY)] = 0.0
    noise: SensingNoise = SensingNoise()
    dropout: Annotated[NonNeg, Field(le=1)] = 0.0
    field_of_view: Annotated[Num, Field(gt=0, le=math.tau)] = math.tau
    occlusion: bool = False


class Actuation(StrictModel):
    """How a robot's command reaches its motors: ``noise`` (m/s^2), the standard deviation
    of Gaussian noise added to each component of each robot's commanded acceleration every
    control period, drawn from the episode's generator (same seed, same noise); ``lag``
    (s): the time constant of a first-order response of the applied acceleration to the
    (noisy) command, a += (1 - exp(-dt / lag)) (command - a) each control period dt
    (a = 0 at the start); both before the world's limits. 0: none."""

    noise: Annotated[NonNeg, Field(le=MAX_MAGNITUDE)] = 0.0
    lag: NonNeg = 0.0


def _unlimited_as_none(value: Any) -> Any:
    """``.inf`` (or ``inf``) means no limit: stored as None (JSON has no infinity)."""
    if isinstance(value, float) and value == math.inf:
        return None
    if isinstance(value, str) and value.strip().lower() in ("inf", ".inf", "infinity"):
        return None
    return value


class CommunicationSpec(StrictModel):
    """What cooperative robots share and how (see :mod:`nao_arena.communication`):
    ``range`` (m, >= 0; null or .inf, the default: no limit): robots farther apart hear
    nothing of each other; ``latency`` (s): a message arrives that long after it is
    sent (whole control periods); ``loss`` (probability in [0, 1]): each pair's
    exchange of a control period is lost with that probability. ``off`` (or false):
    nothing is shared (range 0); ``on`` (or true): the default, perfect communication."""

    range: Annotated[NonNeg | None, BeforeValidator(_unlimited_as_none)] = None
    latency: Annotated[NonNeg, Field(le=MAX_LATENCY)] = 0.0
    loss: Annotated[NonNeg, Field(le=1)] = 0.0

    @model_validator(mode="before")
    @classmethod
    def _on_or_off(cls, data: Any) -> Any:
        if data is False or data == "off":
            return {"range": 0.0}
        if data is True or data == "on":
            return {}
        return data

    @property
    def reach(self) -> float:
        """The range in m (inf: no limit)."""
        return math.inf if self.range is None else float(self.range)


class LayoutSpec(StrictModel):
    """Robots generated by a registered builder (see :mod:`nao_arena.maps`)."""

    builder: str
    args: dict[str, Any] = Field(default_factory=dict)
    robot: RobotTemplate = RobotTemplate()
    name: str | None = None


class MapFile(StrictModel):
    """A map file as written (parameters substituted, layouts not yet expanded)."""

    name: str | None = None
    description: str = ""
    parameters: dict[str, Scalar] = Field(default_factory=dict)
    bounds: Bounds
    walls: list[Wall] = Field(default_factory=list)
    robots: list[RobotSpec] = Field(default_factory=list)
    layouts: list[LayoutSpec] = Field(default_factory=list)
    traffic: list[TrafficEntry] = Field(default_factory=list)
    physics: Physics = Physics()
    episode: Episode = Episode()
    sensing: Sensing = Sensing()
    actuation: Actuation = Actuation()
    communication: CommunicationSpec = CommunicationSpec()


@dataclass(frozen=True)
class BodySpec:
    """One body of the world, in world order.

    kind: "robot", "person" or "traffic"; start (m) and velocity (m/s) at t = 0;
    radius (m), mass (kg), a_max (m/s^2), v_max (m/s); robot: index into
    ``MapSpec.robots`` of the robot or person (the bodies driven by agents; -1 for
    traffic); group: traffic group index (-1 for robots and people).
    """

    index: int
    name: str
    kind: Literal["robot", "person", "traffic"]
    start: tuple[float, float]
    velocity: tuple[float, float]
    radius: float
    mass: float
    a_max: float
    v_max: float
    robot: int = -1
    group: int = -1
    replayed: bool = False


REPLAY_LIMIT = 1e6
"""The a_max (m/s^2) and v_max (m/s) of a recorded person: none (the recording moves it)."""

PARKING_OFFSET = 1000.0
"""How far (m) below and left of the bounds' minimum corner a recorded person waits while
absent from the scene (see :meth:`MapSpec.bodies`)."""


class MapSpec(StrictModel):
    """A loaded, validated map with concrete robots (layouts already expanded).

    ``parameters`` holds the values in effect (defaults merged with overrides).
    """

    name: str
    description: str = ""
    source: str = "<dict>"
    parameters: dict[str, Scalar] = Field(default_factory=dict)
    bounds: Bounds
    walls: list[Wall] = Field(default_factory=list)
    robots: list[RobotSpec] = Field(default_factory=list)
    traffic: list[TrafficGroup] = Field(default_factory=list)
    recorded: list[ReplayedPeople] = Field(default_factory=list)
    physics: Physics = Physics()
    episode: Episode = Episode()
    sensing: Sensing = Sensing()
    actuation: Actuation = Actuation()
    communication: CommunicationSpec = CommunicationSpec()

    def parking(self, k: int) -> tuple[float, float]:
        """Where recorded person k (in body order among the recorded) waits while absent:
        :data:`PARKING_OFFSET` m below and left of the bounds, 1 m apart (out of every
        robot's sensing range; recorded people touch nothing there)."""
        x0, y0 = self.bounds.min
        return (x0 - PARKING_OFFSET - 1.0 * k, y0 - PARKING_OFFSET)

    def replay_states(
        self, step: int
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
        """The recorded people (body order) for control period ``step``, [t0, t1] with
        t0 = step dt and t1 = (step + 1) dt: centres (m) at t0, velocities (m/s: the chord
        to their centres at t1, so that the replay meets the recording at every control
        step) and whether each is in the scene (annotated through the whole period);
        absent people wait at :meth:`parking`, standing still."""
        dt = float(self.physics.dt)
        pos, vel, present = [], [], []
        k = 0
        for group in self.recorded:
            rec = group.recording()
            at_start, _ = rec.states(step * dt)
            at_end, _ = rec.states((step + 1) * dt)
            for person in group.people:
                a, b = at_start[person], at_end[person]
                here = bool(np.all(np.isfinite(a)) and np.all(np.isfinite(b)))
                pos.append(a if here else np.array(self.parking(k)))
                vel.append((b - a) / dt if here else np.zeros(2))
                present.append(here)
                k += 1
        return (
            np.array(pos, dtype=float).reshape(-1, 2),
            np.array(vel, dtype=float).reshape(-1, 2),
            np.array(present, dtype=bool),
        )

    def recorded_paths(self, step: int, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """(R, T, 2) m: the recorded people's true future centres (body order) at
        ``times`` (s) after the start of control period ``step``, NaN rows for those not in
        the scene (see :func:`nao_arena.pedestrians.future_paths`)."""
        from nao_arena.pedestrians import future_paths

        t = step * float(self.physics.dt)
        parts = [future_paths(g.recording(), g.people, t, times) for g in self.recorded]
        return np.concatenate(parts) if parts else np.zeros((0, len(times), 2))

    def bodies(self) -> list[BodySpec]:
        """All bodies in world order: robots, people, traffic vehicles group by group, then
        the recorded people (``replayed``) entry by entry."""
        out: list[BodySpec] = []
        for i, r in enumerate(self.robots):
            out.append(
                BodySpec(
                    index=len(out),
                    name=r.name or f"robot{i}",
                    kind=r.kind,
                    start=r.start,
                    velocity=r.velocity,
                    radius=r.radius,
                    mass=r.mass,
                    a_max=r.a_max,
                    v_max=r.v_max,
                    robot=i,
                )
            )
        for g, grp in enumerate(self.traffic):
            lane = grp.lane_geometry()
            s = grp.arc_positions()
            pts = lane.point_at(s)
            vel = grp.speed * lane.tangent_at(s)
            assert grp.v_max is not None
            for k in range(grp.count):
                out.append(
                    BodySpec(
                        index=len(out),
                        name=f"{grp.name or f'traffic{g}'}_{k}",
                        kind="traffic",
                        start=(float(pts[k, 0]), float(pts[k, 1])),
                        velocity=(float(vel[k, 0]), float(vel[k, 1])),
                        radius=grp.radius,
                        mass=grp.mass,
                        a_max=grp.a_max,
                        v_max=grp.v_max,
                        group=g,
                    )
                )
        if self.recorded:
            pos, vel, _ = self.replay_states(0)
            k = 0
            for group in self.recorded:
                ids = group.recording().ids
                for person in group.people:
                    out.append(
                        BodySpec(
                            index=len(out),
                            name=f"{group.name or 'person'}{int(ids[person])}",
                            kind="person",
                            start=(float(pos[k, 0]), float(pos[k, 1])),
                            velocity=(float(vel[k, 0]), float(vel[k, 1])),
                            radius=group.radius,
                            mass=1.0,
                            a_max=REPLAY_LIMIT,
                            v_max=REPLAY_LIMIT,
                            replayed=True,
                        )
                    )
                    k += 1
        return out

    @property
    def n_robots(self) -> int:
        """Number of robots of kind "robot" (they come first in body order)."""
        return sum(1 for r in self.robots if r.kind == "robot")

    @property
    def n_recorded(self) -> int:
        """Number of recorded people replayed (bodies after the traffic vehicles)."""
        return sum(len(g.people) for g in self.recorded)

    @property
    def n_people(self) -> int:
        """Number of simulated people driven by agents (kind "person", after the robots in
        body order); recorded people are :attr:`n_recorded`."""
        return len(self.robots) - self.n_robots

    def wall_segments(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """All walls as segments (W, 2, 2) m with half-thicknesses (W,) m.

        Segment walls, then polygon edges (half-thickness 0), then the bound
        walls if ``bounds.walls``.
        """
        segs: list[Any] = []
        rad: list[float] = []
        for w in self.walls:
            if isinstance(w, SegmentWall):
                segs.append([w.a, w.b])
                rad.append(w.thickness / 2)
            else:
                p = np.asarray(w.points, float)
                for k in range(len(p)):
                    segs.append([p[k], p[(k + 1) % len(p)]])
                    rad.append(0.0)
        for a, b in self.bound_wall_segments():
            segs.append([a, b])
            rad.append(self.bounds.wall_thickness / 2)
        return np.asarray(segs, float).reshape(-1, 2, 2), np.asarray(rad, float)

    def bound_wall_segments(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        """The four bound walls (end points in m) if ``bounds.walls``, else none."""
        if not self.bounds.walls:
            return []
        (x0, y0), (x1, y1) = self.bounds.min, self.bounds.max
        return [
            ((x0, y0), (x1, y0)),
            ((x1, y0), (x1, y1)),
            ((x1, y1), (x0, y1)),
            ((x0, y1), (x0, y0)),
        ]
