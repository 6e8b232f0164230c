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
    Field,
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
    "Sensing",
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


class Sensing(StrictModel):
    """What robots sense: neighbours within ``range`` (m), at most ``max_neighbours``;
    ``latency`` (s): how old what the robots' agents sense is (their own state, their
    neighbours', plans and paths: the sensing of that many seconds ago, in whole control
    periods, ``round(latency / physics.dt)``; at the start of an episode, the first
    state). The statistics keep using the truth. 0: none."""

    range: Pos = 30.0
    max_neighbours: BodyCount | None = None
    latency: Annotated[NonNeg, Field(le=MAX_LATENCY)] = 0.0


class Actuation(StrictModel):
    """How a robot's command reaches its motors: ``noise`` (m/s^2), the standard deviation
    of Gaussian noise added to each component of each robot's commanded acceleration every
    control period, drawn from the episode's generator (same seed, same noise), before
    the world's limits. 0: none."""

    noise: Annotated[NonNeg, Field(le=MAX_MAGNITUDE)] = 0.0


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
    traffic: list[TrafficGroup] = Field(default_factory=list)
    physics: Physics = Physics()
    episode: Episode = Episode()
    sensing: Sensing = Sensing()
    actuation: Actuation = Actuation()


@dataclass(frozen=True)
class BodySpec:
    """One body of the world, in world order.

    kind: "robot" or "traffic"; start (m) and velocity (m/s) at t = 0;
    radius (m), mass (kg), a_max (m/s^2), v_max (m/s); robot: index into
    ``MapSpec.robots`` (-1 for traffic); group: traffic group index (-1 for
    robots).
    """

    index: int
    name: str
    kind: Literal["robot", "traffic"]
    start: tuple[float, float]
    velocity: tuple[float, float]
    radius: float
    mass: float
    a_max: float
    v_max: float
    robot: int = -1
    group: int = -1


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
    physics: Physics = Physics()
    episode: Episode = Episode()
    sensing: Sensing = Sensing()
    actuation: Actuation = Actuation()

    def bodies(self) -> list[BodySpec]:
        """All bodies in world order: robots, then traffic vehicles group by group."""
        out: list[BodySpec] = []
        for i, r in enumerate(self.robots):
            out.append(
                BodySpec(
                    index=len(out),
                    name=r.name or f"robot{i}",
                    kind="robot",
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
        return out

    @property
    def n_robots(self) -> int:
        """Number of robots (they come first in body order)."""
        return len(self.robots)

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
