"""Map files: schema, parameters, layout builders and the loader.

A map is one YAML file (shipped maps live in the package
``nao_arena.maps_data``, the repository's ``maps/`` folder). Units: metres,
seconds, m/s, m/s^2, kg, radians; all coordinates in the world frame.
Unknown keys are errors everywhere.

Numbers are finite (``.inf`` and ``.nan`` are errors); an integer is
accepted where a number is expected, but ``true``/``false`` never are.
Counts are integers >= 1. These checks apply after parameters are
substituted, so an override cannot get round them. Bounds that keep a
map from hanging or exhausting memory: at most :data:`MAX_BODIES` (10000)
bodies (robots and traffic vehicles) in a map, hence in one layout
(``n``) or lane (``count``); ``physics.substeps`` and
``physics.iterations`` at most :data:`MAX_SUBSTEPS` and
:data:`MAX_ITERATIONS` (1000 each); the ``crowd`` builder's ``max_tries``
at most :data:`MAX_TRIES` (1000000).

Top level
---------
``name`` (str, optional): the map's name (default: the file stem).
``description`` (str, optional).
``parameters`` (mapping name -> number, bool or string, optional): tunable
    values with their defaults. Anywhere else in the file, a value that is
    exactly the string ``"$name"`` is replaced by the parameter's value
    (whole values only; ``"$$x"`` stands for the literal string ``"$x"``).
    ``load_map(name, n=20)`` and the command line (``n=20``, see
    :func:`parse_overrides`) override declared parameters; the override is
    converted to the type of the default. The parameter ``seed`` (if
    declared) seeds the ``numpy.random.Generator`` given to layout builders.
``bounds``: ``min: [x, y]``, ``max: [x, y]`` (m), the arena's extent; robot
    starts, goals and route points must lie inside. ``walls: true`` closes
    the bounds with four segment walls of ``wall_thickness`` (m, default 0.2)
    centred on the boundary.
``walls`` (list, optional): static walls, each one of
    ``{type: segment, a: [x, y], b: [x, y], thickness: t}`` (a segment of
    thickness t m, default 0.2, i.e. a capsule of radius t/2), or
    ``{type: polygon, points: [[x, y], ...]}`` (a convex polygon, >= 3 points).
``robots`` (list, optional): robots placed by hand, each with
    ``start: [x, y]`` (m), ``goal: [x, y]`` (m) and/or ``route`` (list of
    waypoints [x, y] m; the goal defaults to the last one), ``velocity``
    (initial, m/s, default [0, 0]), ``radius`` (m, default 0.3), ``mass``
    (kg, default 1), ``a_max`` (m/s^2, default 2), ``v_max`` (m/s, default
    1.5), ``agent`` (default "nao": a built-in or plug-in agent name, checked
    when the map loads, or ``path/to/file.py:Class`` / ``module:Class``,
    checked when the agent is loaded), ``predictor`` (default "turn_rate",
    one of :data:`nao_arena.predictors.PREDICTORS`), ``agent_options``
    (keyword options of the agent's constructor, e.g. ``{horizon: 5.0}``),
    ``name`` (default "robot<i>").
``layouts`` (list, optional): generated robots, each
    ``{builder: <name>, args: {...}, robot: {...}, name: prefix}``, where
    ``builder`` names a registered layout builder (:data:`LAYOUTS`),
    ``args`` are its arguments (below) and ``robot`` holds the shared robot
    settings (radius, mass, a_max, v_max, agent, predictor). Builders:

    - ``circle_swap``: ``n`` robots (default 10) evenly on a circle of
      ``radius`` (m, default 8) around ``center`` (default [0, 0]), the first
      at ``angle`` (rad, default 0); each goes to the antipodal point;
      ``perturb`` (m, default 0) displaces each start uniformly within a disc
      of that radius (seeded).
    - ``crowd``: ``n`` robots (default 20) with random starts and goals drawn
      uniformly in the square ``region_min``..``region_max`` (default: the
      bounds inset by the robot radius + ``min_gap``), at least ``min_gap``
      (m, default 0.2) apart surface to surface, start and goal at least
      ``min_travel`` (m, default 0) apart; it gives up after ``max_tries``
      random draws for the starts, or for the goals (default 100000, at
      most 1000000).
    - ``stream``: ``n`` robots in a block ``width`` abreast (default 1),
      ``spacing`` (m) between centres, the block's front centre at
      ``origin``, heading along ``direction`` ([dx, dy], normalized); each
      goal is its start moved ``distance`` (m) along ``direction``;
      ``perturb`` (m, default 0) displaces each start (and its goal)
      uniformly within a disc of that radius (seeded).
``traffic`` (list, optional): scripted vehicles, one group per lane:
    ``lane``: ``{type: circle, center: [x, y], radius: R, direction: ccw|cw,
    start_angle: rad}`` or ``{type: polyline, points: [[x, y], ...], closed:
    bool}``; ``speed`` (cruise, m/s); ``count`` (default 1); ``spacing`` (m of
    arc length between consecutive vehicles; default: the lane length /
    count on a closed lane, required on an open lane with count > 1);
    ``offset`` (m, arc length of vehicle 0, default 0; vehicle k is at
    offset + k spacing); ``phase_jitter`` (m, default 0: the whole group is
    shifted along its lane by a uniform draw in [0, phase_jitter) from the
    map's seeded Generator, after the layouts have drawn theirs); ``radius``
    (m, default 1), ``mass`` (kg, default 1000), ``a_max`` (m/s^2, default
    3), ``v_max`` (m/s, default 1.5 speed, must exceed speed), car
    following: ``time_headway`` (s, default 1), ``min_gap`` (m, default 2),
    ``name``.
``physics``: ``dt`` (control period, s, default 0.1), ``substeps`` (1..1000,
    default 10), ``elasticity`` (0..1, default 0.2), ``friction`` (>= 0,
    default 0), ``collision_slop`` (m of tolerated overlap, default 0.005),
    ``iterations`` (solver iterations per physics step, 1..1000, default 10).
``episode``: ``time_limit`` (s, > 0, default 60), ``goal_tolerance`` (m from
    the goal at which a robot has arrived, default 0.3).
``sensing``: ``range`` (m, default 30): robots sense the bodies within it;
    ``max_neighbours`` (default: no limit), the nearest first.

Body order (the world's, the stats', the agents'): hand-placed robots,
then layout robots (layout by layout), then traffic (group by group,
vehicle 0 first).

Errors are :class:`MapError` (a ``ValueError``) naming the file, the field
path and what was expected, e.g. ``maps/foo.yaml: robots[2].radius:
expected a positive number, got -1``.
"""

from __future__ import annotations

import json
import math
import re
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
import yaml
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticKnownError

from nao_arena.traffic import CircleLane, FollowerParams, PolylineLane

__all__ = [
    "LAYOUTS",
    "MAX_BODIES",
    "MAX_ITERATIONS",
    "MAX_SUBSTEPS",
    "MAX_TRIES",
    "BodySpec",
    "Bounds",
    "CircleLaneSpec",
    "Episode",
    "LayoutSpec",
    "MapError",
    "MapSpec",
    "Physics",
    "PolygonWall",
    "PolylineLaneSpec",
    "RobotSpec",
    "RobotTemplate",
    "SegmentWall",
    "Sensing",
    "TrafficGroup",
    "available_maps",
    "format_reference",
    "load_map",
    "map_from_dict",
    "parse_overrides",
    "register_layout",
]


class MapError(ValueError):
    """A map file that cannot be loaded: the message names file, field path and expectation."""


MAX_BODIES = 10_000
"""Most bodies (robots and traffic vehicles) in one map, and in one layout or lane."""
MAX_SUBSTEPS = 1000
"""Most physics substeps per control period (``physics.substeps``)."""
MAX_ITERATIONS = 1000
"""Most solver iterations per physics step (``physics.iterations``)."""
MAX_TRIES = 1_000_000
"""Most random draws of the ``crowd`` builder (``max_tries``)."""


def _no_bool_number(value: Any) -> Any:
    """A YAML ``true`` is not the number 1."""
    if isinstance(value, bool):
        raise PydanticKnownError("float_type")
    return value


def _no_bool_integer(value: Any) -> Any:
    if isinstance(value, bool):
        raise PydanticKnownError("int_type")
    return value


Num = Annotated[float, BeforeValidator(_no_bool_number), Field(allow_inf_nan=False)]
Pos = Annotated[Num, Field(gt=0)]
NonNeg = Annotated[Num, Field(ge=0)]
Vec2 = tuple[Num, Num]
PosInt = Annotated[int, BeforeValidator(_no_bool_integer), Field(gt=0)]
BodyCount = Annotated[PosInt, Field(le=MAX_BODIES)]
Scalar = bool | int | float | str


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Bounds(_Model):
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


class SegmentWall(_Model):
    """A straight wall from a to b (m) of ``thickness`` m (a capsule of radius thickness/2)."""

    type: Literal["segment"]
    a: Vec2
    b: Vec2
    thickness: Pos = 0.2


class PolygonWall(_Model):
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


class RobotTemplate(_Model):
    """Settings shared by the robots of a layout (units as in :class:`RobotSpec`)."""

    radius: Pos = 0.3
    mass: Pos = 1.0
    a_max: Pos = 2.0
    v_max: Pos = 1.5
    agent: str = "nao"
    predictor: str = "turn_rate"
    agent_options: dict[str, Scalar] = Field(default_factory=dict)


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


class CircleLaneSpec(_Model):
    """A circular lane: centre (m), radius (m), driving direction, angle of s = 0 (rad)."""

    type: Literal["circle"]
    center: Vec2 = (0.0, 0.0)
    radius: Pos
    direction: Literal["ccw", "cw"] = "ccw"
    start_angle: Num = 0.0

    def geometry(self) -> CircleLane:
        """The lane as a :class:`nao_arena.traffic.CircleLane`."""
        return CircleLane(self.center, self.radius, self.direction, self.start_angle)


class PolylineLaneSpec(_Model):
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


class TrafficGroup(_Model):
    """Scripted vehicles on one lane (see the module docstring for the fields)."""

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
        return self.offset + self.spacing * np.arange(self.count)

    def follower_params(self) -> FollowerParams:
        """The lane followers' settings."""
        return FollowerParams(
            speed=self.speed, a_max=self.a_max, time_headway=self.time_headway,
            min_gap=self.min_gap,
        )


class Physics(_Model):
    """Control period dt (s), physics substeps per period, contact material, solver."""

    dt: Pos = 0.1
    substeps: Annotated[PosInt, Field(le=MAX_SUBSTEPS)] = 10
    elasticity: Annotated[Num, Field(ge=0, le=1)] = 0.2
    friction: NonNeg = 0.0
    collision_slop: NonNeg = 0.005
    iterations: Annotated[PosInt, Field(le=MAX_ITERATIONS)] = 10


class Episode(_Model):
    """Time limit (s) and goal tolerance (m)."""

    time_limit: Pos = 60.0
    goal_tolerance: Pos = 0.3


class Sensing(_Model):
    """What robots sense: neighbours within ``range`` (m), at most ``max_neighbours``."""

    range: Pos = 30.0
    max_neighbours: PosInt | None = None


class LayoutSpec(_Model):
    """Robots generated by a registered builder (see the module docstring)."""

    builder: str
    args: dict[str, Any] = Field(default_factory=dict)
    robot: RobotTemplate = RobotTemplate()
    name: str | None = None


class _MapFile(_Model):
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


class MapSpec(_Model):
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

    def bodies(self) -> list[BodySpec]:
        """All bodies in world order: robots, then traffic vehicles group by group."""
        out: list[BodySpec] = []
        for i, r in enumerate(self.robots):
            out.append(
                BodySpec(
                    index=len(out), name=r.name or f"robot{i}", kind="robot", start=r.start,
                    velocity=r.velocity, radius=r.radius, mass=r.mass, a_max=r.a_max,
                    v_max=r.v_max, robot=i,
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
                        index=len(out), name=f"{grp.name or f'traffic{g}'}_{k}", kind="traffic",
                        start=(float(pts[k, 0]), float(pts[k, 1])),
                        velocity=(float(vel[k, 0]), float(vel[k, 1])), radius=grp.radius,
                        mass=grp.mass, a_max=grp.a_max, v_max=grp.v_max, group=g,
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
        return [((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)),
                ((x0, y1), (x0, y0))]


# --------------------------------------------------------------------------- layouts

Placement = list[tuple[tuple[float, float], tuple[float, float]]]


@dataclass(frozen=True)
class LayoutContext:
    """What a builder may use: the bounds, the robots' radius (m) and a seeded Generator."""

    bounds: Bounds
    radius: float
    rng: np.random.Generator


LayoutBuilder = Callable[[Any, LayoutContext], Placement]
LAYOUTS: dict[str, tuple[type[BaseModel], LayoutBuilder]] = {}


def register_layout(
    name: str, args_model: type[BaseModel]
) -> Callable[[LayoutBuilder], LayoutBuilder]:
    """Register a builder: ``fn(args, ctx) -> [(start, goal), ...]`` with validated args."""

    def deco(fn: LayoutBuilder) -> LayoutBuilder:
        LAYOUTS[name] = (args_model, fn)
        return fn

    return deco


def _pt(p: NDArray[np.float64]) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


class CircleSwapArgs(_Model):
    """Arguments of the ``circle_swap`` builder."""

    n: BodyCount = 10
    radius: Pos = 8.0
    center: Vec2 = (0.0, 0.0)
    angle: Num = 0.0
    perturb: NonNeg = 0.0


@register_layout("circle_swap", CircleSwapArgs)
def circle_swap(args: CircleSwapArgs, ctx: LayoutContext) -> Placement:
    """n robots evenly on a circle, each sent to the antipodal point."""
    th = args.angle + 2.0 * np.pi * np.arange(args.n) / args.n
    c = np.asarray(args.center, float)
    ring = args.radius * np.stack([np.cos(th), np.sin(th)], axis=1)
    starts = c + ring
    goals = c - ring
    if args.perturb > 0:
        rho = args.perturb * np.sqrt(ctx.rng.random(args.n))
        phi = 2.0 * np.pi * ctx.rng.random(args.n)
        starts = starts + rho[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    return [(_pt(s), _pt(g)) for s, g in zip(starts, goals, strict=True)]


class CrowdArgs(_Model):
    """Arguments of the ``crowd`` builder."""

    n: BodyCount = 20
    region_min: Vec2 | None = None
    region_max: Vec2 | None = None
    min_gap: NonNeg = 0.2
    min_travel: NonNeg = 0.0
    max_tries: Annotated[PosInt, Field(le=MAX_TRIES)] = 100_000


def _scatter(
    rng: np.random.Generator, n: int, lo: NDArray[np.float64], hi: NDArray[np.float64],
    min_dist: float, max_tries: int, avoid: NDArray[np.float64] | None = None,
    avoid_dist: float = 0.0,
) -> NDArray[np.float64]:
    """n points uniform in [lo, hi] at least min_dist apart (and avoid_dist from avoid[k])."""
    pts = np.empty((n, 2))
    k = tries = 0
    while k < n:
        if tries >= max_tries:
            raise ValueError(
                f"cannot place {n} robots within {max_tries} tries; "
                "expected a larger region, fewer robots or a smaller min_gap"
            )
        tries += 1
        p = lo + (hi - lo) * rng.random(2)
        if k and np.min(np.sum((pts[:k] - p) ** 2, axis=1)) < min_dist**2:
            continue
        if avoid is not None and np.sum((avoid[k] - p) ** 2) < avoid_dist**2:
            continue
        pts[k] = p
        k += 1
    return pts


@register_layout("crowd", CrowdArgs)
def crowd(args: CrowdArgs, ctx: LayoutContext) -> Placement:
    """n robots with random, non-overlapping starts and goals in a square region."""
    inset = ctx.radius + args.min_gap
    lo = np.asarray(args.region_min if args.region_min else ctx.bounds.min, float)
    hi = np.asarray(args.region_max if args.region_max else ctx.bounds.max, float)
    if args.region_min is None:
        lo = lo + inset
    if args.region_max is None:
        hi = hi - inset
    if np.any(hi <= lo):
        raise ValueError(f"expected a non-empty region, got {_pt(lo)}..{_pt(hi)}")
    d = 2 * ctx.radius + args.min_gap
    starts = _scatter(ctx.rng, args.n, lo, hi, d, args.max_tries)
    goals = _scatter(ctx.rng, args.n, lo, hi, d, args.max_tries, starts, args.min_travel)
    return [(_pt(s), _pt(g)) for s, g in zip(starts, goals, strict=True)]


class StreamArgs(_Model):
    """Arguments of the ``stream`` builder."""

    n: BodyCount
    origin: Vec2
    direction: Vec2
    distance: Pos
    spacing: Pos
    width: PosInt = 1
    perturb: NonNeg = 0.0

    @field_validator("direction")
    @classmethod
    def _nonzero(cls, d: tuple[float, float]) -> tuple[float, float]:
        if math.hypot(*d) == 0.0:
            raise ValueError("expected a non-zero direction")
        return d


@register_layout("stream", StreamArgs)
def stream(args: StreamArgs, ctx: LayoutContext) -> Placement:
    """A block of robots ``width`` abreast, all heading ``distance`` m along ``direction``."""
    d = np.asarray(args.direction, float)
    d = d / np.hypot(*d)
    nrm = np.array([-d[1], d[0]])
    k = np.arange(args.n)
    row, col = k // args.width, k % args.width
    starts = (
        np.asarray(args.origin, float)
        - (row * args.spacing)[:, None] * d
        + ((col - (args.width - 1) / 2) * args.spacing)[:, None] * nrm
    )
    if args.perturb > 0:
        rho = args.perturb * np.sqrt(ctx.rng.random(args.n))
        phi = 2.0 * np.pi * ctx.rng.random(args.n)
        starts = starts + rho[:, None] * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    goals = starts + args.distance * d
    return [(_pt(s), _pt(g)) for s, g in zip(starts, goals, strict=True)]


# --------------------------------------------------------------------------- errors

_TAGS = frozenset({"segment", "polygon", "circle", "polyline"})


def _render_path(loc: Sequence[Any], data: Any) -> str:
    """``robots[2].radius`` from a pydantic loc, dropping union tags, following the data."""
    out = ""
    node = data
    for el in loc:
        if isinstance(el, int):
            out += f"[{el}]"
            node = node[el] if isinstance(node, list) and -len(node) <= el < len(node) else None
        elif isinstance(node, dict) and el in node:
            out += f".{el}"
            node = node[el]
        elif isinstance(node, dict) and el in _TAGS and node.get("type") == el:
            continue
        else:
            out += f".{el}"
            node = None
    return out.lstrip(".") or "(top level)"


def _show(x: Any) -> str:
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, int | float):
        return f"{x:g}" if isinstance(x, float) else str(x)
    text = repr(x)
    return text if len(text) <= 60 else text[:57] + "..."


def _allowed_keys(model: Any, loc: Sequence[Any]) -> list[str] | None:
    """Field names of the model reached by loc (None if it cannot be resolved)."""
    tp: Any = model
    for el in loc:
        tp = _strip(tp)
        if isinstance(tp, type) and issubclass(tp, BaseModel):
            if el not in tp.model_fields:
                return None
            tp = tp.model_fields[el].annotation
            continue
        origin, targs = typing.get_origin(tp), typing.get_args(tp)
        if origin in (list, tuple) and isinstance(el, int):
            tp = targs[0]
        elif origin is dict:
            tp = targs[1]
        elif origin in (Union, types.UnionType):
            match = [
                t for t in targs
                if isinstance(t, type) and issubclass(t, BaseModel)
                and "type" in t.model_fields
                and typing.get_args(t.model_fields["type"].annotation) == (el,)
            ]
            if not match:
                return None
            tp = match[0]
        else:
            return None
    tp = _strip(tp)
    if isinstance(tp, type) and issubclass(tp, BaseModel):
        return list(tp.model_fields)
    return None


def _strip(tp: Any) -> Any:
    while typing.get_origin(tp) is Annotated:
        tp = typing.get_args(tp)[0]
    if typing.get_origin(tp) in (Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return _strip(args[0])
    return tp


def _expectation(err: Mapping[str, Any], model: Any) -> str:
    kind = err["type"]
    ctx = err.get("ctx") or {}
    got = f", got {_show(err.get('input'))}"
    if kind == "missing":
        return "required field missing"
    if kind == "extra_forbidden":
        allowed = _allowed_keys(model, err["loc"][:-1])
        hint = f"; expected one of: {', '.join(allowed)}" if allowed else ""
        return f"unknown key{hint}"
    if kind == "greater_than":
        return ("expected a positive number" if ctx.get("gt") == 0
                else f"expected a number greater than {ctx.get('gt')}") + got
    if kind == "greater_than_equal":
        return ("expected a non-negative number" if ctx.get("ge") == 0
                else f"expected a number >= {ctx.get('ge')}") + got
    if kind in ("less_than_equal", "less_than"):
        return f"expected a number <= {ctx.get('le', ctx.get('lt'))}" + got
    if kind in ("float_type", "float_parsing"):
        return "expected a number" + got
    if kind == "finite_number":
        return "expected a finite number" + got
    if kind in ("int_type", "int_parsing", "int_from_float"):
        return "expected an integer" + got
    if kind in ("bool_type", "bool_parsing"):
        return "expected true or false" + got
    if kind == "string_type":
        return "expected a string" + got
    if kind == "literal_error":
        return f"expected {ctx.get('expected')}" + got
    if kind in ("list_type", "tuple_type"):
        return "expected a list" + got
    if kind == "too_short":
        return f"expected at least {ctx.get('min_length')} items" + got
    if kind == "too_long":
        return f"expected at most {ctx.get('max_length')} items" + got
    if kind in ("model_type", "dict_type", "model_attributes_type"):
        return "expected a mapping" + got
    if kind == "union_tag_invalid":
        return f"expected type to be one of {ctx.get('expected_tags')}, got {ctx.get('tag')!r}"
    if kind == "union_tag_not_found":
        return f"expected a 'type' key ({ctx.get('expected_tags', 'see the map format')})"
    if kind in ("value_error", "assertion_error"):
        return str(err["msg"]).removeprefix("Value error, ").removeprefix("Assertion failed, ")
    return str(err["msg"]) + got


def _wrap(file: str, exc: ValidationError, data: Any, model: Any, prefix: str = "") -> MapError:
    lines = []
    for err in exc.errors(include_url=False):
        loc = err["loc"]
        if err["type"] == "missing" and loc and isinstance(loc[-1], int):
            # a point given with too few coordinates: name the point, not the coordinate
            err = {**err, "type": "too_short", "ctx": {"min_length": loc[-1] + 1}}
            loc = loc[:-1]
        path = _render_path(loc, data)
        full = path if not prefix else (prefix if path == "(top level)" else f"{prefix}.{path}")
        lines.append(f"{file}: {full}: {_expectation(err, model)}")
    return MapError("\n".join(lines))


def _fail(file: str, path: str, what: str) -> MapError:
    return MapError(f"{file}: {path}: {what}")


# --------------------------------------------------------------------------- parameters


def parse_overrides(items: Sequence[str]) -> dict[str, Any]:
    """``["n=20", "seed=3"]`` -> ``{"n": 20, "seed": 3}`` (values parsed as YAML scalars)."""
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise MapError(f"parameter override {item!r}: expected name=value")
        try:
            out[key.strip()] = yaml.safe_load(value) if value.strip() else ""
        except yaml.YAMLError:
            out[key.strip()] = value
    return out


def _coerce(file: str, name: str, default: Any, value: Any) -> Any:
    if isinstance(value, str) and not isinstance(default, str):
        try:
            value = yaml.safe_load(value)
        except yaml.YAMLError:
            pass
    path = f"parameters.{name}"
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise _fail(file, path, f"expected true or false, got {_show(value)}")
        return value
    if isinstance(default, int):
        if isinstance(value, bool) or not (
            isinstance(value, int) or (isinstance(value, float) and value.is_integer())
        ):
            raise _fail(file, path, f"expected an integer, got {_show(value)}")
        return int(value)
    if isinstance(default, float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise _fail(file, path, f"expected a number, got {_show(value)}")
        return float(value)
    return str(value)


def _substitute(file: str, node: Any, params: Mapping[str, Any], path: str) -> Any:
    if isinstance(node, dict):
        return {k: _substitute(file, v, params, f"{path}.{k}".lstrip(".")) for k, v in node.items()}
    if isinstance(node, list):
        return [_substitute(file, v, params, f"{path}[{i}]") for i, v in enumerate(node)]
    if isinstance(node, str) and node.startswith("$"):
        if node.startswith("$$"):
            return node[1:]
        name = node[1:]
        if name not in params:
            declared = ", ".join(params) or "none"
            raise _fail(file, path, f"unknown parameter {node!r} (declared: {declared})")
        return params[name]
    return node


def _parameters(file: str, raw: Any, overrides: Mapping[str, Any]) -> dict[str, Any]:
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        raise _fail(file, "parameters", f"expected a mapping, got {_show(raw)}")
    params: dict[str, Any] = {}
    for k, v in raw.items():
        if not isinstance(k, str) or not k.isidentifier():
            raise _fail(file, f"parameters.{k}", "expected an identifier as parameter name")
        if not isinstance(v, bool | int | float | str):
            raise _fail(
                file, f"parameters.{k}", f"expected a number, bool or string, got {_show(v)}"
            )
        params[k] = v
    for k, v in overrides.items():
        if k not in params:
            declared = ", ".join(params) or "none"
            raise _fail(file, f"parameters.{k}", f"unknown parameter (declared: {declared})")
        params[k] = _coerce(file, k, params[k], v)
    return params


# --------------------------------------------------------------------------- checks


def _point_segment_distance(
    p: NDArray[np.float64], segs: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Distances (n, W) m from points (n, 2) to segments (W, 2, 2)."""
    a, b = segs[:, 0], segs[:, 1]
    ab = b - a
    ll = np.maximum(np.sum(ab * ab, axis=1), 1e-300)
    rel = p[:, None, :] - a[None]
    t = np.clip(np.sum(rel * ab[None], axis=2) / ll, 0.0, 1.0)
    d = rel - t[..., None] * ab[None]
    return np.hypot(d[..., 0], d[..., 1])


def _inside_convex(p: NDArray[np.float64], poly: NDArray[np.float64]) -> NDArray[np.bool_]:
    e = np.roll(poly, -1, axis=0) - poly
    rel = p[:, None, :] - poly[None]
    cross = e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0]
    return np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)


def _wall_clearance(spec: MapSpec, points: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """Per wall (as listed, then bound walls): surface distance (n,) m from points to it."""
    out = []
    for w in spec.walls:
        if isinstance(w, SegmentWall):
            d = _point_segment_distance(points, np.array([[w.a, w.b]], float))[:, 0]
            out.append(d - w.thickness / 2)
        else:
            poly = np.asarray(w.points, float)
            edges = np.stack([poly, np.roll(poly, -1, axis=0)], axis=1)
            d = np.min(_point_segment_distance(points, edges), axis=1)
            out.append(np.where(_inside_convex(points, poly), -d, d))
    for a, b in spec.bound_wall_segments():
        d = _point_segment_distance(points, np.array([[a, b]], float))[:, 0]
        out.append(d - spec.bounds.wall_thickness / 2)
    return out


def _wall_name(spec: MapSpec, k: int) -> str:
    return f"walls[{k}]" if k < len(spec.walls) else f"bounds.walls (edge {k - len(spec.walls)})"


def _check_geometry(file: str, spec: MapSpec, origins: Sequence[str]) -> None:
    """Starts, goals and routes inside the bounds and clear of walls; no overlapping bodies."""
    bounds_text = f"inside the bounds {spec.bounds.min}..{spec.bounds.max}"
    for i, r in enumerate(spec.robots):
        where = origins[i]
        if not spec.bounds.contains(np.array(r.start))[0]:
            raise _fail(file, f"{where}.start", f"expected a point {bounds_text}, got {r.start}")
        if not spec.bounds.contains(np.array(r.goal))[0]:
            raise _fail(file, f"{where}.goal", f"expected a point {bounds_text}, got {r.goal}")
        for j, q in enumerate(r.route or []):
            if not spec.bounds.contains(np.array(q))[0]:
                raise _fail(file, f"{where}.route[{j}]", f"expected a point {bounds_text}, got {q}")
    bodies = spec.bodies()
    if not bodies:
        return
    starts = np.array([b.start for b in bodies], float)
    radii = np.array([b.radius for b in bodies])

    first = {}
    for b in bodies:
        first.setdefault(b.group, b.index)

    def name(k: int) -> str:
        b = bodies[k]
        if b.kind == "robot":
            return origins[b.robot]
        return f"traffic[{b.group}] (vehicle {k - first[b.group]})"

    for w, clear in enumerate(_wall_clearance(spec, starts)):
        bad = np.flatnonzero(clear < radii)
        if len(bad):
            k = int(bad[0])
            field = ".start" if bodies[k].kind == "robot" else ""
            raise _fail(
                file, name(k) + field,
                f"expected a start clear of the walls, but the body (radius {radii[k]:g}) "
                f"overlaps {_wall_name(spec, w)} (surface distance {clear[k]:.3g} m)",
            )
    goals = np.array([r.goal for r in spec.robots], float).reshape(-1, 2)
    rr = radii[: len(spec.robots)]
    for w, clear in enumerate(_wall_clearance(spec, goals)):
        bad = np.flatnonzero(clear < rr)
        if len(bad):
            k = int(bad[0])
            raise _fail(
                file, f"{origins[k]}.goal",
                f"expected a goal clear of the walls, but it overlaps {_wall_name(spec, w)}",
            )
    # pairwise start overlaps, one row at a time to bound memory
    for i in range(1, len(bodies)):
        d = np.hypot(*(starts[:i] - starts[i]).T)
        bad = np.flatnonzero(d < radii[:i] + radii[i])
        if len(bad):
            j = int(bad[0])
            same_lane = bodies[i].group >= 0 and bodies[i].group == bodies[j].group
            if same_lane:
                g = bodies[i].group
                where = f"traffic[{g}].spacing"
                what = f"vehicles {j - first[g]} and {i - first[g]} overlap"
            else:
                where = name(i) + (".start" if bodies[i].kind == "robot" else "")
                what = f"it overlaps {name(j)}"
            raise _fail(
                file, where,
                f"expected non-overlapping starts, but {what} "
                f"(distance {d[j]:.3g} m < {radii[i] + radii[j]:.3g} m)",
            )
    for g, grp in enumerate(spec.traffic):
        lane = grp.lane_geometry()
        s = grp.arc_positions()
        if not lane.closed and (np.min(s) < 0 or np.max(s) > lane.length):
            raise _fail(
                file, f"traffic[{g}].offset",
                f"expected all vehicles within the lane's length (0..{lane.length:.4g} m), "
                f"got arc lengths {np.min(s):.4g}..{np.max(s):.4g} m",
            )


# --------------------------------------------------------------------------- loading


def _shipped() -> Any:
    return resources.files("nao_arena.maps_data")


def available_maps() -> list[str]:
    """Names of the shipped maps, sorted."""
    return sorted(
        p.name.removesuffix(".yaml") for p in _shipped().iterdir() if p.name.endswith(".yaml")
    )


def _resolve(source: str | Path) -> tuple[str, str]:
    """(display name, text) of a map given by name or path."""
    text_source = str(source)
    path = Path(source)
    looks_like_path = isinstance(source, Path) or text_source.endswith((".yaml", ".yml")) or (
        "/" in text_source
    )
    if looks_like_path:
        if not path.is_file():
            raise MapError(f"{text_source}: no such map file")
        return text_source, path.read_text(encoding="utf-8")
    res = _shipped() / f"{text_source}.yaml"
    if not res.is_file():
        raise MapError(
            f"{text_source}: no such map; expected a file path or one of: "
            f"{', '.join(available_maps())}"
        )
    return f"maps/{text_source}.yaml", res.read_text(encoding="utf-8")


def load_map(
    source: str | Path, rng: np.random.Generator | None = None, **overrides: Any
) -> MapSpec:
    """Load and validate a map by shipped name (e.g. "roundabout") or file path.

    overrides: values for the map's declared ``parameters``. rng: the
    Generator given to layout builders (default: seeded with the map's
    ``seed`` parameter, or 0). Raises :class:`MapError`.
    """
    file, text = _resolve(source)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "(top level)"
        problem = getattr(exc, "problem", None) or str(exc)
        raise MapError(f"{file}: {where}: expected valid YAML ({problem})") from None
    default_name = Path(file).name.removesuffix(".yaml").removesuffix(".yml")
    return map_from_dict(data, file, rng=rng, default_name=default_name, **overrides)


def map_from_dict(
    data: Any,
    source: str = "<dict>",
    rng: np.random.Generator | None = None,
    default_name: str = "map",
    **overrides: Any,
) -> MapSpec:
    """Validate a map given as plain data (as parsed from YAML); see :func:`load_map`."""
    file = source
    if not isinstance(data, dict):
        raise _fail(file, "(top level)", f"expected a mapping, got {_show(data)}")
    params = _parameters(file, data.get("parameters"), overrides)
    body = {k: v for k, v in data.items() if k != "parameters"}
    body = _substitute(file, body, params, "")
    body["parameters"] = params
    try:
        mf = _MapFile.model_validate(body)
    except ValidationError as exc:
        raise _wrap(file, exc, body, _MapFile) from None
    _check_names(file, mf)
    if rng is None:
        seed = params.get("seed", 0)
        rng = np.random.default_rng(seed if isinstance(seed, int) and seed >= 0 else 0)
    robots = list(mf.robots)
    origins = [f"robots[{i}]" for i in range(len(robots))]
    _check_total(file, "robots", len(robots), "the robots placed by hand")
    for li, lay in enumerate(mf.layouts):
        robots_l, origins_l = _expand_layout(file, li, lay, mf.bounds, rng, body)
        robots.extend(robots_l)
        origins.extend(origins_l)
        _check_total(file, f"layouts[{li}]", len(robots), "this layout's robots")
    total = len(robots)
    for g, grp in enumerate(mf.traffic):
        total += grp.count
        _check_total(file, f"traffic[{g}].count", total, "this group's vehicles")
    named = [
        r if r.name else r.model_copy(update={"name": f"robot{i}"}) for i, r in enumerate(robots)
    ]
    traffic = [
        g.model_copy(update={"offset": g.offset + float(rng.uniform(0.0, g.phase_jitter))})
        if g.phase_jitter > 0 else g
        for g in mf.traffic
    ]
    spec = MapSpec(
        name=mf.name or default_name, description=mf.description, source=file,
        parameters=params, bounds=mf.bounds, walls=mf.walls, robots=named,
        traffic=traffic, physics=mf.physics, episode=mf.episode, sensing=mf.sensing,
    )
    _check_geometry(file, spec, origins)
    return spec


def _check_names(file: str, mf: _MapFile) -> None:
    """Every robot's and layout template's agent and predictor names a known one.

    Agents given as ``FILE.py:Class`` or ``module:Class`` are checked when loaded.
    """
    from nao_arena.agent import BUILTIN_AGENTS, available_agents
    from nao_arena.predictors import PREDICTORS

    templates: list[tuple[str, RobotTemplate]] = [
        (f"robots[{i}]", r) for i, r in enumerate(mf.robots)
    ] + [(f"layouts[{i}].robot", lay.robot) for i, lay in enumerate(mf.layouts)]
    agents: dict[str, str] | None = None
    for where, t in templates:
        if t.agent not in BUILTIN_AGENTS and ":" not in t.agent:
            agents = available_agents() if agents is None else agents
            if t.agent not in agents:
                raise _fail(
                    file, f"{where}.agent",
                    f"expected one of {', '.join(agents)}, a path/to/file.py:ClassName or a "
                    f"package.module:ClassName, got {t.agent!r}",
                )
        if t.predictor not in PREDICTORS:
            raise _fail(
                file, f"{where}.predictor",
                f"expected one of {', '.join(PREDICTORS)}, got {t.predictor!r}",
            )


def _check_total(file: str, path: str, total: int, these: str) -> None:
    """At most :data:`MAX_BODIES` bodies up to and including ``these`` (at path)."""
    if total > MAX_BODIES:
        raise _fail(
            file, path,
            f"expected at most {MAX_BODIES} bodies (robots and traffic vehicles) in a map, "
            f"got {total} with {these}",
        )


def _expand_layout(
    file: str, li: int, lay: LayoutSpec, bounds: Bounds, rng: np.random.Generator, body: Any
) -> tuple[list[RobotSpec], list[str]]:
    path = f"layouts[{li}]"
    if lay.builder not in LAYOUTS:
        raise _fail(
            file, f"{path}.builder",
            f"expected one of {', '.join(sorted(LAYOUTS))}, got {lay.builder!r}",
        )
    model, fn = LAYOUTS[lay.builder]
    try:
        args = model.model_validate(lay.args)
    except ValidationError as exc:
        raise _wrap(file, exc, lay.args, model, prefix=f"{path}.args") from None
    try:
        placed = fn(args, LayoutContext(bounds, lay.robot.radius, rng))
    except ValueError as exc:
        raise _fail(file, path, str(exc)) from None
    prefix = lay.name or lay.builder
    robots = []
    for k, (start, goal) in enumerate(placed):
        fields = {**lay.robot.model_dump(), "start": start, "goal": goal, "name": f"{prefix}{k}"}
        try:
            robots.append(RobotSpec.model_validate(fields))
        except ValidationError as exc:
            raise _wrap(file, exc, fields, RobotSpec, prefix=f"{path} (robot {k})") from None
    return robots, [f"{path} (robot {k})" for k in range(len(robots))]


# --------------------------------------------------------------------------- reference


def _sections() -> list[tuple[str, type[BaseModel]]]:
    """(where in a map file, model) of every part of the format, in reading order."""
    return [
        ("top level", _MapFile),
        ("bounds", Bounds),
        ("walls[] with type: segment", SegmentWall),
        ("walls[] with type: polygon", PolygonWall),
        ("robots[]", RobotSpec),
        ("layouts[]", LayoutSpec),
        ("layouts[].robot", RobotTemplate),
        *[(f"layouts[].args with builder: {name}", model)
          for name, (model, _) in sorted(LAYOUTS.items())],
        ("traffic[]", TrafficGroup),
        ("traffic[].lane with type: circle", CircleLaneSpec),
        ("traffic[].lane with type: polyline", PolylineLaneSpec),
        ("physics", Physics),
        ("episode", Episode),
        ("sensing", Sensing),
    ]


def _kind(prop: Mapping[str, Any]) -> str:
    """A JSON-schema property as a short type text, e.g. ``number > 0`` or ``[x, y]``."""
    if "anyOf" in prop:
        return " or ".join(_kind(p) for p in prop["anyOf"] if p.get("type") != "null")
    if "oneOf" in prop:
        return f"mapping (type: {'|'.join(prop['discriminator']['mapping'])})"
    if "$ref" in prop:
        return "mapping"
    if "const" in prop:
        return str(prop["const"])
    if "enum" in prop:
        return "|".join(map(str, prop["enum"]))
    kind = prop.get("type")
    if kind == "array":
        if "prefixItems" in prop:
            return "[x, y]"
        text = f"list of {_kind(prop.get('items', {}))}"
        return text + (f" (>= {prop['minItems']})" if "minItems" in prop else "")
    if kind == "object":
        return "mapping"
    if kind in ("number", "integer"):
        limits = [f"{op} {prop[key]}" for key, op in (
            ("gt", ">"), ("exclusiveMinimum", ">"), ("ge", ">="), ("minimum", ">="),
            ("lt", "<"), ("exclusiveMaximum", "<"), ("le", "<="), ("maximum", "<="),
        ) if key in prop]
        return " ".join([kind, ", ".join(limits)]).strip()
    return {"boolean": "true|false", "string": "string"}.get(str(kind), str(kind))


def _default(model: type[BaseModel], name: str) -> str:
    info = model.model_fields[name]
    if info.is_required():
        return "required"
    value = info.get_default(call_default_factory=True)
    if value is None:
        return "optional"
    if isinstance(value, BaseModel):
        return "section below"
    if isinstance(value, bool | float | int):
        return _show(value)
    return json.dumps(value)


def _field_tables() -> str:
    """Every field of the format: name, type and default, from the models themselves."""
    out = []
    for where, model in _sections():
        props = model.model_json_schema()["properties"]
        rows = [(name, _kind(props[name]), _default(model, name)) for name in model.model_fields]
        w0 = max(len(r[0]) for r in rows)
        w1 = max(len(r[1]) for r in rows)
        out += ["", where]
        out += [f"  {a.ljust(w0)}  {b.ljust(w1)}  {c}".rstrip() for a, b, c in rows]
    return "\n".join(out)


def format_reference() -> str:
    """The map file format as plain text: the description of this module's docstring,
    then every field with its type and default, generated from the schema's models (what
    ``nao-arena maps --schema`` prints)."""
    prose = (__doc__ or "").split("\n\n", 1)[1]
    prose = re.sub(r":\w+:`~?([^`]+)`", r"\1", prose).replace("``", "`")
    head = "Every field (generated from the schema; optional: absent or null, see above)"
    return "\n".join([
        "nao-arena map files", "===================", "", prose.strip(), "",
        head, "-" * len(head) + _field_tables(),
    ])
